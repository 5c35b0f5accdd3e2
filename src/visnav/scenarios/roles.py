"""Configuration by role (issue #13): what each system flies, and the translation of the older layout.

``SUITES``: per ``mission.type``, the vehicle kind, the named sensors (kind and the system's default values)
and the navigator kind its builder (``app/missions.py``) assembles. A scenario file names only what it
changes; a section the system does not fly (``sensors.sonar`` on the deck) or a kind its builder does not
take is an error naming the key and the system.

``WORLD`` / ``CONTROL``: the sections of ``[world.<thing>]`` and ``[control.<system>]`` each system has (filled
with their defaults; another system's is an error). ``MOVED``: keys that left ``[mission]`` for them (issue #31):
world content and controller gains; an old key still works (files, ``--set``) and says its new name once.

``LEGACY``: the mission-keyed layout before issue #13 kept every device of the deck, CONDOR, geo-location,
WITAS and pad systems under ``mission`` (``mission.camera``, ``mission.filter``, ...). Such files (old
``scenario.toml`` of run directories included) and ``--set`` keys are translated key by key
(``legacy_key``); a key with no translation fails with one line naming the new one.

Pure dict operations: ``schema.py`` calls ``fill_suite`` from the ``Scenario`` model.
"""

from __future__ import annotations

import copy
from typing import Any

from visnav.scenarios.base import ScenarioError

_RMAX = {"imu": {"kind": "rmax-imu"}, "gps": {"kind": "gps"}, "laser": {"kind": "laser"}, "sonar": {"kind": "sonar"},
         "camera": {"kind": "camera"}}
_FIXEDWING_AUTOPILOT = {"ahrs": {"kind": "ahrs"}, "imu": {"kind": "mems-imu"}, "pitot": {"kind": "pitot"}}

#: mission.type -> vehicle, sensors (name -> kind and the system's values), optional sensors (present only
#: when the file names them), navigation
SUITES: dict[str, dict[str, Any]] = {
    "palace": {"vehicle": {"kind": "rmax"}, "sensors": _RMAX, "navigation": {"kind": "palace"}},
    "hover": {"vehicle": {"kind": "rmax"}, "sensors": _RMAX, "navigation": {"kind": "palace"}},
    # the camera's mount carries the laser (no frames are processed on GPS)
    "pfcm": {"vehicle": {"kind": "rmax"}, "sensors": _RMAX, "navigation": {"kind": "palace"}},
    "witas-homing": {
        "vehicle": {"kind": "rmax"},
        "sensors": {"imu": {"kind": "rmax-imu"}, "gps": {"kind": "gps"},
                    # downward CCD camera, ~45 deg horizontal view, half resolution 384x288 at 25 Hz (§5.9)
                    "camera": {"kind": "camera", "width": 384, "height": 288, "focal_px": 463.0, "depression_deg": 90.0,
                               "lever_arm_m": [0.0, 0.0, 0.5], "capture_hz": 25.0, "noise_sigma": 2.0,
                               "latency_s": 0.04},
                    "baro": {"kind": "baro"}},
        "optional": {"compass": {"kind": "compass", "bias_deg": 0.5}},
        "navigation": {"kind": "witas"}},
    "pad-landing": {"vehicle": {"kind": "rmax"},
                    "sensors": {"imu": {"kind": "rmax-imu"}, "camera": {"kind": "pantilt-camera"}},
                    "navigation": {"kind": "pad"}},
    "deck": {"vehicle": {"kind": "multirotor"},
             "sensors": {"imu": {"kind": "multirotor-imu"}, "camera": {"kind": "led-camera"}},
             "navigation": {"kind": "deck"}},
    "condor": {
        "vehicle": {"kind": "fixedwing"},
        "sensors": {"camera": {"kind": "gimbal-camera"}, "gimbal": {"kind": "condor-gimbal"},
                    # eq. 2.1 altimeter (its temperature error; no Gauss-Markov bias)
                    "baro": {"kind": "baro", "rate_hz": 50.0, "sigma_m": 0.3, "bias_sigma_m": 0.0, "t_outside_c": 20.0,
                             "t_measured_c": 20.0, "c0": 0.0004, "c1": 0.000005},
                    "link": {"kind": "link"}, **_FIXEDWING_AUTOPILOT, "compass": {"kind": "compass"},
                    "gps": {"kind": "gps", "rate_hz": 5.0, "sigma_m": 1.0, "velocity_sigma_mps": 0.1, "latency_s": 0.1}},
        "navigation": {"kind": "condor"}},
    "mav-geolocation": {
        "vehicle": {"kind": "mav"},
        "sensors": {"camera": {"kind": "mav-camera"}, "gimbal": {"kind": "mav-gimbal"},
                    "telemetry": {"kind": "mav-telemetry"}, **_FIXEDWING_AUTOPILOT},
        "navigation": {"kind": "geolocation"}},
}


