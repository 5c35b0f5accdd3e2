"""TUM trajectory format (timestamp tx ty tz qx qy qz qw), readable by evo."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation


def write_tum(path: str | Path, t, position, euler) -> None:
    """Write a trajectory; orientation from (roll, pitch, yaw) ZYX Euler angles (body -> NED)."""
    t = np.asarray(t, float)
    p = np.asarray(position, float).reshape(-1, 3)
    e = np.asarray(euler, float).reshape(-1, 3)
    q = Rotation.from_euler("ZYX", e[:, ::-1]).as_quat()  # x, y, z, w
    data = np.column_stack([t, p, q])
    np.savetxt(path, data, fmt="%.6f", header="timestamp tx ty tz qx qy qz qw (NED, body FRD)")


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a TUM file: returns (t, position (N,3), quaternion xyzw (N,4))."""
    d = np.loadtxt(path, comments="#", ndmin=2)
    if d.shape[1] != 8:
        raise ValueError(f"{path}: a TUM file has 8 columns, found {d.shape[1]}")
    return d[:, 0], d[:, 1:4], d[:, 4:8]
