"""The metrics of a run from its log: ``mission.type`` -> ``xxx_metrics(log, scenario, *, wall_time_s, error)``.

Every metrics function reads the run's ``FlightLog`` (the same data as its ``log.h5``) and the resolved
scenario, never the live simulation, so a run directory, a replayed or a recorded flight is scored by the
same code: ``metrics_for(scenario)(log, scenario, wall_time_s=..., error=...)``, ``visnav metrics RUN_DIR``
(``from_run_dir``). Targets are named ("module:function") and imported on use, like
``app/missions.SIMULATION``; a new mission adds its line here (or calls ``register_metrics``).
"""

from __future__ import annotations

import importlib
import json
import math
from pathlib import Path
from typing import Callable
from visnav.io.tum import trajectory_rmse, tum_frame
from visnav.flightlog import FlightLog
from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.analysis.outcome import apply_outcome
from visnav.scenarios.schema import ScenarioError, load_scenario

MetricsFn = Callable[..., dict]

METRICS: dict[str, str] = {
    "palace": "visnav.analysis.metrics:palace_metrics",
    "hover": "visnav.analysis.metrics:hover_metrics",
    "pfcm": "visnav.analysis.path_metrics:pfcm_metrics",
    "witas-homing": "visnav.analysis.witas_metrics:witas_metrics",
    "pad-landing": "visnav.analysis.pad_report:pad_metrics",
    "mav-geolocation": "visnav.analysis.geolocation_metrics:geolocation_metrics",
    "condor": "visnav.analysis.condor_metrics:condor_metrics",
    "deck": "visnav.analysis.deck_metrics:deck_metrics",
}


class RunDirError(ValueError):
    """A run directory that cannot be scored (missing, or without a readable log.h5 / scenario.toml)."""


def register_metrics(mission_type: str, target: str | MetricsFn) -> None:
    """Name the metrics function of ``mission_type`` ("module:function", or the function itself)."""
    METRICS[mission_type] = target if isinstance(target, str) else f"{target.__module__}:{target.__qualname__}"


def metrics_function(mission_type: str) -> MetricsFn:
    """The ``xxx_metrics(log, scenario, *, wall_time_s, error)`` of ``mission_type`` (ValueError: none)."""
    target = METRICS.get(mission_type)
    if target is None:
        raise ValueError(f"no metrics from the log for mission.type {mission_type!r} yet; "
                         f"known: {', '.join(sorted(METRICS))}")
    module, name = target.split(":")
    return getattr(importlib.import_module(module), name)


def compute_metrics(log, scenario, *, wall_time_s: float = math.nan, error: str | None = None,
                    interrupted: bool = False) -> dict:
    """The metrics of ``scenario``'s mission from ``log`` (a ``FlightLog``); ``outcome`` as
    ``analysis/outcome.py`` defines it (``interrupted``: the run was stopped by Ctrl-C)."""

    out = metrics_function(scenario.mission.type)(log, scenario, wall_time_s=wall_time_s, error=error)
    out.update(integrity_metrics(log, scenario))  # issue #18: every R-MAX navigator logs its integrity
    if "ate_rmse_m" not in out and tum_frame(scenario) is not None:  # as a run's RunResult adds it (app/loop.py)
        ate = trajectory_rmse(log)
        if ate is not None:
            out["ate_rmse_m"] = ate
    if interrupted:
        out["interrupted"] = True
    return apply_outcome(out, log, scenario, interrupted)


def from_run_dir(run_dir: str | Path) -> dict:
    """Recompute the metrics of a run directory from its ``log.h5`` and ``scenario.toml``. The wall time and
    the error are the run's own (``metrics.json``, when there is one); ``RunDirError`` names what is missing."""

    d = Path(run_dir)
    if d.is_file() and d.name == "log.h5":  # the log itself: its folder is the run directory
        d = d.parent
    if not d.is_dir():
        what = "a file, not a folder" if d.exists() else "no such folder"
        raise RunDirError(f"{d}: not a run directory ({what})")
    for f in ("log.h5", "scenario.toml"):
        if not (d / f).is_file():
            raise RunDirError(f"{d}: no {f} (a run directory of `visnav run` holds log.h5 and scenario.toml)")
    try:
        sc = load_scenario(str(d / "scenario.toml"))
    except ScenarioError as exc:
        raise RunDirError(f"{d / 'scenario.toml'}: {exc}") from None
    try:
        log = FlightLog.from_hdf5(d / "log.h5")
    except (OSError, KeyError, ValueError) as exc:
        raise RunDirError(f"{d / 'log.h5'}: not a readable flight log ({exc})") from None
    wall, interrupted = math.nan, False  # the run's own wall time and Ctrl-C, when its metrics.json says
    try:
        own = json.loads((d / "metrics.json").read_text())
        interrupted = own.get("interrupted") is True
        w = own.get("wall_time_s")
        wall = float(w) if w is not None else math.nan
    except (OSError, ValueError, TypeError, AttributeError):
        pass  # no or a broken metrics.json: the metrics without the run's wall time
    err = log.get("error")  # the loop logs the exception that stopped a run
    return compute_metrics(log, sc, wall_time_s=wall, error=str(err["message"][-1]) if err else None,
                           interrupted=interrupted)
