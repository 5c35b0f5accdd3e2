"""Every settable key of a scenario (``visnav keys``): value, unit, allowed range and description,
read from the pydantic schema (the same models that validate ``--set``)."""

from __future__ import annotations

import re
from typing import Any

from pydantic import BaseModel

from visnav.scenarios.schema import Scenario, SensorsConfig, _optional, describe_field, not_applicable

# field-name suffix -> unit (longest first: ``_deg_s`` before ``_s``)
_SUFFIX_UNITS = (
    ("_deg_s", "deg/s"), ("_rad_s", "rad/s"), ("_mps2", "m/s^2"), ("_m_s2", "m/s^2"), ("_mps", "m/s"),
    ("_m_s", "m/s"), ("_deg", "deg"), ("_rad", "rad"), ("_hz", "Hz"), ("_rps", "rad/s"), ("_px", "px"),
    ("_db", "dB"), ("_pct", "%"), ("_ms", "ms"), ("_km", "km"), ("_kg", "kg"), ("_ga", "gauss"),
    ("_c", "degC"), ("_m", "m"), ("_s", "s"),
)
# a unit the description starts with ("m/s^2 per sample, 1 sigma", "YACS units", "grey levels")
_DESC_UNIT = re.compile(r"^(m/s\^2|m/s|rad/s\^?2?|rad/s|deg/s|rad|deg|m|s|Hz|px|YACS units|grey levels)\b")


def unit_of(name: str, description: str = "") -> str:
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    m = _DESC_UNIT.match(description or "")
    return m.group(1) if m else ""


def _plain(v: Any) -> Any:
    if isinstance(v, BaseModel):
        return v.model_dump()
    return v


def settable_keys(sc: Scenario) -> list[dict]:
    """One dict per leaf key of ``sc`` that its mission reads (dotted ``key``, this scenario's ``value``, the
    schema's ``default``, ``unit``, ``allowed``, ``description``), in schema order; keys its simulation
    ignores (``schema.NOT_APPLICABLE``) and the role tags (``kind``, fixed by the mission type's suite) are left
    out."""
    mission_type = getattr(sc.mission, "type", "palace")
    rows: list[dict] = []

    def walk(model: BaseModel, path: list[str]) -> None:
        for name, f in type(model).model_fields.items():
            value = getattr(model, name)
            loc = path + [name]
            if name == "kind" and len(path) <= 2 and path[:1] in (["vehicle"], ["navigation"], ["sensors"]):
                continue
            if isinstance(value, SensorsConfig):
                for sname, sensor in value.items():
                    walk(sensor, loc + [sname])
                continue
            if isinstance(value, BaseModel):
                walk(value, loc)
                continue
            sub = _optional(f.annotation)
            if value is None and isinstance(sub, type) and issubclass(sub, BaseModel):
                continue  # another system's [world.<thing>] / [control.<system>] section

            if not_applicable(".".join(loc), mission_type) is not None:
                continue
            default = None if f.default_factory is not None else f.default
            if f.default_factory is not None:
                try:
                    default = f.default_factory()
                except TypeError:  # factories that take the validated data
                    default = None
            desc = f.description or ""
            allowed = describe_field(type(model), name).removeprefix("allowed: ")
            rows.append({"key": ".".join(loc), "value": _plain(value), "default": _plain(default),
                         "unit": unit_of(name, desc), "allowed": allowed, "description": desc})

    walk(sc, [])
    return rows
