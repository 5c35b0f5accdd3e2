"""TUM trajectory format (timestamp tx ty tz qx qy qz qw), readable by evo.

A run writes ``truth.tum`` (every logged truth pose) and ``estimate.tum`` with the samples where the
estimate is valid only (no 0,0,0 pose before the first fix), stamped as the truth samples of the
same instants, each with a header line naming the frame (``tum_frame``). ``trajectory_rmse`` is the position RMSE over exactly those samples: what
``evo_ape tum truth.tum estimate.tum`` (translation part, no alignment) reports.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

NED_FRAME = "NED world [m], orientation body FRD -> NED"
DECK_FRAME = ("deck-relative: position of the deck origin relative to the vehicle in vehicle body FRD axes [m], "
              "orientation from the deck/vehicle 3-2-1 Euler angles e of seed 003's state")


def tum_frame(sc) -> str | None:
    """The frame a scenario's poses are logged in, or None when it logs no pose (the CONDOR ground
    test's rows are single-image range estimates, not a trajectory)."""
    m = sc.mission
    if getattr(m, "type", "") == "condor" and getattr(m, "experiment", "") == "ground_test":
        return None
    return DECK_FRAME if getattr(m, "type", "") == "deck" else NED_FRAME


def write_tum(path: str | Path, t, position, euler, frame: str = NED_FRAME) -> None:
    """Write a trajectory; orientation from (roll, pitch, yaw) ZYX Euler angles."""
    t = np.asarray(t, float)
    p = np.asarray(position, float).reshape(-1, 3)
    e = np.asarray(euler, float).reshape(-1, 3)
    q = Rotation.from_euler("ZYX", e[:, ::-1]).as_quat() if len(e) else np.zeros((0, 4))  # x, y, z, w
    write_tum_quat(path, t, p, q, frame)


def write_tum_quat(path: str | Path, t, position, quat_xyzw, frame: str = NED_FRAME, decimals: int = 6) -> None:
    """Write a trajectory from unit quaternions (x, y, z, w); the header line names the frame."""
    data = np.column_stack([np.asarray(t, float), np.asarray(position, float).reshape(-1, 3),
                            np.asarray(quat_xyzw, float).reshape(-1, 4)])
    np.savetxt(path, data, fmt=f"%.{decimals}f", header=f"timestamp tx ty tz qx qy qz qw; frame: {frame}")


def valid_pairs(truth: dict, estimate: dict) -> tuple[np.ndarray, np.ndarray]:
    """Indices (into truth, into estimate) of the samples logged at the same instant where the
    estimate is valid (its ``valid`` flag when logged) and both poses are finite."""
    tt, te = np.asarray(truth["t"], float), np.asarray(estimate["t"], float)
    ok = np.ones(len(te), bool)
    if "valid" in estimate:
        ok &= np.asarray(estimate["valid"]).astype(bool)
    ok &= np.all(np.isfinite(np.asarray(estimate["position"], float).reshape(len(te), -1)), axis=1)
    ok &= np.all(np.isfinite(np.asarray(estimate["euler"], float).reshape(len(te), -1)), axis=1)
    j = np.flatnonzero(ok)
    if len(tt) == 0 or len(j) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    i = np.clip(np.searchsorted(tt, te[j]), 0, len(tt) - 1)
    same = np.abs(tt[i] - te[j]) < 1e-9
    i, j = i[same], j[same]
    fin = np.all(np.isfinite(np.asarray(truth["position"], float)[i]), axis=1)
    return i[fin], j[fin]


def trajectory_rmse(log) -> float | None:
    """RMS position error [m] of the valid estimate against truth (None when the log has no pair)."""
    tr, es = log.get("truth"), log.get("estimate")
    if not tr or not es:
        return None
    i, j = valid_pairs(tr, es)
    if not len(i):
        return None
    d = np.asarray(es["position"], float)[j] - np.asarray(tr["position"], float)[i]
    return float(np.sqrt(np.mean(np.sum(d * d, axis=1))))


def write_run_tum(out_dir: Path, log, frame: str) -> list[Path]:
    """``truth.tum`` (finite truth poses) and ``estimate.tum`` (valid estimates); returns the files written."""
    tr, es = log.get("truth"), log.get("estimate")
    if not tr or not es:
        return []
    i, j = valid_pairs(tr, es)
    pt, et = np.asarray(tr["position"], float), np.asarray(tr["euler"], float)
    k = np.flatnonzero(np.all(np.isfinite(pt), axis=1) & np.all(np.isfinite(et), axis=1))
    paths = [out_dir / "truth.tum", out_dir / "estimate.tum"]
    write_tum(paths[0], np.asarray(tr["t"])[k], pt[k], et[k], frame)
    write_tum(paths[1], np.asarray(es["t"])[j], np.asarray(es["position"])[j], np.asarray(es["euler"])[j], frame)
    return paths


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a TUM file: returns (t, position (N,3), quaternion xyzw (N,4))."""
    d = np.loadtxt(path, comments="#", ndmin=2)
    if d.shape[1] != 8:
        raise ValueError(f"{path}: a TUM file has 8 columns, found {d.shape[1]}")
    return d[:, 0], d[:, 1:4], d[:, 4:8]
