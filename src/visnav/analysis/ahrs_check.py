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
from visnav.io.logs import open_recording
from visnav.io.provenance import provenance
from types import SimpleNamespace
from visnav.geometry.rotations import euler_to_dcm
from visnav.estimation.timesync import gyro_rotvecs, hand_eye_rotation, rotation_angle_deg

__all__ = ["ahrs_check"]


def ahrs_check(log_path, out_dir=None, declination_deg: float | None = None,
               cfg: AhrsConfig | None = None) -> dict:
    """Returns the metrics dict (also written to ``out_dir/metrics.json``). ``log_path``: a PX4 ULog, or any
    input of ``io/logs.open_recording`` (recording folder, EuRoC folder, DataFlash, ROS bag): its IMU against
    its ground truth attitude (truth.csv, EuRoC's Vicon), else its attitude stream."""
    data = read_ulog(log_path) if Path(log_path).suffix.lower() == ".ulg" else _from_recording(log_path)
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
    reason = None
    if data.mag is None:
        reason = ("no magnetometer: absolute yaw is not observable from the IMU alone (gyro-only yaw drifts"
                  + (", and the reference's yaw is relative to an arbitrary world axis)" if getattr(data, "ref_kind", "") == "ground truth"
                     else ")"))
    frame = _reference_frame(data)
    R_rg = frame.pop("_R", None)
    if R_rg is not None and frame["reference_to_gyro_rotation_sigma_deg"] < 0.5:
        # the reference attitude turned into the gyro's axes (C_n,gyro = C_n,ref R^T): what is left once the
        # reference's own frame misalignment, measured by the gyro alone, is taken out
        from scipy.spatial.transform import Rotation

        C_ref = Rotation.from_quat(np.asarray(data.att_quat)[:, [1, 2, 3, 0]]).as_matrix()
        e_g = quat_to_euler(Rotation.from_matrix(C_ref @ R_rg.T).as_quat()[:, [3, 0, 1, 2]])
        cmp_r = attitude_differences(res["t"], res["euler"], data.att_t, e_g)
        frame |= {"roll_rms_diff_deg_gyro_axes": cmp_r["roll_rms_diff_deg"],
                  "pitch_rms_diff_deg_gyro_axes": cmp_r["pitch_rms_diff_deg"]}
    metrics = {
        "reference": getattr(data, "ref_kind", "PX4 vehicle_attitude"),
        "yaw_unobservable_reason": reason,
        **frame,
        "roll_rms_diff_deg": cmp["roll_rms_diff_deg"],
        "pitch_rms_diff_deg": cmp["pitch_rms_diff_deg"],
        "yaw_rms_diff_deg": None if reason else cmp["yaw_rms_diff_deg"],
        # the constant part of the difference and what is left around it (a constant part is an
        # accelerometer bias or a frame misalignment; docs/real-data.md, EuRoC)
        "roll_mean_diff_deg": float(np.degrees(cmp["diff"][:, 0].mean())),
        "pitch_mean_diff_deg": float(np.degrees(cmp["diff"][:, 1].mean())),
        "roll_std_diff_deg": float(np.degrees(cmp["diff"][:, 0].std())),
        "pitch_std_diff_deg": float(np.degrees(cmp["diff"][:, 1].std())),
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
        a.plot(data.att_t, np.degrees(unwrap(ref[:, i])), "k-", lw=1.2, label=m.get("reference", "PX4 vehicle_attitude"))
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
        b.set_ylabel(f"{n} ours − reference [deg]")
        v = m[f"{n}_rms_diff_deg"]
        b.set_title(f"RMS {v:.3f} deg" if v is not None else "not observable (no magnetometer)", fontsize=9)
    axes[0, 0].legend(fontsize=8)
    axes[0, 1].legend(fontsize=8)
    axes[2, 0].set_xlabel("t [s]")
    axes[2, 1].set_xlabel("t [s]")
    fig.suptitle(f"AHRS check: {Path(m['log']).name}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _from_recording(path):
    """An opened recording as the fields ``ahrs_check`` reads from a ULog (magnetometer: field vectors only)."""

    from scipy.spatial.transform import Rotation

    rec = open_recording(path)
    rec.require(("imu",), "AHRS check")
    ref, kind = (rec.truth, "ground truth") if rec.truth is not None and "roll_rad" in rec.truth else \
        (rec.streams.get("attitude"), "attitude")
    if ref is None:
        raise ValueError(f"{path}: no reference attitude (truth.csv / ground truth or attitude.csv) to compare with")
    s = rec.streams["imu"]
    e = np.column_stack([ref["roll_rad"], ref["pitch_rad"], ref["yaw_rad"]])
    q = Rotation.from_matrix(np.array([euler_to_dcm(x) for x in e])).as_quat()[:, [3, 0, 1, 2]]
    mf = rec.streams.get("mag_field")  # a log's magnetometer field vectors (io/logs.py: DataFlash MAG, tlog IMU)
    mag = np.column_stack([mf["mx_ga"], mf["my_ga"], mf["mz_ga"]]) if mf is not None and len(mf["t_s"]) > 1 else None
    damaged = bool(rec.summary) and "; to the end (" not in rec.summary
    return SimpleNamespace(imu_t=s["t_s"], accel=np.column_stack([s[f"a{a}_mps2"] for a in "xyz"]),
                           gyro=np.column_stack([s[f"g{a}_radps"] for a in "xyz"]), att_t=ref["t_s"], att_quat=q,
                           mag_t=mf["t_s"] if mag is not None else None, mag=mag, declination_deg=None,
                           notes=([rec.summary] if damaged else []) + list(rec.notes),
                           mag_source="mag_field" if mag is not None else None, truncated=damaged, ref_kind=kind)


def _reference_frame(data) -> dict:
    """Diagnostics of the reference itself: the rotation between the reference's body frame and the gyro's
    (hand-eye of the gyro's and the reference attitude's rotations over 0.25 s, estimation/timesync.py),
    and the accelerometer's mean difference from the reference's gravity (1 s means): a constant
    difference is an accelerometer bias or a frame misalignment, which the IMU alone cannot tell apart
    from a tilt and which therefore shows in the roll / pitch differences."""
    from scipy.spatial.transform import Rotation, Slerp


    ta = np.asarray(data.att_t, float)
    t = np.asarray(data.imu_t, float)
    t0s = np.arange(max(ta[0], t[0]), min(ta[-1], t[-1]) - 1.0, 0.25)
    if len(t0s) < 8:
        return {}
    sl = Slerp(ta, Rotation.from_quat(np.asarray(data.att_quat)[:, [1, 2, 3, 0]]))
    v_ref = (sl(t0s).inv() * sl(t0s + 0.25)).as_rotvec()
    pairs = np.column_stack([t0s, t0s + 0.25])
    R, b = hand_eye_rotation(v_ref, gyro_rotvecs(t, data.gyro, pairs), np.full(len(t0s), 0.25))
    C = sl(t0s + 0.5).as_matrix()
    f_ref = C.transpose(0, 2, 1) @ np.array([0.0, 0.0, -9.80665])
    f = np.array([data.accel[(t >= a) & (t < a + 1.0)].mean(0) for a in t0s])
    psi = gyro_rotvecs(t, data.gyro, pairs)
    rng = np.random.default_rng(0)
    boot = [rotation_angle_deg(hand_eye_rotation(v_ref, psi, np.full(len(t0s), 0.25), w, iters=4)[0] @ R.T)
            for w in rng.multinomial(len(t0s), np.full(len(t0s), 1 / len(t0s)), size=40).astype(float)]
    return {"_R": R, "reference_to_gyro_rotation_deg": rotation_angle_deg(R),
            "reference_to_gyro_rotation_sigma_deg": float(np.sqrt(np.mean(np.square(boot)))),
            "reference_to_gyro_rotvec_deg": np.degrees(Rotation.from_matrix(R).as_rotvec()).tolist(),
            "accel_minus_reference_gravity_mps2": np.nanmean(f - f_ref, axis=0).tolist()}