#: mission.type -> the world's sub-sections ([world.<thing>]) and the controller sections ([control.<system>]) its
#: simulation reads; present (at their defaults) exactly for it
WORLD: dict[str, tuple[str, ...]] = {"deck": ("deck",), "witas-homing": ("witas_map",), "pad-landing": ("pad",),
                                     "condor": ("tent",), "mav-geolocation": ("geo_map", "truck")}
CONTROL: dict[str, tuple[str, ...]] = {"deck": ("deck",), "condor": ("condor",), "mav-geolocation": ("mav",),
                                       "pfcm": ("pfcm",)}


def _deep_merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        out[k] = _deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _kind_of(v: Any) -> Any:
    return v.get("kind") if isinstance(v, dict) else getattr(v, "kind", None)


def _fill(key: str, given: Any, default: dict, mission_type: str) -> Any:
    kind = _kind_of(given)
    if kind is not None and kind != default["kind"]:
        raise ScenarioError(f"{key}.kind {kind!r} does not fit mission.type {mission_type!r} (its builder flies "
                            f"{key}.kind = {default['kind']!r})")
    if given is None:
        return copy.deepcopy(default)
    return _deep_merge(default, given) if isinstance(given, dict) else given


def mission_type_of(data: dict) -> str:
    m = data.get("mission")
    t = m.get("type", "palace") if isinstance(m, dict) else getattr(m, "type", "palace")
    return t if isinstance(t, str) else "palace"


def fill_suite(data: dict) -> dict:
    """``data`` with the vehicle, sensors and navigation of its mission type's suite: kinds and the system's
    default values under what the file gives. An unknown mission type is left to the schema's error."""
    if isinstance(data.get("mission"), dict):
        data["mission"].setdefault("type", "palace")
    mtype = mission_type_of(data)
    suite = SUITES.get(mtype)
    if suite is None:
        return data
    data = dict(data)
    for section, have in (("world", WORLD.get(mtype, ())), ("control", CONTROL.get(mtype, ()))):
        given = data.get(section, {})
        if hasattr(given, "model_dump"):  # a WorldConfig / ControlConfig object: checked and filled the same way
            given = given.model_dump(exclude_none=True)
        if not isinstance(given, dict):
            continue  # a bad value: the schema reports it
        known = {n for names in (WORLD if section == "world" else CONTROL).values() for n in names}
        extra = [n for n in given if n in known and n not in have and given[n] is not None]
        if extra:
            raise ScenarioError(f"{section}.{extra[0]} does not apply to mission.type {mtype!r} (its {section} "
                                f"sections: {', '.join(section + '.' + h for h in have) or 'none'})")
        data[section] = {**given, **{h: given.get(h) or {} for h in have}}
    for role in ("vehicle", "navigation"):
        data[role] = _fill(role, data.get(role), suite[role], mtype)
    given = data.get("sensors")
    given = getattr(given, "root", given) or {}
    if not isinstance(given, dict):
        return data  # the schema says what is wrong
    have = {**suite["sensors"], **suite.get("optional", {})}
    extra = [n for n in given if n not in have]
    if extra:
        raise ScenarioError(f"sensors.{extra[0]} does not apply to mission.type {mtype!r} (its sensors: "
                            f"{', '.join(have)})")
    sensors = {}
    for name, default in have.items():
        if name in suite["sensors"] or name in given:
            sensors[name] = _fill(f"sensors.{name}", given.get(name), default, mtype)
    data["sensors"] = sensors
    return data


