"""Run metrics, computed from the flight log (truth enters here, never the navigator).

Every ``xxx_metrics(log, scenario, *, wall_time_s, error)`` reads only the run's ``FlightLog`` (the same
data as its ``log.h5``) and the resolved scenario, never the live simulation, so that a run directory, a
replayed or a recorded flight is scored by the same code (``analysis/run_metrics.py``, ``visnav metrics``).
"""

from __future__ import annotations

import math

import numpy as np
from visnav.analysis.drift import measure_drift

def interp_rows(t_query, t, values) -> np.ndarray:
    """Linear interpolation of each column of ``values`` (N,k) at ``t_query``."""
    values = np.asarray(values, float)
    tq = np.atleast_1d(np.asarray(t_query, float))
    return np.stack([np.interp(tq, t, values[:, j]) for j in range(values.shape[1])], axis=-1)


def finish_metrics(out: dict, sim_time_s: float, wall_time_s: float, error: str | None) -> dict:
    """The keys every run reports: sim_time_s, wall_time_s, real_time_factor (and error, if any)."""
    out["sim_time_s"] = float(sim_time_s)
    out["wall_time_s"] = float(wall_time_s)
    out["real_time_factor"] = float(sim_time_s / wall_time_s) if wall_time_s > 0 else float("nan")
    if error:
        out["error"] = error
    return out


def mode_changes(log) -> tuple[np.ndarray, list[str]]:
    """(times, modes) of the mission's mode changes (its ``mode`` stream)."""
    m = log.get("mode")
    if not m:
        return np.zeros(0), []
    return np.asarray(m["t"], float), [str(x) for x in m["mode"]]


def final_mode(log) -> str:
    """The mission's last mode: its last mode change, else the mode it logged at its first step."""
    _, modes = mode_changes(log)
    if modes:
        return modes[-1]
    st = log.get("status")
    return str(st["mode"][0]) if st else ""


def mode_entered(log, mode: str, which: str = "first") -> float | None:
    """Time the mission entered ``mode`` (its ``first`` or ``last`` entry), None if it never did."""
    t, modes = mode_changes(log)
    hits = [float(x) for x, m in zip(t, modes) if m == mode]
    return (hits[0] if which == "first" else hits[-1]) if hits else None


def last_row(log, stream: str, name: str, default=math.nan):
    """Last value of ``stream.name`` (``default`` when the stream never recorded)."""
    s = log.get(stream)
    return s[name][-1] if s and name in s else default


def _count(x) -> int | float:
    """An integer counter, or NaN when the log did not hold it."""
    x = float(x)
    return int(x) if math.isfinite(x) else math.nan


def mpe_drift(log, horizontal: bool = True) -> tuple[float, np.ndarray]:
    """Cumulative MPE drift (seed 000 §5.4).

    At every (re-)initialisation i of the ground reference the drift vector d_i = MPE - truth just
    before it is banked, and the error j_i the new reference starts with (GPS noise, or the drift
    inherited when re-basing on MPE's own estimate) is taken off; the final MPE - truth difference
    is added: drift = | sum_i (d_i - j_i) + final |.
    """
    truth = log.get("truth")
    mpe = log.get("mpe")
    inits = log.get("track_init")
    if not mpe or not truth:
        return float("nan"), np.full(3, np.nan)
    tt, tp = truth["t"], truth["position"]
    mt, mp = mpe["t"], mpe["position"]
    total = np.zeros(3)
    if inits:
        for ti, pi in zip(inits["t"], inits["init_position"]):
            before = np.nonzero(mt < ti - 1e-9)[0]
            if before.size:
                k = before[-1]
                total += mp[k] - interp_rows(mt[k], tt, tp)[0]
            total -= np.asarray(pi) - interp_rows(ti, tt, tp)[0]
    k = len(mt) - 1
    total += mp[k] - interp_rows(mt[k], tt, tp)[0]
    if horizontal:
        total[2] = 0.0
    return float(np.linalg.norm(total)), total


def _mode_mask(log, t: np.ndarray, mode: str, settle_s: float) -> np.ndarray:
    """Samples at times ``t`` that lie in any segment of ``mode``, ``settle_s`` after it began."""
    modes = log.get("mode")
    mask = np.zeros(t.shape, dtype=bool)
    if not modes:
        return mask
    starts = list(modes["t"]) + [np.inf]
    for i, m in enumerate(modes["mode"]):
        if m == mode:
            mask |= (t >= starts[i] + settle_s) & (t < starts[i + 1])
    return mask


