"""Metrics of the geo-location flights (seed 002 ch. 7), from the flight log (the navigator's samples and
final estimate, truth) and the resolved scenario: a ``log.h5`` read back scores the same."""

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


def sample_table(log, target) -> dict[str, np.ndarray]:
    """Per-sample arrays from the log's ``sample`` stream: registration and map-based errors, RLS errors
    after each sample."""
    s = log.get("sample")
    tgt = np.asarray(target, float)[:2]
    n = len(s["t"]) if s else 0
    out = {k: (np.asarray(s[k], float).reshape(n, 2) if n else np.zeros((0, 2))) for k in ("reg", "map", "est_reg", "est_map")}
    out["t"] = np.asarray(s["t"], float) if n else np.zeros(0)
    for k, src in (("ok", "ok"), ("reg_used", "reg_used"), ("hough_applied", "hough")):
        out[k] = np.asarray(s[src], bool) if n else np.zeros(0, bool)
    for k in ("quality", "peak", "heading_tel", "heading_used"):
        out[k] = np.asarray(s[k], float) if n else np.zeros(0)
    for k in ("reg", "map", "est_reg", "est_map"):
        out[k + "_err"] = np.linalg.norm(out[k] - tgt, axis=1) if n else np.zeros(0)
    return out


def geolocation_metrics(log, scenario, wall_time_s: float, error: str | None = None) -> dict:
    """Metrics of a geo-location run from its flight log (``log.h5``) and the resolved scenario."""
    cfg = scenario.mission
    tg = log.get("target")
    target = np.asarray(tg["position"][0], float)[:2] if tg else np.full(2, np.nan)
    tab = sample_table(log, target)
    ok = tab["ok"]
    reg_err = tab["reg_err"][ok]
    fm = cfg.registration.false_match_m
    res = log.get("result")
    fr = log.get("frame")

    def last(k, default=math.nan):
        return res[k][-1] if res and len(res["t"]) else default

    reg_valid, map_valid = bool(last("target_reg_valid", False)), bool(last("target_map_valid", False))
    out = {
        "target_error_m": float(np.linalg.norm(np.asarray(last("target_reg"), float) - target)) if reg_valid else math.nan,
        "map_based_error_m": float(np.linalg.norm(np.asarray(last("target_map"), float) - target)) if map_valid else math.nan,
        "samples": int(ok.sum()),
        "false_match_rate": float(np.mean(reg_err > fm)) if reg_err.size else math.nan,
        "samples_to_3m": _stays_below(tab["est_reg_err"][ok], 3.0),
        "single_frame_error_median_m": float(np.median(reg_err)) if reg_err.size else math.nan,
        "map_based_sample_error_median_m": float(np.median(tab["map_err"])) if tab["map_err"].size else math.nan,
        "registration_failures": int((~ok).sum()),
        "samples_rejected": int(last("samples_rejected", 0)),
        "rls_restarts": int(last("rls_restarts", 0)),
        "hough_applied_rate": float(np.mean(tab["hough_applied"][ok])) if ok.any() else math.nan,
        "frames": int(len(fr["t"])) if fr else 0,
        "frames_target_visible": int(np.count_nonzero(np.asarray(fr["visible"], bool))) if fr else 0,
        "frames_tracked": int(last("frames_tracked", 0)),
        "target_sigma_m": float(last("target_reg_sigma")) if reg_valid else math.nan,
    }
    yaw_err = _heading_error_deg(log)
    out["heading_error_rms_deg"], out["heading_error_max_deg"] = yaw_err
    sim_time = float(res["t"][-1]) if res and len(res["t"]) else math.nan
    return finish_metrics(out, sim_time, wall_time_s, error)


def _heading_error_deg(log) -> tuple[float, float]:
    """Telemetry (GPS course) heading minus the aircraft's yaw: the error the image rotation starts from."""
    tel = log.get("telemetry")
    if not tel:
        return math.nan, math.nan
    d = np.degrees((tel["heading"] - tel["true_yaw"] + np.pi) % (2 * np.pi) - np.pi)
    return float(np.sqrt(np.mean(d * d))), float(np.max(np.abs(d)))
