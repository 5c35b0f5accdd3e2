"""Metrics of a deck landing run (issue #6 keys), from the flight log alone (``touchdown``, ``camera``, ...)."""

from __future__ import annotations

import numpy as np

from visnav.analysis.metrics import finish_metrics
from visnav.geometry.rotations import euler_to_dcm

#: 95% two-sided chi-square band of the NEES of 12 states
NEES_BAND_12 = (4.404, 23.337)


def attitude_error_deg(e_true: np.ndarray, e_est: np.ndarray) -> np.ndarray:
    """Rotation angle [deg] between true and estimated relative attitudes, per sample."""
    Ct, Ce = euler_to_dcm(e_true), euler_to_dcm(e_est)
    tr = np.einsum("nij,nij->n", Ct, Ce)
    return np.degrees(np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0)))


def final_approach_mask(log) -> np.ndarray:
    es = log.get("estimate")
    return np.isin(es["mode"], ["approach", "descend"]) if es else np.zeros(0, bool)


def deck_metrics(log, scenario=None, wall_time_s: float = float("nan"), error: str | None = None) -> dict:
    """Every metric of a deck run from its ``FlightLog`` (or the same data read back from ``log.h5``).

    ``scenario`` is the resolved scenario (unused by the keys so far; kept for the one metrics signature).
    """
    nan = float("nan")
    tdl = log.get("touchdown")
    td = None
    if tdl and len(tdl["t"]):
        td = dict(t=float(tdl["t"][0]), rel_speed=float(tdl["rel_speed"][0]), pos_err=float(tdl["pos_err"][0]),
                  on_deck=bool(tdl["on_deck"][0]), att_mismatch=float(tdl["att_mismatch"][0]))
    out: dict = {"landed": bool(td is not None and td["on_deck"] and error is None)}
    out["touchdown_rel_speed_mps"] = td["rel_speed"] if td else nan
    out["touchdown_attitude_mismatch_deg"] = td["att_mismatch"] if td else nan
    out["touchdown_position_error_m"] = td["pos_err"] if td else nan
    tr, es = log.get("truth"), log.get("estimate")
    m = final_approach_mask(log)
    if tr and m.any():
        out["pos_error_final_approach_median_m"] = float(np.median(np.linalg.norm(
            es["position"][m] - tr["position"][m], axis=1)))
        out["att_error_final_approach_median_deg"] = float(np.median(attitude_error_deg(tr["euler"][m], es["euler"][m])))
        out["vel_error_final_approach_median_mps"] = float(np.median(np.linalg.norm(
            es["velocity"][m] - tr["velocity"][m], axis=1)))
    else:
        for k in ("pos_error_final_approach_median_m", "att_error_final_approach_median_deg",
                  "vel_error_final_approach_median_mps"):
            out[k] = nan
    auto = np.isin(es["mode"], ["hover", "approach", "descend"]) if es else np.zeros(0, bool)
    out["nees_mean"] = float(np.nanmean(es["nees"][auto])) if es and auto.any() else nan
    cam = log.get("camera")
    out["lights_used_mean"] = float(np.mean(cam["lights_used"])) if cam else nan
    out["blobs_rejected"] = int(np.sum(cam["rejected"])) if cam else nan  # no camera stream: unknown
    drop = log.get("imu_dropped")  # one row per dropped sample: none recorded is none dropped
    out["imu_dropped"] = int(len(drop["t"])) if drop else 0
    out["touchdown_time_s"] = td["t"] if td else nan
    # time flown without a 3-light fix before contact (the camera of eq. 5.9 loses the lights over the deck origin)
    seen = cam["t"][cam["lights_used"] >= 3] if cam else np.zeros(0)
    out["blind_before_touchdown_s"] = float(td["t"] - seen[-1]) if td and seen.size else nan
    # time past the trajectory's end without contact (the descend mode; 0 when contact came during the approach)
    sim_time_s = float(tr["t"][-1]) if tr and len(tr["t"]) else 0.0
    md = log.get("mode")
    t_desc = [t for t, m in zip(md["t"], md["mode"]) if m == "descend"] if md else []
    out["descend_s"] = float((td["t"] if td else sim_time_s) - t_desc[0]) if t_desc else 0.0
    return finish_metrics(out, sim_time_s, wall_time_s, error)
