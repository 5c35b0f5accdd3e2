"""Metrics of the CONDOR runs (seed 004), from the flight log (truth included) and the resolved scenario:
the same function scores a live run and a ``log.h5`` read back."""

from __future__ import annotations

import math

import numpy as np

from visnav.analysis.metrics import finish_metrics

KEYS = ("radius_est_error_rms_pct", "radius_est_error_max_pct", "orbit_radius_error_rms_m",
        "orbit_radius_error_max_m", "tracking_lost_s")


def _ground_summary(g) -> dict:
    """Per-method error statistics of the ground test from its ``ground_test`` stream."""
    out = {}
    for k in ("thesis", "ours", "configured"):
        e = np.asarray(g[f"{k}_error_pct"], float)
        a = np.abs(e)
        ok = np.isfinite(a)
        out[f"{k}_mean_abs_error_pct"] = float(np.mean(a[ok])) if ok.any() else math.nan
        out[f"{k}_max_abs_error_pct"] = float(np.max(a[ok])) if ok.any() else math.nan
        out[f"{k}_rms_error_pct"] = float(np.sqrt(np.mean(a[ok] ** 2))) if ok.any() else math.nan
        out[f"{k}_invalid"] = int(np.count_nonzero(~ok))
    return out


def _switched_at(log) -> float | None:
    m = log.get("mode")
    if m:
        for t, mode in zip(m["t"], m["mode"]):
            if str(mode) == "vision_orbit":
                return float(t)
    return None


def condor_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    """Metrics of a CONDOR run from its flight log (the same data as ``log.h5``) and the resolved scenario."""
    cfg = scenario.mission
    out: dict = {k: math.nan for k in KEYS}
    out["controller"] = "none (static camera)" if cfg.experiment == "ground_test" else scenario.control.condor.orbit.logic
    sim_time = 0.0
    if cfg.experiment == "ground_test":
        g = log.get("ground_test")
        if g and len(g["t"]):
            s = _ground_summary(g)
            out["radius_est_error_rms_pct"] = s["configured_rms_error_pct"]
            out["radius_est_error_max_pct"] = s["configured_max_abs_error_pct"]
            out["tracking_lost_s"] = 0.0
            out.update({k: v for k, v in s.items() if not k.startswith("configured_")})
        return finish_metrics(out, math.nan, wall_time_s, error)  # a static test: no simulated time
    vis, tr = log.get("vision"), log.get("truth")
    if tr:
        sim_time = float(tr["t"][-1])
    t0 = _switched_at(log)
    out["switched_at_s"] = math.nan if t0 is None else float(t0)
    if vis:
        t = vis["t"]
        after = t >= (t0 if t0 is not None else np.inf)
        ok = vis["valid"].astype(bool) & after
        if ok.any():
            e = 100.0 * (vis["radius"][ok] / vis["true_radius"][ok] - 1.0)
            out["radius_est_error_rms_pct"] = float(np.sqrt(np.mean(e**2)))
            out["radius_est_error_max_pct"] = float(np.abs(e).max())
            out["radius_est_error_mean_pct"] = float(np.mean(e))
        frame_dt = 1.0 / scenario.sensors.camera.frame_hz
        out["tracking_lost_s"] = float(np.count_nonzero(~vis["tracked"].astype(bool)) * frame_dt)
        out["vision_valid_fraction"] = float(np.mean(vis["valid"].astype(bool)))
    if tr and t0 is not None:
        sel = tr["t"] >= t0 + cfg.orbit.transition_s
        if sel.any():
            p = tr["position"][sel]
            target = np.array([scenario.world.tent.north_m, scenario.world.tent.east_m])
            r = np.hypot(p[:, 0] - target[0], p[:, 1] - target[1])
            e = r - cfg.orbit.radius_m
            out["orbit_radius_error_rms_m"] = float(np.sqrt(np.mean(e**2)))
            out["orbit_radius_error_max_m"] = float(np.abs(e).max())
            out["orbit_radius_mean_m"] = float(r.mean())
            # the orbit's centre (least-squares circle fit) against the tent: the downwind drift
            A = np.column_stack([2 * p[:, 0], 2 * p[:, 1], np.ones(len(p))])
            c = np.linalg.lstsq(A, p[:, 0] ** 2 + p[:, 1] ** 2, rcond=None)[0]
            out["orbit_centre_offset_m"] = float(np.hypot(c[0] - target[0], c[1] - target[1]))
            out["max_bank_deg"] = float(np.degrees(np.abs(tr["euler"][sel, 0]).max()))
            out["altitude_error_rms_m"] = float(np.sqrt(np.mean((-p[:, 2] - cfg.altitude_m) ** 2)))
    es = log.get("estimate")
    if es and tr and t0 is not None:
        ok = es["valid"].astype(bool) & (es["t"] >= t0)
        if ok.any():  # eq. 3.24 relative position (range + bearing) against truth, horizontal
            d = es["position"][ok, :2] - tr["position"][ok, :2]
            out["position_est_error_rms_m"] = float(np.sqrt(np.mean(np.sum(d**2, axis=1))))
    up = log.get("uplink")
    if up and len(up["t"]):
        out["link_drop_fraction"] = float(1.0 - np.mean(np.asarray(up["delivered"], bool)))
    return finish_metrics(out, sim_time, wall_time_s, error)