def hover_oscillation(log, mode: str = "hold", settle_s: float = 1.0) -> dict:
    """Oscillation while hovering on MPE (the §5.1 delay experiment): horizontal RMS of truth about
    its mean, roll/pitch RMS, over every segment of ``mode`` (the MPE hold at the switch height)."""
    truth = log.get("truth")
    if not truth:
        return {}
    sel = _mode_mask(log, truth["t"], mode, settle_s)
    if sel.sum() < 5:
        return {}
    p = truth["position"][sel, :2]
    e = np.rad2deg(truth["euler"][sel, :2])
    return {
        "hover_pos_rms_m": float(np.sqrt(np.mean(np.sum((p - p.mean(0)) ** 2, axis=1)))),
        "hover_attitude_rms_deg": float(np.sqrt(np.mean(np.sum((e - e.mean(0)) ** 2, axis=1)))),
        "hover_time_s": float(sel.sum() * np.median(np.diff(truth["t"]))),
    }


def palace_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    """The PALACE landing (seed 000 §5.4): touch-down, MPE drift and accuracy, vision time, the mission's
    re-initialisations and fall-backs (its ``palace_progress`` stream), the navigator's rejections (``status``)."""
    truth = log.get("truth")
    sim_time = float(truth["t"][-1]) if truth else 0.0
    td = log.get("touchdown")
    aborted = mode_entered(log, "abort") is not None
    landed = bool(td) and not aborted and error is None
    point = np.array([*scenario.mission.landing_point_m[:2], 0.0])
    out: dict = {
        "landed": landed,
        "aborted": aborted,
        "touchdown_error_m": float(np.linalg.norm(td["position"][0][:2] - point[:2])) if td else float("nan"),
        "touchdown_speed_mps": float(td["speed"][0]) if td else float("nan"),
    }
    drift, vec = mpe_drift(log)
    out["mpe_drift_m"] = drift
    mpe_t = (log.get("mpe") or {}).get("t")
    # the time the drift accumulated over (Table 5.3's "Duration": first MPE fix to the last)
    out["mpe_drift_duration_s"] = float(mpe_t[-1] - mpe_t[0]) if mpe_t is not None and len(mpe_t) else float("nan")
    # NaN, not 0, from a log without the stream (a log written before it existed): unknown, not none
    out["time_under_vision_s"] = float(last_row(log, "palace_progress", "vision_time"))
    out["reinitializations"] = _count(last_row(log, "palace_progress", "reinitializations"))
    out["mpe_fallbacks"] = _count(last_row(log, "palace_progress", "fallbacks"))
    # MPE accuracy while it flew the aircraft
    mpe, est = log.get("mpe"), log.get("estimate")
    if mpe and truth:
        err = mpe["position"] - interp_rows(mpe["t"], truth["t"], truth["position"])
        h = np.linalg.norm(err[:, :2], axis=1)
        out["mpe_error_rms_m"] = float(np.sqrt(np.mean(h**2)))
        out["mpe_error_max_m"] = float(h.max())
    if est and truth:
        on_mpe = est["source"] == "mpe"
        if on_mpe.any():
            e = est["position"][on_mpe, :2] - truth["position"][on_mpe, :2]
            out["nav_error_under_mpe_rms_m"] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    out.update(hover_oscillation(log))
    out["rejected_samples"] = _count(last_row(log, "status", "rejected_samples"))
    out["rejected_ranges"] = _count(last_row(log, "status", "rejected_ranges"))
    out["final_mode"] = final_mode(log)
    return finish_metrics(out, sim_time, wall_time_s, error)


def hover_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    """Metrics of a hover mission: the §4.2.1 drift of MPE (open or closed loop) during the hold."""

    cfg = scenario.mission
    truth, mpe = log.get("truth"), log.get("mpe")
    _, modes = mode_changes(log)
    out: dict = {"altitude_m": float(cfg.altitude_m), "surface": scenario.world.surface,
                 "source": cfg.source, "tracker_lost": "lost" in modes}
    t_hold = mode_entered(log, "hold", "last")  # HoverMission.t_hold: its last entry into the hold
    if mpe and truth and t_hold is not None:
        sel = mpe["t"] >= t_hold
        if sel.sum() > 20:
            t = mpe["t"][sel]
            err = mpe["position"][sel] - interp_rows(t, truth["t"], truth["position"])
            fx = float(scenario.sensors.camera.focal_px)  # PinholeCamera.ideal: fx = fy = focal_px
            r = measure_drift(t, err[:, :2], mpe["range"][sel], fx)
            out.update(drift_m=r.drift_m, drift_px=r.drift_px, drift_duration_s=r.duration_s,
                       mpe_noise_sigma_m=r.noise_sigma_m, mean_range_m=float(np.mean(mpe["range"][sel])))
    out.update(hover_oscillation(log))
    return finish_metrics(out, float(truth["t"][-1]) if truth else 0.0, wall_time_s, error)
