"""Metrics of the geo-location flights (seed 002 ch. 7), from the log: the navigator's samples and its final
estimates beside the truth (``geolocation_metrics(log, scenario, *, wall_time_s, error)``)."""

from __future__ import annotations

import math

import numpy as np

from visnav.analysis.metrics import _count, finish_metrics



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

    def col(k, shape=(0, 2), dtype=float):
        return np.asarray(s[k], dtype).reshape(n, *shape[1:]) if n else np.zeros(shape, dtype)

    out = {k: col(k) for k in ("reg", "map", "est_reg", "est_map")}
    out["t"] = col("t", (0,))
    for k, src in (("ok", "ok"), ("reg_used", "reg_used"), ("hough_applied", "hough")):
        out[k] = col(src, (0,), bool)
    for k in ("quality", "peak", "heading_tel", "heading_used"):
        out[k] = col(k, (0,))
    for k in ("reg", "map", "est_reg", "est_map"):
        out[k + "_err"] = np.linalg.norm(out[k] - tgt, axis=1) if n else np.zeros(0)
    return out


def geolocation_metrics(log, scenario, *, wall_time_s: float, error: str | None = None) -> dict:
    """From the log: the navigator's samples (``sample``), its final estimates and counters
    (``geoloc_result``), the frames (``frame``), the true target (``target``) and the telemetry."""
    cfg = scenario.mission
    tgt = log.get("target")
    target = np.asarray(tgt["position"][0], float) if tgt else np.full(2, np.nan)
    tab = sample_table(log, target)
    ok = tab["ok"]
    reg_err = tab["reg_err"][ok]
    fm = scenario.navigation.false_match_m
    res = log.get("geoloc_result")

    def last(k, default=math.nan):
        return res[k][-1] if res else default

    est_ok, map_ok = bool(last("est_reg_valid", False)), bool(last("est_map_valid", False))
    frames = log.get("frame")
    out = {
        "target_error_m": float(np.linalg.norm(last("est_reg") - target)) if est_ok else math.nan,
        "map_based_error_m": float(np.linalg.norm(last("est_map") - target)) if map_ok else math.nan,
        "samples": int(ok.sum()),
        "false_match_rate": float(np.mean(reg_err > fm)) if reg_err.size else math.nan,
        "samples_to_3m": _stays_below(tab["est_reg_err"][ok], 3.0),
        "single_frame_error_median_m": float(np.median(reg_err)) if reg_err.size else math.nan,
        "map_based_sample_error_median_m": float(np.median(tab["map_err"])) if tab["map_err"].size else math.nan,
        "registration_failures": int((~ok).sum()),
        "samples_rejected": _count(last("rejected")),
        "rls_restarts": _count(last("reinits")),
        "hough_applied_rate": float(np.mean(tab["hough_applied"][ok])) if ok.any() else math.nan,
        "frames": len(frames["t"]) if frames else 0,
        "frames_target_visible": int(np.sum(np.asarray(frames["visible"], bool))) if frames else 0,
        "frames_tracked": _count(last("frames_tracked")),
        "target_sigma_m": float(last("target_sigma")) if est_ok else math.nan,
    }
    yaw_err = _heading_error_deg(log)
    out["heading_error_rms_deg"], out["heading_error_max_deg"] = yaw_err
    return finish_metrics(out, float(last("sim_time")), wall_time_s, error)


def _heading_error_deg(log) -> tuple[float, float]:
    """Telemetry (GPS course) heading minus the aircraft's yaw: the error the image rotation starts from."""
    tel = log.get("telemetry")
    if not tel:
        return math.nan, math.nan
    d = np.degrees((tel["heading"] - tel["true_yaw"] + np.pi) % (2 * np.pi) - np.pi)
    return float(np.sqrt(np.mean(d * d))), float(np.max(np.abs(d)))
