"""Benchmark: INS mechanization + error-state KF step times, and AHRS throughput on the PX4 log.

Run: ``PYTHONPATH=src python benchmarks/bench_ins.py``. Prints a markdown table; ``main()``
returns the numbers as a dict (microseconds per call, best of 5 repeats; AHRS: best of 3 runs).

Reference point: one filterpy ``KalmanFilter.predict`` / ``update`` of the same size, timed in the
same process (it does only the covariance algebra, no mechanization, no F construction).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from visnav.estimation.eskf import EskfConfig, ErrorStateKF  # noqa: E402
from visnav.estimation.ins import NavState, StrapdownINS, euler_to_quat  # noqa: E402

LOG = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "px4" / "sample_px4_events.ulg"
if not LOG.is_file() and os.environ.get("VISNAV_SHARED_DATA"):
    LOG = Path(os.environ["VISNAV_SHARED_DATA"]) / "px4" / "sample_px4_events.ulg"


def _per_call(fn, n: int, repeats: int = 5) -> float:
    """Best over repeats of the mean time of n calls [us] (the minimum: the machine is shared)."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for i in range(n):
            fn(i)
        out.append((time.perf_counter() - t0) / n * 1e6)
    return float(np.min(out))


def _filter(gyro_bias: bool, disc: str) -> ErrorStateKF:
    cfg = EskfConfig(gyro_bias=gyro_bias, discretization=disc)
    n = 15 if gyro_bias else 12
    s0 = NavState(0.0, np.array([0.0, 0.0, -60.0]), np.array([8.0, 3.0, 0.0]), euler_to_quat([0.05, -0.03, 1.0]))
    return ErrorStateKF(s0, np.ones(n), cfg)


def main() -> dict:
    rng = np.random.default_rng(0)
    res: dict[str, float | str] = {}
    acc = np.array([0.3, -0.2, -9.7])
    gyr = np.array([0.01, -0.02, 0.05])
    ins = StrapdownINS()
    s = NavState(0.0)
    res["ins_propagate_us"] = _per_call(lambda i: ins.propagate(s, acc, gyr, 0.02), 2000)
    for gb in (False, True):
        for disc in ("first_order", "van_loan"):
            f = _filter(gb, disc)
            n = 15 if gb else 12
            # predict = nominal mechanization (eq. A.1) + F, G, Phi, Q_k and P propagation
            res[f"predict_{n}_{disc}_us"] = _per_call(lambda i, f=f: f.propagate(acc, gyr, 0.02), 1000)
    f = _filter(False, "first_order")
    z3 = rng.normal(0, 1, (4000, 3)) * 0.5 + [0, 0, -60]
    res["update_position3d_us"] = _per_call(lambda i: f.update_position(z3[i % 4000], 1.0), 1000)
    res["update_position2d_us"] = _per_call(lambda i: f.update_position(z3[i % 4000, :2], np.diag([4.0, 1.0])), 1000)
    res["update_baro_us"] = _per_call(lambda i: f.update_baro(60.0 + 0.1 * (i % 7), 0.5), 1000)
    res["update_heading_us"] = _per_call(lambda i: f.update_heading(1.0 + 0.001 * (i % 5), 0.05), 1000)
    try:
        from filterpy.kalman import KalmanFilter

        kf = KalmanFilter(dim_x=12, dim_z=3)
        kf.F = np.eye(12)  # dense 12x12 algebra either way; identity keeps P finite over the repeats
        kf.Q = np.eye(12) * 1e-4
        kf.H = np.hstack([np.eye(3), np.zeros((3, 9))])
        kf.R = np.eye(3)
        res["filterpy_predict_12_us"] = _per_call(lambda i: kf.predict(), 2000)
        res["filterpy_update_3_us"] = _per_call(lambda i: kf.update(z3[i % 4000]), 2000)
    except ImportError:
        res["filterpy_reference"] = "not installed (pip install filterpy): no reference timings"
    if LOG.is_file():
        from visnav.estimation.ahrs import AhrsConfig, run_ahrs
        from visnav.io.ulog import read_ulog

        t0 = time.perf_counter()
        d = read_ulog(LOG)
        res["ulog_read_s"] = time.perf_counter() - t0
        walls = []
        for _ in range(3):
            t0 = time.perf_counter()
            run_ahrs(d.imu_t, d.accel, d.gyro, d.mag_t, d.mag, AhrsConfig(declination_deg=d.declination_deg or 0.0))
            walls.append(time.perf_counter() - t0)
        w = float(np.min(walls))
        res["ahrs_wall_s"] = w
        res["ahrs_imu_samples_per_sec"] = len(d.imu_t) / w
        res["ahrs_real_time_factor"] = float(d.imu_t[-1] - d.imu_t[0]) / w
        res["log_imu_samples"] = float(len(d.imu_t))
    print("| operation | time |\n|---|---:|")
    for k, v in res.items():
        if k.endswith("_us"):
            print(f"| {k} | {v:,.1f} µs |")
        elif k.endswith("_s"):
            print(f"| {k} | {v:.3f} s |")
        elif isinstance(v, str):
            print(f"| {k} | {v} |")
        else:
            print(f"| {k} | {v:,.1f} |")
    return res


if __name__ == "__main__":
    main()
