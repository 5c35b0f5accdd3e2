"""The "driving a navigator from your own script" example of docs/architecture.md runs as printed."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

DOC = Path(__file__).resolve().parents[2] / "docs" / "architecture.md"


def _example() -> str:
    text = DOC.read_text()
    m = re.search(r"<!-- example: own-script.*?-->\s*```python\n(.*?)```", text, re.S)
    assert m, "example block not found in docs/architecture.md"
    return m.group(1)


def test_own_script_example_follows_a_constant_velocity_flight(tmp_path, monkeypatch):
    """Level flight at (3, -1, 0.5) m/s: IMU reads -g on z, attitude zero, GPS fixes every 10th row (10 Hz);
    the example's estimates must follow the straight line (a closed form) to a few centimetres."""
    t = np.arange(0.0, 8.0, 0.01)
    v = np.array([3.0, -1.0, 0.5])
    p = np.array([10.0, 5.0, -20.0]) + t[:, None] * v
    cols = {"t_s": t, "ax_mps2": 0 * t, "ay_mps2": 0 * t, "az_mps2": -9.81 + 0 * t, "gx_radps": 0 * t,
            "gy_radps": 0 * t, "gz_radps": 0 * t, "roll_rad": 0 * t, "pitch_rad": 0 * t, "yaw_rad": 0 * t}
    gps = np.arange(len(t)) % 10 == 0
    for j, k in enumerate(("n_m", "e_m", "d_m")):
        cols[k] = np.where(gps, p[:, j], np.nan)
    for j, k in enumerate(("vn_mps", "ve_mps", "vd_mps")):
        cols[k] = np.where(gps, v[j], np.nan)
    np.savetxt(tmp_path / "flight.csv", np.column_stack(list(cols.values())), delimiter=",",
               header=",".join(cols), comments="", fmt="%.17g")
    monkeypatch.chdir(tmp_path)
    exec(compile(_example(), str(DOC), "exec"), {})
    out = np.loadtxt(tmp_path / "estimate.csv", delimiter=",", skiprows=1)
    assert len(out) == len(t)  # valid from the first fix (row 0) on
    want = np.array([10.0, 5.0, -20.0]) + out[:, :1] * v
    assert np.max(np.abs(out[:, 1:] - want)) < 0.02
