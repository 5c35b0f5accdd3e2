"""Metrics of the geo-location flights (seed 002 ch. 7), from the navigator's samples and the truth."""

from __future__ import annotations

import math

import numpy as np

from visnav.analysis.metrics import finish_metrics



def _stays_below(err: np.ndarray, limit: float) -> float:
    """Number of samples after which ``err`` stays below ``limit`` for good (NaN if it never does)."""
    if err.size == 0 or not np.isfinite(err[-1]) or err[-1] >= limit:
        return math.nan
    bad = np.nonzero(~(err < limit))[0]
    return float(bad[-1] + 2) if bad.size else 1.0


def sample_table(nav, target) -> dict[str, np.ndarray]:
    """Per-sample arrays: registration and map-based errors, RLS errors after each sample."""
    s = nav.samples
    tgt = np.asarray(target, float)[:2]

    def col(k):
        return np.array([x[k] for x in s]) if s else np.zeros((0, 2))

    out = {k: col(k) for k in ("reg", "map", "est_reg", "est_map")}
    out["t"] = np.array([x["t"] for x in s], float)
    for k in ("ok", "reg_used", "map_used", "hough_applied"):
        out[k] = np.array([x[k] for x in s], bool)
    for k in ("quality", "peak", "heading_tel", "heading_used"):
        out[k] = np.array([x[k] for x in s], float)
    for k in ("reg", "map", "est_reg", "est_map"):
        out[k + "_err"] = np.linalg.norm(out[k] - tgt, axis=1) if len(s) else np.zeros(0)
    return out


def geolocation_metrics(sim, wall_time_s: float, error: str | None = None) -> dict:
    nav, cfg = sim.nav, sim.cfg
    tab = sample_table(nav, sim.target)
    ok = tab["ok"]
    reg_err = tab["reg_err"][ok]
    fm = cfg.registration.false_match_m
    est = nav.estimate(0.0)
    est_m = nav.estimate(0.0, "map_based")
    out = {
        "target_error_m": float(np.linalg.norm(est.position - sim.target)) if est.valid else math.nan,
        "map_based_error_m": float(np.linalg.norm(est_m.position - sim.target)) if est_m.valid else math.nan,
        "samples": int(ok.sum()),
        "false_match_rate": float(np.mean(reg_err > fm)) if reg_err.size else math.nan,
        "samples_to_3m": _stays_below(tab["est_reg_err"][ok], 3.0),
        "single_frame_error_median_m": float(np.median(reg_err)) if reg_err.size else math.nan,
        "map_based_sample_error_median_m": float(np.median(tab["map_err"])) if tab["map_err"].size else math.nan,
        "registration_failures": int((~ok).sum()),
        "samples_rejected": int(nav.rls["registration"].rejected),
        "rls_restarts": int(nav.rls["registration"].reinits),
        "hough_applied_rate": float(np.mean(tab["hough_applied"][ok])) if ok.any() else math.nan,
        "frames": len(sim.frames),
        "frames_target_visible": int(sum(v for _, v, _ in sim.frames)),
        "frames_tracked": int(nav.frames_tracked),
        "target_sigma_m": float(math.sqrt(max(np.trace(est.covariance), 0.0))) if est.valid else math.nan,
    }
    yaw_err = _heading_error_deg(sim.log)
    out["heading_error_rms_deg"], out["heading_error_max_deg"] = yaw_err
    return finish_metrics(out, getattr(sim, "sim_time", math.nan), wall_time_s, error)


def _heading_error_deg(log) -> tuple[float, float]:
    """Telemetry (GPS course) heading minus the aircraft's yaw: the error the image rotation starts from."""
    tel = log.get("telemetry")
    if not tel:
        return math.nan, math.nan
    d = np.degrees((tel["heading"] - tel["true_yaw"] + np.pi) % (2 * np.pi) - np.pi)
    return float(np.sqrt(np.mean(d * d))), float(np.max(np.abs(d)))