# ----------------------------------------------------------------------------------------------------------
# The mission-keyed layout before issue #13: old dotted prefix -> new one, per mission type (longest first).
_R = "rmax"
LEGACY: dict[str, list[tuple[str, str]]] = {
    "deck": [("mission.vehicle", "vehicle"), ("mission.camera", "sensors.camera"), ("mission.imu", "sensors.imu"),
             ("mission.filter", "navigation")],
    "condor": [("mission.airframe", "vehicle"), ("mission.camera", "sensors.camera"), ("mission.gimbal", "sensors.gimbal"),
               ("mission.altimeter.noise_m", "sensors.baro.sigma_m"), ("mission.altimeter", "sensors.baro"),
               ("mission.link", "sensors.link"), ("mission.gps_noise_m", "sensors.gps.sigma_m"),
               ("mission.sensors.gps.velocity_noise_mps", "sensors.gps.velocity_sigma_mps"),
               ("mission.sensors", "sensors"), ("mission.vision", "navigation.vision"),
               ("mission.navigation", "navigation")],
    "mav-geolocation": [("mission.airframe", "vehicle"), ("mission.camera", "sensors.camera"),
                        ("mission.gimbal", "sensors.gimbal"), ("mission.telemetry", "sensors.telemetry"),
                        ("mission.sensors.gps.velocity_noise_mps", "sensors.gps.velocity_sigma_mps"),
                        ("mission.sensors", "sensors"), ("mission.registration", "navigation")],
    "witas-homing": [("mission.camera", "sensors.camera"), ("mission.baro", "sensors.baro"),
                     ("mission.compass.sigma_deg", "sensors.compass.noise_deg"), ("mission.compass", "sensors.compass"),
                     ("mission.filter", "navigation")],
    "pad-landing": [("mission.camera", "sensors.camera"), ("mission.pantilt", "sensors.camera.pantilt"),
                    ("mission.platform", "sensors.camera.platform"), ("mission.filter", "navigation")],
}
for _t in ("palace", "hover", "pfcm", "witas-homing", "pad-landing"):
    LEGACY.setdefault(_t, []).insert(0, ("vehicle.model", "vehicle.kind"))
LEGACY["deck"] += [("vehicle.model", "")]  # the R-MAX's tag, written into every old resolved scenario.toml
LEGACY["condor"] += [("vehicle.model", "")]
LEGACY["mav-geolocation"] += [("vehicle.model", "")]


#: keys the old layout accepted and the system never read: dropped at these (their old defaults), one line
#: otherwise (the geo-location MAV's autopilot GPS and compass: its telemetry carries the GPS)
LEGACY_UNREAD: dict[str, dict[str, Any]] = {
    "mav-geolocation": {"mission.sensors.gps.rate_hz": 5.0, "mission.sensors.gps.latency_s": 0.1,
                        "mission.sensors.gps.velocity_noise_mps": 0.1, "mission.sensors.compass.rate_hz": 10.0,
                        "mission.sensors.compass.noise_deg": 1.0, "mission.sensors.compass.bias_deg": 2.0},
}


def _leaves(data: Any, path: tuple[str, ...] = ()):
    if isinstance(data, dict) and data:
        for k, v in data.items():
            yield from _leaves(v, path + (str(k),))
    elif path:
        yield path, data


def _match(key: str, prefix: str) -> bool:
    return key == prefix or key.startswith(prefix + ".")


