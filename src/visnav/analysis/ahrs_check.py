"""Real-data check of the INS attitude part: our AHRS on a PX4 log's raw IMU vs PX4's attitude.

``ahrs_check(log)`` reads the ULog (io/ulog.py), runs the AHRS mode of the error-state filter
(estimation/ahrs.py) on ``sensor_combined`` (+ magnetometer), and compares roll, pitch and yaw
with the log's ``vehicle_attitude``. For context it also reports a gyro-only propagation from the
same initial attitude (no aid at all). Writes ``metrics.json`` and ``ahrs.png`` when ``out_dir``
is given.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from visnav.estimation.ahrs import AhrsConfig, attitude_differences, run_ahrs
from visnav.estimation.ins import euler_to_quat, integrate_gyro, quat_to_euler
from visnav.io.ulog import read_ulog

__all__ = ["ahrs_check"]


def ahrs_check(log_path, out_dir=None, declination_deg: float | None = None,
               cfg: AhrsConfig | None = None) -> dict:
    """Returns the metrics dict (also written to ``out_dir/metrics.json``)."""
    data = read_ulog(log_path)
    decl = declination_deg if declination_deg is not None else (data.declination_deg or 0.0)
    cfg = cfg or AhrsConfig()
    cfg = AhrsConfig(**{**cfg.__dict__, "declination_deg": float(decl)})
    t0 = time.perf_counter()
    res = run_ahrs(data.imu_t, data.accel, data.gyro, data.mag_t, data.mag, cfg)
    wall = time.perf_counter() - t0
    ref = quat_to_euler(data.att_quat)
    cmp = attitude_differences(res["t"], res["euler"], data.att_t, ref)
    # gyro-only: the same first attitude, body rates integrated (trapezoid), no aid
    dt = np.diff(data.imu_t)
    w_mid = 0.5 * (data.gyro[1:] + data.gyro[:-1])
    q0 = euler_to_quat(res["euler"][0])
    gyro_only = quat_to_euler(integrate_gyro(q0, w_mid, dt))
    cmp_g = attitude_differences(data.imu_t, gyro_only, data.att_t, ref)
    duration = float(data.imu_t[-1] - data.imu_t[0])
    metrics = {
        "roll_rms_diff_deg": cmp["roll_rms_diff_deg"],
        "pitch_rms_diff_deg": cmp["pitch_rms_diff_deg"],
        "yaw_rms_diff_deg": cmp["yaw_rms_diff_deg"],
        "roll_max_diff_deg": float(np.degrees(np.abs(cmp["diff"][:, 0]).max())),
        "pitch_max_diff_deg": float(np.degrees(np.abs(cmp["diff"][:, 1]).max())),
        "yaw_max_diff_deg": float(np.degrees(np.abs(cmp["diff"][:, 2]).max())),
        "gyro_only_roll_rms_diff_deg": cmp_g["roll_rms_diff_deg"],
        "gyro_only_pitch_rms_diff_deg": cmp_g["pitch_rms_diff_deg"],
        "gyro_only_yaw_rms_diff_deg": cmp_g["yaw_rms_diff_deg"],
        "declination_deg": float(decl),
        "magnetometer": data.mag is not None,
        "magnetometer_source": data.mag_source,
        "log_truncated": data.truncated,
        "imu_samples": int(len(data.imu_t)),
        "duration_s": duration,
        "imu_rate_hz": float((len(data.imu_t) - 1) / duration) if duration > 0 else math.nan,
        "gyro_bias_radps": res["gyro_bias"].tolist(),
        "updates": {k: {"accepted": a, "rejected": r} for k, (a, r) in res["stats"].items()},
        "rejected_imu_samples": res["rejected_samples"],
        "ahrs_wall_s": wall,
        "log_notes": data.notes,
        "log": str(log_path),
    }
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        from visnav.io.provenance import provenance

        (out / "metrics.json").write_text(json.dumps({**metrics, "provenance": provenance()}, indent=2))
        _plot(out / "ahrs.png", data, res, ref, gyro_only, metrics)
    return metrics


def _plot(path: Path, data, res, ref, gyro_only, m) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 2, figsize=(12, 8), sharex=True)
    names = ("roll", "pitch", "yaw")
    ours = res["euler"].copy()
    for i, n in enumerate(names):
        a = axes[i, 0]
        unwrap = np.unwrap if i == 2 else (lambda x: x)
        a.plot(data.att_t, np.degrees(unwrap(ref[:, i])), "k-", lw=1.2, label="PX4 vehicle_attitude")
        a.plot(res["t"], np.degrees(unwrap(ours[:, i])), "C0-", lw=0.8, label="visnav AHRS (ESKF)")
        a.plot(data.imu_t, np.degrees(unwrap(gyro_only[:, i])), "C3:", lw=0.8, label="gyro only")
        a.set_ylabel(f"{n} [deg]")
        b = axes[i, 1]
        d = np.interp(data.att_t, res["t"], np.unwrap(ours[:, i]) if i == 2 else ours[:, i])
        diff = (d - (np.unwrap(ref[:, i]) if i == 2 else ref[:, i]) + np.pi) % (2 * np.pi) - np.pi
        b.plot(data.att_t, np.degrees(diff), "C0-", lw=0.8)
        b.fill_between(res["t"], -3 * np.degrees(res["sigma"][:, i]), 3 * np.degrees(res["sigma"][:, i]),
                       color="C0", alpha=0.15, label="±3σ (filter)")
        lim = max(0.5, 1.5 * float(np.abs(np.degrees(diff[data.att_t > data.att_t[0] + 2.0])).max(initial=0.0)))
        b.set_ylim(-lim, lim)
        b.set_ylabel(f"{n} ours − PX4 [deg]")
        b.set_title(f"RMS {m[f'{n}_rms_diff_deg']:.3f} deg", fontsize=9)
    axes[0, 0].legend(fontsize=8)
    axes[0, 1].legend(fontsize=8)
    axes[2, 0].set_xlabel("t [s]")
    axes[2, 1].set_xlabel("t [s]")
    fig.suptitle(f"AHRS check: {Path(m['log']).name}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