def legacy_key(key: str, mission_type: str) -> str | None:
    """The new dotted key of an old one (None: not an old key; "": dropped, the old R-MAX tag)."""
    for old, new in LEGACY.get(mission_type, ()):
        if _match(key, old):
            return new + key[len(old):] if new else ""
    return None


def is_legacy(data: dict) -> bool:
    mtype = mission_type_of(data)
    return any(legacy_key(".".join(p), mtype) is not None for p, _ in _leaves(data) if p[0] in ("mission", "vehicle"))


def _fixed_wing() -> list[tuple[str, str]]:
    return [("vehicle", "its aircraft is vehicle.*, kind 'fixedwing' or 'mav'"),
            ("sensors", "its sensors are sensors.* of its own kinds (visnav keys SCENARIO)"),
            ("navigation", "its navigator is navigation.*, of its own kind")]


#: the R-MAX sections of the old layout that a system did not fly (what schema.NOT_APPLICABLE said before
#: issue #13): an old file that sets one of them off its default fails with this line
LEGACY_NOT_APPLICABLE: dict[str, list[tuple[str, str]]] = {
    "deck": [("vehicle", "its vehicle is vehicle.*, kind 'multirotor'"),
             ("sensors.imu", "its IMU is sensors.imu.*, kind 'multirotor-imu'"),
             ("sensors.camera", "its camera is sensors.camera.*, kind 'led-camera'"),
             ("sensors", "its sensors are sensors.imu.* and sensors.camera.*"),
             ("navigation", "its filter is navigation.*, kind 'deck'")],
    "condor": _fixed_wing(),
    "mav-geolocation": _fixed_wing(),
    "witas-homing": [("navigation", "its navigator is navigation.*, kind 'witas'"),
                     ("sensors.camera", "its camera is sensors.camera.* (the mission.camera.* of the old layout)"),
                     ("sensors.laser", "its navigator takes no range measurement"),
                     ("sensors.sonar", "its navigator takes no range measurement")],
    "pad-landing": [("navigation", "its navigator is navigation.*, kind 'pad'"),
                    ("sensors.camera", "its camera is sensors.camera.*, kind 'pantilt-camera'"),
                    ("sensors.imu.rate_hz", "its IMU rates are navigation.gyro_hz and navigation.accel_hz"),
                    ("sensors.gps", "it flies GPS-free"),
                    ("sensors.laser", "its navigator takes no range measurement"),
                    ("sensors.sonar", "its navigator takes no range measurement")],
    "pfcm": [("navigation.tracker", "it flies on GPS: no camera, no tracker"),
             ("navigation.mpe", "it flies on GPS: no camera, no MPE")],
}


def legacy_not_applicable(key: str, mission_type: str) -> str | None:
    for prefix, hint in LEGACY_NOT_APPLICABLE.get(mission_type, ()):
        if _match(key, prefix):
            return hint
    return None


def _set(data: dict, path: list[str], value: Any) -> None:
    node = data
    for p in path[:-1]:
        node = node.setdefault(p, {})
    node[path[-1]] = value


def migrate(data: dict, rmax_defaults: dict[str, Any]) -> dict:
    """Translate a file in the mission-keyed layout (``is_legacy``). Its R-MAX sections that the system does
    not fly (every old resolved ``scenario.toml`` holds them at their defaults) are dropped at their default
    and an error (the old one line) otherwise; ``mission.compass.enabled`` becomes the compass's presence."""
    mtype = mission_type_of(data)
    leaves = list(_leaves(data))
    out: dict = {}
    compass_on = None
    for path, value in leaves:
        key = ".".join(path)
        if key == "mission.compass.enabled" and mtype == "witas-homing":
            compass_on = bool(value)
            continue
        unread = LEGACY_UNREAD.get(mtype, {})
        if key in unread:
            if unread[key] == value:
                continue
            raise ScenarioError(f"{key} does not apply to mission.type {mtype!r} (its simulation never read it: "
                                f"its sensors are {', '.join(SUITES[mtype]['sensors'])})")
        new = legacy_key(key, mtype)
        if new == "":
            continue
        if new is None and path[0] in ("vehicle", "sensors", "navigation") and key in rmax_defaults:
            section = data.get(path[0], {}) if path[0] != "sensors" else data["sensors"].get(path[1], {})
            hint = None if isinstance(section, dict) and "kind" in section else legacy_not_applicable(key, mtype)
            if hint is not None:  # an R-MAX section of the old layout that this system does not fly
                if rmax_defaults[key] == value:
                    continue
                raise ScenarioError(f"{key} does not apply to mission.type {mtype!r} ({hint})")
        _set(out, (new or key).split("."), value)
    if compass_on is False:
        out.get("sensors", {}).pop("compass", None)
    elif compass_on:
        out.setdefault("sensors", {}).setdefault("compass", {})
    return out


# ----------------------------------------------------------------------------------------------------------
# Issue #31: world content and controller gains left [mission]: old dotted key (or prefix) -> new, per mission
# type, first match wins (single keys before their section).
_DECK_GAINS = ("k_static", "k_rho", "k_alpha_beta", "spring_per_s2", "damper_per_s", "feedforward_lead_s")
_ORBIT_GAINS = ("logic", "kp_original", "kd_original", "kp_modified", "kd_modified", "base_limit")
MOVED: dict[str, list[tuple[str, str]]] = {
    "deck": [("mission.deck", "world.deck")]
    + [(f"mission.guidance.{k}", f"control.deck.{k}") for k in _DECK_GAINS],
    "witas-homing": [("mission.map", "world.witas_map")],
    "pad-landing": [("mission.pad", "world.pad")],
    "condor": [("mission.target", "world.tent")]
    + [(f"mission.control.orbit.{k}", f"control.condor.orbit.{k}") for k in _ORBIT_GAINS]
    + [("mission.control.orbit", "mission.orbit"), ("mission.control.altitude_m", "mission.altitude_m"),
       ("mission.control", "control.condor")],
    "mav-geolocation": [("mission.map", "world.geo_map"), ("mission.target.click_sigma_px", "mission.click_sigma_px"),
                        ("mission.target", "world.truck"), ("mission.control.l1_m", "control.mav.l1_m"),
                        ("mission.control.bank_limit_deg", "control.mav.bank_limit_deg"),
                        ("mission.control", "mission")],
    "pfcm": [(f"mission.{k}", f"control.pfcm.{k}") for k in ("iterations", "roll_integral", "roll_compensator",
                                                              "roll_margin_deg")],
}

#: the messages already given in this process (each old key is named once, not once per run of a campaign)
_SAID: set[str] = set()


def moved_key(key: str, mission_type: str) -> str | None:
    """The key's place since issue #31 (None: it did not move)."""
    for old, new in MOVED.get(mission_type, ()):
        if _match(key, old):
            return new + key[len(old):]
    return None


def move(data: dict, say=None) -> dict:
    """``data`` with the keys of ``MOVED`` at their new place; ``say(line)`` gets one line per old key (once per
    process): "mission.deck.motion is now world.deck.motion". A key given in both places takes the old key's value
    (``--set mission.deck.motion=moving`` on a file in the new layout sets it)."""
    mtype = mission_type_of(data)
    if mtype not in MOVED or not isinstance(data.get("mission"), dict):
        return data
    out: dict = {}
    moved: list[tuple[tuple[str, ...], Any]] = []
    for path, value in _leaves(data):
        new = moved_key(".".join(path), mtype)
        if new is None:
            _set(out, list(path), value)
        else:
            moved.append((tuple(new.split(".")), value))
            line = f"{'.'.join(path)} is now {new}"
            if say is not None and line not in _SAID:
                _SAID.add(line)
                say(line)
    for path, value in moved:
        _set(out, list(path), value)
    return out
