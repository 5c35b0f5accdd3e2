"""``visnav check``: a recording's conventions and calibration verified from the flight itself (issue 29).

Each check gives a row (name, status ok / warning / problem / not observable, measured, expected) and
feeds ``check.json``. What each check does (only where the data allows it):

* streams: rate (median interval), gaps (intervals over 3x the median), repeated and out-of-order stamps.
* IMU axes: the mean specific force at rest (windows of low rotation and |f| near g; else the whole
  flight, a multirotor's mean thrust) names the convention: FRD reads f = (0, 0, -g), FLU (0, 0, +g);
  with an attitude (attitude.csv or the ground truth), the gyro is compared with the attitude's
  derivative (rotation vectors over 0.25 s, ``estimation/timesync.hand_eye_rotation``) and the
  accelerometer with the attitude's gravity; the best of the 48 signed axis permutations names a
  flipped sign or a swapped pair.
* camera vs IMU: frame rotations from feature tracks (``vision/frame_rotation.py``) against the
  integrated gyro (``estimation/timesync.calibrate_camera_imu``): camera-to-IMU rotation (hand-eye)
  vs the declared mount, and the clock offset (t_imu = t_camera + offset) vs the declared one.
* magnetometer (field vectors): hard-iron offset and radius by a least-squares sphere
  ``|m|^2 = 2 m.o + (r^2 - |o|^2)``, a levelled circle when the flight covers too few directions;
  heading changes against the gyro's yaw changes.
* GPS vs IMU: the acceleration from GPS velocities against the accelerometer rotated by the
  attitude (a^n = C f + g); the GPS latency is the lag maximising their correlation.
* focal length: on the frame pairs with the most rotation, the focal length scale that best maps the
  tracks through K R K^-1 with the gyro's rotation.
"""

from __future__ import annotations

import base64
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from visnav.estimation.timesync import (calibrate_camera_imu, gyro_rotvecs, hand_eye_rotation,
                                        rotation_angle_deg, wide_offset)
from visnav.geometry.rotations import euler_to_dcm
from visnav.io.recording import STREAMS, read_csv
import itertools
from visnav.vision.frame_rotation import frame_rotations
from visnav.io.json_values import jsonable
from html import escape

__all__ = ["run_check", "camera_imu", "CheckResult", "write_check"]

G = 9.80665
OK, WARN, PROBLEM, NA = "ok", "warning", "problem", "not observable"


@dataclass
class CheckResult:
    rows: list = field(default_factory=list)  # (name, status, measured, expected)
    summary: dict = field(default_factory=dict)  # check.json keys
    plots: dict = field(default_factory=dict)  # name -> data for the HTML

    def add(self, name, status, measured, expected):
        self.rows.append((name, status, measured, expected))
        if status == PROBLEM:
            self.summary["problems"].append(f"{name}: {measured} (expected {expected})")


# ------------------------------------------------------------------------------------------ helpers
def _imu(rec):
    s = rec.streams["imu"]
    return (s["t_s"], np.column_stack([s["ax_mps2"], s["ay_mps2"], s["az_mps2"]]),
            np.column_stack([s["gx_radps"], s["gy_radps"], s["gz_radps"]]))


def _attitude(rec):
    """(t, C_nb (N,3,3), source) from attitude.csv, else the ground truth's attitude, else None."""
    for src, s in (("attitude.csv", rec.streams.get("attitude")), ("ground truth", rec.truth)):
        if s is not None and "roll_rad" in s and len(s["t_s"]) > 10:
            e = np.column_stack([s["roll_rad"], s["pitch_rad"], s["yaw_rad"]])
            ok = np.all(np.isfinite(e), axis=1) & np.isfinite(s["t_s"])  # an attitude without yaw is not enough
            if ok.sum() > 10:
                return s["t_s"][ok], np.array([euler_to_dcm(x) for x in e[ok]]), src
    return None


def _signed_permutations():
    for p in itertools.permutations(range(3)):
        for s in itertools.product((1, -1), repeat=3):
            M = np.zeros((3, 3))
            M[range(3), p] = s
            yield M


def _name_axes(M: np.ndarray) -> str:
    """What a signed permutation does to the axes, in words ("identity", "x sign flipped", "x/y swapped")."""
    if np.allclose(M, np.eye(3)):
        return "identity"
    parts = []
    p = np.argmax(np.abs(M), axis=1)
    swapped = [(i, int(p[i])) for i in range(3) if p[i] != i and i < p[i]]
    parts += [f"{'xyz'[i]}/{'xyz'[j]} swapped" for i, j in swapped]
    parts += [f"{'xyz'[i]} sign flipped" for i in range(3) if M[i, p[i]] < 0]
    return ", ".join(parts)


def _best_axes(measured: np.ndarray, predicted: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The signed permutation M with measured ~ M predicted by least squares: (M, its RMS, identity's RMS)."""
    best, best_r = np.eye(3), math.inf
    for M in _signed_permutations():
        r = float(np.sqrt(np.mean((measured - predicted @ M.T) ** 2)))
        if r < best_r:
            best, best_r = M, r
    return best, best_r, float(np.sqrt(np.mean((measured - predicted) ** 2)))


# ------------------------------------------------------------------------------------------ checks
def _check_streams(rec, out: CheckResult) -> None:
    for name, s in rec.streams.items():
        t = np.asarray(s["t_s"], float)
        if len(t) < 3:
            out.add(f"{name} rate", NA, f"{len(t)} samples", "at least 3 samples")
            continue
        d = np.diff(t)
        pos = d[d > 0]
        med = float(np.median(pos)) if len(pos) else math.nan
        rate = 1.0 / med if med > 0 else math.nan
        out.summary.setdefault("rates_hz", {})[name] = rate
        back = int((d < 0).sum())
        if "sensor" in s:  # several sensors in one stream (range: sonar and laser) may share an instant
            rep = sum(int((np.diff(t[s["sensor"] == k]) == 0).sum()) for k in np.unique(s["sensor"]))
        else:
            rep = int((d == 0).sum())
        gaps = d > 3 * med
        msg = f"{rate:.2f} Hz, {len(t)} samples"
        if gaps.any():
            msg += f", {int(gaps.sum())} gaps (longest {d.max():.3f} s)"
        status = OK
        if back or rep:
            status = PROBLEM if back else WARN
            msg += f", {back} out of order, {rep} repeated stamps"
        elif gaps.sum() > max(1, 0.01 * len(d)):
            status = WARN
        out.add(f"{name} rate", status, msg, "steady rate, no gaps, increasing stamps")
        out.plots.setdefault("dt", {})[name] = d
    repaired = [n for n in rec.notes if any(k in n for k in ("re-sorted", "out of order", "dropped", "truncated",
                                                              "duplicate"))]
    if repaired:  # a log reader repairs what a folder reader refuses: the repairs are named here
        out.add("reader repairs", WARN, "; ".join(repaired[:5]) + (" ..." if len(repaired) > 5 else ""),
                "stamps in order, nothing dropped")
    out.summary["imu_rate_hz"] = out.summary.get("rates_hz", {}).get("imu")
    out.summary["camera_rate_hz"] = out.summary.get("rates_hz", {}).get("frames")



def _check_imu_axes(rec, out: CheckResult) -> None:
    t, f, w = _imu(rec)
    win = max(int(round(0.5 / max(np.median(np.diff(t)), 1e-6))), 2)
    n = len(t) // win
    fm = f[: n * win].reshape(n, win, 3).mean(1)
    ws = np.linalg.norm(w[: n * win].reshape(n, win, 3), axis=2).mean(1)
    rest = (np.abs(np.linalg.norm(fm, axis=1) - G) < 0.3) & (ws < 0.05)
    src = f"{int(rest.sum())} windows at rest" if rest.sum() >= 2 else "the whole flight's mean (no rest found)"
    mean_f = fm[rest].mean(0) if rest.sum() >= 2 else f.mean(0)
    u = mean_f / max(np.linalg.norm(mean_f), 1e-9)
    i = int(np.argmax(np.abs(u)))
    up = f"{'+' if u[i] > 0 else '-'}{'xyz'[i]}"
    name = {"-z": "FRD", "+z": "FLU"}.get(up, f"other (gravity reads along {up})")
    if abs(u[i]) < 0.9:
        name = f"other (gravity at {np.degrees(np.arccos(abs(u[i]))):.0f} deg from {up})" if abs(u[i]) < 0.7 else name
    out.summary["imu_axes"] = name
    out.plots["gravity"] = mean_f
    out.add("IMU axes (gravity)", OK if name == "FRD" else PROBLEM,
            f"{name}: mean specific force {np.round(mean_f, 2).tolist()} m/s^2 ({src})",
            "FRD: (0, 0, -9.8) when level")
    att = _attitude(rec)
    if att is None:
        out.add("gyro vs attitude", NA, "no attitude.csv and no ground truth attitude", "an attitude stream")
        return
    ta, C, asrc = att
    # gyro against the attitude's rotation over 0.25 s (hand-eye with bias: R should be the identity)
    step = 0.25
    t0s = np.arange(max(ta[0], t[0]), min(ta[-1], t[-1]) - step, step)
    if len(t0s) < 8:
        out.add("gyro vs attitude", NA, "attitude and IMU overlap too little", "> 2 s of overlap")
        return
    from scipy.spatial.transform import Rotation, Slerp

    sl = Slerp(ta, Rotation.from_matrix(C))
    R0, R1 = sl(t0s), sl(t0s + step)
    v_att = (R0.inv() * R1).as_rotvec()
    pairs = np.column_stack([t0s, t0s + step])
    v_gyro = gyro_rotvecs(t, w, pairs)
    exc = float(np.degrees(np.sqrt(np.mean(v_att**2))))
    if exc < 0.2:
        out.add("gyro vs attitude", NA, f"the attitude changes {exc:.2f} deg RMS per {step} s", "rotation")
    else:
        M, r_best, r_id = _best_axes(v_gyro - np.median(v_gyro - v_att, axis=0), v_att)
        dts = pairs[:, 1] - pairs[:, 0]
        R, b = hand_eye_rotation(v_att, v_gyro, dts)
        ang = rotation_angle_deg(R)
        res = float(np.degrees(np.sqrt(np.mean(np.sum((v_gyro - v_att @ R.T - b * step) ** 2, 1)))))
        rng = np.random.default_rng(0)
        boot = [rotation_angle_deg(hand_eye_rotation(v_att, v_gyro, dts, w, iters=4)[0] @ R.T)
                for w in rng.multinomial(len(dts), np.full(len(dts), 1 / len(dts)), size=40).astype(float)]
        sig = float(np.sqrt(np.mean(np.square(boot))))
        out.summary["gyro_attitude_rotation_deg"] = ang if sig < 2 else None
        out.plots["gyro_bias"] = b if sig < 2 else None
        if not np.allclose(M, np.eye(3)) and r_best < 0.5 * r_id:
            out.add("gyro vs attitude", PROBLEM, f"gyro axes look {_name_axes(M)} against the {asrc} "
                    f"(RMS {np.degrees(r_best):.3f} vs {np.degrees(r_id):.3f} deg as is)", "identity")
        elif sig >= 2:
            out.add("gyro vs attitude", NA, f"the rotation between gyro and attitude frames is undetermined "
                    f"(bootstrap sigma {sig:.0f} deg: the flight rotates about too few axes; {exc:.2f} deg RMS per "
                    f"{step} s)", "rotation about several axes")
        else:
            out.add("gyro vs attitude", OK if ang < 3 else WARN,
                    f"frames differ by {ang:.2f} +- {sig:.2f} deg, residual {res:.3f} deg per {step} s, gyro bias "
                    f"{np.round(b, 4).tolist()} rad/s ({asrc})", "< 3 deg")
    # accelerometer against the attitude's gravity, 0.25 s means (accelerations taken as noise)
    fa = C.transpose(0, 2, 1) @ np.array([0.0, 0.0, -G])
    wl = 0.25  # window [s]: long enough to average vibration, short enough to keep the tilts
    ti = np.arange(max(ta[0], t[0]), min(ta[-1], t[-1]) - wl, wl)
    if len(ti) >= 8:
        meas = np.array([f[(t >= a) & (t < a + wl)].mean(0) for a in ti])
        pred = np.array([fa[(ta >= a) & (ta < a + wl)].mean(0) if np.any((ta >= a) & (ta < a + wl))
                         else fa[np.searchsorted(ta, a).clip(0, len(ta) - 1)] for a in ti])
        M, r_best, r_id = _best_axes(meas, pred)
        if not np.allclose(M, np.eye(3)) and r_best < 0.5 * r_id:
            out.add("accelerometer vs attitude", PROBLEM, f"accelerometer axes look {_name_axes(M)} against the "
                    f"{asrc} (RMS {r_best:.2f} vs {r_id:.2f} m/s^2 as is)", "identity")
        else:
            bias = (meas - pred).mean(0)
            out.add("accelerometer vs attitude", OK if r_id < 1.0 else WARN,
                    f"RMS {r_id:.2f} m/s^2, mean difference {np.round(bias, 2).tolist()} m/s^2 (bias or frame "
                    f"misalignment, {asrc})", "< 1 m/s^2")


def _frames_window(rec, max_frames: int | None) -> np.ndarray:
    """Indices of the frames to use: all, or the ``max_frames`` consecutive ones with the most gyro rotation."""
    tf = rec.streams["frames"]["t_s"]
    n = len(tf)
    if max_frames is None or n <= max_frames or getattr(rec, "frames_own_clock", False):
        return np.arange(n) if max_frames is None or n <= max_frames else np.arange(max_frames)
    t, _, w = _imu(rec)
    ang = np.interp(tf, t, np.concatenate([[0], np.cumsum(np.linalg.norm(w[1:], axis=1) * np.diff(t))]))
    score = np.abs(np.diff(ang))
    c = np.concatenate([[0], np.cumsum(score)])
    j = int(np.argmax(c[max_frames - 1:] - c[: n - max_frames + 1]))
    return np.arange(j, j + max_frames)


def camera_imu(rec, max_offset_s: float = 0.25, max_frames: int | None = None, keep=None):
    """(``CameraImuCalibration`` of the recording's frames and gyro, None) or (None, why not observable)."""

    if "frames" not in rec.streams or "imu" not in rec.streams or rec.camera is None:
        return None, "no frames or no IMU"
    if rec.camera.mount is None:
        return None, "a gimbal camera (no fixed camera-to-body rotation)"
    idx = _frames_window(rec, max_frames)
    tf = np.asarray(rec.streams["frames"]["t_s"], float)[idx]
    imgs, ts = [], []
    for k, i in enumerate(idx):
        img, _ = rec.image(int(i))
        if img is not None:
            imgs.append(img)
            ts.append(tf[k])
    if len(imgs) < 12:
        return None, f"{len(imgs)} decodable frames (at least 12 needed)"
    R_cb = rec.camera.mount.R_cam_to_body
    down_cam = R_cb.T @ np.array([0.0, 0.0, 1.0])  # body down seen from the camera
    plane = down_cam if down_cam[2] > math.cos(math.radians(45.0)) else None  # looking down: ground plane
    fr = frame_rotations(ts, imgs, rec.camera.camera, plane_normal_cam=plane)
    t, _, w = _imu(rec)
    try:
        center = wide_offset(t, w, fr.t_pairs, fr.rotvec) if getattr(rec, "frames_own_clock", False) else 0.0
        cal = calibrate_camera_imu(t, w, fr.t_pairs, fr.rotvec, rec.camera.mount.R_cam_to_body,
                                   min(max_offset_s, 0.05) if center else max_offset_s, center_s=center)
    except ValueError as exc:
        return None, str(exc)
    cal.extra["frames"] = fr
    ok = np.all(np.isfinite(fr.rotvec), axis=1)
    tp = fr.t_pairs[ok]
    cal.extra["psi"] = (gyro_rotvecs(t, w, tp, cal.offset_s) - cal.gyro_bias * np.diff(tp, axis=1)) / np.diff(tp, axis=1)
    return cal, None


def _check_camera(rec, out: CheckResult, max_frames: int | None) -> None:
    cal, why = camera_imu(rec, max_frames=max_frames)
    for k in ("camera_time_offset_s", "camera_time_offset_sigma_s", "camera_imu_rotation_error_deg",
              "camera_imu_rotation_sigma_deg"):
        out.summary[k] = None
    if cal is None:
        out.add("camera vs IMU", NA, why, "frames and an IMU with rotation")
        return
    declared = rec.camera.time_offset_s if rec.camera else 0.0
    exc = float(np.linalg.norm(cal.excitation_deg))
    out.plots["camera"] = cal
    if cal.rotation_sigma_deg > 5 or cal.coarse.peak < 0.5:
        out.add("camera vs IMU", NA, f"rotation per frame interval {exc:.3f} deg RMS, rate correlation "
                f"{cal.coarse.peak:.2f}, rotation sigma {cal.rotation_sigma_deg:.1f} deg", "turns entered and left")
        return
    amb = _translation_ambiguity(rec, cal) if not np.any(cal.extra["frames"].method == "homography") else None
    if amb is not None and amb > 0.3 * exc:
        out.add("camera vs IMU", NA, f"the translation looks like {amb:.2f} deg of rotation per frame pair against "
                f"{exc:.2f} deg of rotation (a distant scene: rotation and translation cannot be told apart); found "
                f"{cal.rotation_error_deg:.1f} deg, offset {cal.offset_s * 1e3:.0f} ms", "rotation dominating")
        return
    s = out.summary
    s["camera_time_offset_s"], s["camera_time_offset_sigma_s"] = cal.offset_s, cal.offset_sigma_s
    s["camera_imu_rotation_error_deg"], s["camera_imu_rotation_sigma_deg"] = (cal.rotation_error_deg,
                                                                              cal.rotation_sigma_deg)
    s["camera_imu_rotation_estimated"] = cal.R_imu_cam.tolist()
    bad_r = cal.rotation_error_deg > max(2.0, 3 * cal.rotation_sigma_deg)
    out.add("camera-to-IMU rotation", PROBLEM if bad_r else OK,
            f"{cal.rotation_error_deg:.2f} +- {cal.rotation_sigma_deg:.2f} deg from the declared mount "
            f"({cal.intervals} frame pairs, residual {cal.residual_deg:.3f} deg)", "< 2 deg (or within 3 sigma)")
    d = cal.offset_s - declared
    bad_t = abs(d) > max(0.005, 3 * cal.offset_sigma_s) and not getattr(rec, "frames_own_clock", False)
    out.add("camera clock offset", PROBLEM if bad_t else OK,
            f"{cal.offset_s * 1e3:.1f} +- {cal.offset_sigma_s * 1e3:.1f} ms (t_imu = t_camera + offset; declared "
            f"{declared * 1e3:.1f} ms)", "within 5 ms of the declared")
    _check_focal(rec, out, cal)


def _translation_ambiguity(rec, cal) -> float | None:
    """RMS |v| dt / h per frame pair [deg]: how much rotation the translation over a distant scene (height h
    from the truth or the GPS) can mimic; None without a velocity and a height."""
    src = rec.truth if rec.truth is not None and "vn_mps" in rec.truth else rec.streams.get("gps")
    if src is None or "vn_mps" not in src:
        return None
    h = -np.asarray(src["d_m"], float)
    if not np.all(h > 1.0):
        return None
    tp = cal.extra["frames"].t_pairs
    v = np.column_stack([np.interp(tp[:, 0], src["t_s"], src[k]) for k in ("vn_mps", "ve_mps", "vd_mps")])
    hh = np.interp(tp[:, 0], src["t_s"], h)
    return float(np.degrees(np.sqrt(np.mean((np.linalg.norm(v, axis=1) * np.diff(tp, axis=1)[:, 0] / hh) ** 2))))


def _check_focal(rec, out: CheckResult, cal) -> None:
    """Focal length scale s (f' = s f) that best maps the tracks through the gyro's rotation."""
    import cv2

    fr = cal.extra["frames"]
    cam = rec.camera.camera
    psi = gyro_rotvecs(*_imu(rec)[::2], fr.t_pairs, cal.offset_s) - cal.gyro_bias * np.diff(fr.t_pairs, axis=1)
    rc = psi @ cal.R_imu_cam  # the camera's rotation per pair, camera frame
    big = [i for i in np.argsort(-np.linalg.norm(rc, axis=1))[:20]
           if fr.tracks[i] is not None and np.linalg.norm(rc[i]) > math.radians(0.5)]
    if len(big) < 5:
        out.summary["focal_scale"] = None
        out.add("focal length", NA, f"{len(big)} frame pairs rotate more than 0.5 deg", "at least 5")
        return
    scales = np.linspace(0.7, 1.3, 61)
    cost = np.zeros(len(scales))
    for k, s in enumerate(scales):
        K = cam.K.copy()
        K[0, 0] *= s
        K[1, 1] *= s
        for i in big:
            uv1, uv2 = fr.tracks[i]
            x1 = cv2.undistortPoints(uv1.reshape(-1, 1, 2), K, np.asarray(cam.dist)).reshape(-1, 2)
            b = np.column_stack([x1, np.ones(len(x1))]) @ cv2.Rodrigues(rc[i])[0]  # p2 = R^T p1
            uv = cv2.projectPoints(b, np.zeros(3), np.zeros(3), K, np.asarray(cam.dist))[0].reshape(-1, 2)
            cost[k] += float(np.median(np.linalg.norm(uv - uv2, axis=1)))
    s = float(scales[int(np.argmin(cost))])
    out.summary["focal_scale"] = s
    out.add("focal length", OK if abs(s - 1) < 0.1 else WARN, f"{s:.2f} x declared ({len(big)} rotating pairs)",
            "within 10 % of the declared")


def _raw_mag(rec) -> np.ndarray | None:
    f = Path(rec.path) / "magnetometer.csv"
    if not f.is_file():
        return None

    m = read_csv(f, STREAMS["magnetometer"])
    return np.column_stack([m["t_s"], m["mx"], m["my"], m["mz"]]) if "mx" in m else None


def _check_heading(rec, out: CheckResult) -> None:
    """Magnetometer headings against the gyro's yaw: psi_dot = (q sin(phi) + r cos(phi)) / cos(theta)
    integrated (roll, pitch from the attitude, else level), compared after removing a constant (the gyro
    bias taken from the gyro vs attitude fit when it was determined, else a linear drift fitted too); a
    hard-iron offset leaves an error that turns with the heading."""
    m = rec.streams.get("magnetometer")
    if m is None or "heading_rad" not in m or "imu" not in rec.streams or len(m["t_s"]) < 20:
        out.add("heading vs gyro", NA, "no magnetometer heading and IMU", "magnetometer.csv and imu.csv")
        return
    t, _, w = _imu(rec)
    att = _attitude(rec)
    if att is not None:
        ta, C, _ = att
        e = np.array([[math.atan2(c[2, 1], c[2, 2]), -math.asin(np.clip(c[2, 0], -1, 1))] for c in C])
        phi, th = np.interp(t, ta, e[:, 0]), np.interp(t, ta, e[:, 1])
    else:
        phi = th = np.zeros_like(t)
    bias = out.plots.get("gyro_bias")  # from the gyro vs attitude fit when it was determined
    if bias is not None:
        w = w - bias
    rate = (w[:, 1] * np.sin(phi) + w[:, 2] * np.cos(phi)) / np.cos(th)
    yaw = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])
    tm = np.asarray(m["t_s"], float)
    ok = (tm >= t[0]) & (tm <= t[-1]) & np.isfinite(m["heading_rad"])
    tm, h = tm[ok], np.unwrap(np.asarray(m["heading_rad"], float)[ok])
    if len(tm) < 20:
        out.add("heading vs gyro", NA, f"{len(tm)} headings inside the IMU's span", "at least 20")
        return
    d = h - np.interp(tm, t, yaw)
    res = d - (d.mean() if bias is not None else np.polyval(np.polyfit(tm, d, 1), tm))
    how = "a constant (gyro bias from the attitude fit)" if bias is not None else "a constant and a drift"
    turned = float(np.degrees(np.ptp(np.interp(tm, t, yaw))))
    rms = float(np.degrees(np.sqrt(np.mean(res**2))))
    out.summary["heading_gyro_rms_deg"] = rms
    status = OK if rms < 5 else (WARN if rms < 10 or turned < 90 else PROBLEM)
    out.add("heading vs gyro", status, f"{rms:.1f} deg RMS after {how} ({turned:.0f} deg of yaw "
            "flown)", "< 5 deg (an error turning with the heading: hard iron)")


def _check_mag(rec, out: CheckResult) -> None:
    _check_heading(rec, out)
    out.summary["mag_offset"] = None
    raw = _raw_mag(rec)
    if raw is None:
        out.add("magnetometer", NA, "no magnetometer field vectors (mx, my, mz)", "field vectors")
        return
    t, m = raw[:, 0], raw[:, 1:]
    A = np.column_stack([2 * m, np.ones(len(m))])
    y = (m**2).sum(1)
    cond = np.linalg.cond(A[:, :3] - A[:, :3].mean(0))
    att = _attitude(rec)
    if cond < 30:
        sol = np.linalg.lstsq(A, y, rcond=None)[0]
        o = sol[:3]
        r = math.sqrt(max(sol[3] + o @ o, 0.0))
        how = "sphere fit"
    elif att is not None:  # levelled circle: the horizontal field turns with the heading only
        ta, C, _ = att
        from scipy.spatial.transform import Rotation, Slerp

        Cm = Slerp(ta, Rotation.from_matrix(C))(np.clip(t, ta[0], ta[-1])).as_matrix()
        # the offset o is in body axes: m_n = C (m_b), so fit m_b = C^T h + o with the horizontal h turning
        # (a linear problem in o and the constant world field h_n: m_b = C^T h_n + o)
        rows = np.concatenate([np.concatenate([Cm.transpose(0, 2, 1), np.repeat(np.eye(3)[None], len(t), 0)], 2)])
        sol = np.linalg.lstsq(rows.reshape(-1, 6), m.reshape(-1), rcond=None)[0]
        o, r = sol[3:], float(np.linalg.norm(sol[:3]))
        how = "field-and-offset fit with the attitude"
    else:
        out.add("magnetometer", NA, "the flight covers too few directions and there is no attitude", "turns")
        return
    out.summary["mag_offset"] = o.tolist()
    out.plots["mag"] = (m, o, r)
    rel = float(np.linalg.norm(o) / max(r, 1e-12))
    out.add("magnetometer hard iron", PROBLEM if rel > 0.1 else OK,
            f"offset {np.round(o, 3).tolist()} ({rel * 100:.0f} % of the field {r:.3g}, {how})",
            "offset < 10 % of the field")


def _check_gps(rec, out: CheckResult) -> None:
    out.summary["gps_latency_s"] = None
    att = _attitude(rec)
    if "gps" not in rec.streams or att is None:
        out.add("GPS vs IMU", NA, "needs gps and an attitude", "gps.csv and attitude")
        return
    g = rec.streams["gps"]
    tg = g["t_s"]
    if len(tg) < 20:
        out.add("GPS vs IMU", NA, f"{len(tg)} GPS fixes", "at least 20")
        return
    v = np.column_stack([g["vn_mps"], g["ve_mps"], g["vd_mps"]])
    t, f, _ = _imu(rec)
    ta, C, _ = att
    from scipy.spatial.transform import Rotation, Slerp

    Ci = Slerp(ta, Rotation.from_matrix(C))(np.clip(t, ta[0], ta[-1])).as_matrix()
    an = np.einsum("kij,kj->ki", Ci, f) + np.array([0.0, 0.0, G])
    # velocity changes over +-m fixes (a matched filter: the same window on both sides): GPS differences
    # against the integrated IMU acceleration over the same window moved by the candidate latency
    V = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (an[1:] + an[:-1]) * np.diff(t)[:, None], axis=0)])
    m = max(int(round(0.5 / float(np.median(np.diff(tg))))), 1)
    k = np.arange(m, len(tg) - m)
    lags = np.arange(-0.5, 0.5001, 0.01)
    inside = (tg[k - m] - 0.5 > t[0]) & (tg[k + m] + 0.5 < t[-1])
    k = k[inside]
    if len(k) < 20:
        out.add("GPS vs IMU", NA, f"{len(k)} GPS fixes inside the IMU's span", "at least 20")
        return
    dv_g = (v[k + m] - v[k - m])[:, :2]
    if np.std(dv_g) < 0.1:
        out.add("GPS vs IMU", NA, f"horizontal velocity changes {np.std(dv_g):.3f} m/s RMS per {2 * m} fixes",
                "manoeuvres")
        return
    rho = []
    for lag in lags:  # GPS stamps late by `lag`: the GPS at tg saw the motion of tg - lag
        Va = np.column_stack([np.interp(tg[k + m] - lag, t, V[:, j]) - np.interp(tg[k - m] - lag, t, V[:, j])
                              for j in range(2)])
        rho.append(np.corrcoef(Va.ravel(), dv_g.ravel())[0, 1])
    rho = np.array(rho)
    j = int(np.clip(np.argmax(rho), 1, len(lags) - 2))
    den = rho[j - 1] - 2 * rho[j] + rho[j + 1]
    lat = float(lags[j] + (0.5 * (rho[j - 1] - rho[j + 1]) / den * 0.01 if den < 0 else 0.0))
    out.summary["gps_latency_s"] = lat
    out.plots["gps"] = (lags, rho)
    out.add("GPS latency", OK if abs(lat) < 0.2 and rho.max() > 0.5 else WARN,
            f"{lat * 1e3:.0f} ms (correlation {rho.max():.2f})", "|latency| < 200 ms, correlation > 0.5")


def run_check(rec, max_frames: int | None = None) -> CheckResult:
    """Every check of the module docstring on an opened recording."""
    out = CheckResult(summary={"problems": []})
    _check_streams(rec, out)
    if "imu" in rec.streams and len(rec.streams["imu"]["t_s"]) > 20:
        _check_imu_axes(rec, out)
        _check_camera(rec, out, max_frames)
        _check_gps(rec, out)
    else:
        out.summary.update(imu_axes=None, camera_time_offset_s=None, camera_time_offset_sigma_s=None,
                           camera_imu_rotation_error_deg=None, camera_imu_rotation_sigma_deg=None,
                           gps_latency_s=None)
        out.add("IMU", NA, "no IMU stream", "imu.csv")
    _check_mag(rec, out)
    out.summary.setdefault("imu_rate_hz", None)
    out.summary.setdefault("camera_rate_hz", None)
    return out


# ------------------------------------------------------------------------------------------ output
def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def _plots(res: CheckResult) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figs = []
    if res.plots.get("dt"):
        fig, ax = plt.subplots(1, len(res.plots["dt"]), figsize=(3 * len(res.plots["dt"]), 2.6), squeeze=False)
        for a, (n, d) in zip(ax[0], res.plots["dt"].items()):
            a.hist(d * 1e3, bins=40 if np.ptp(d) > 1e-9 else 1)
            a.set_title(n, fontsize=9)
            a.set_xlabel("interval [ms]")
        fig.tight_layout()
        figs.append(("Sample intervals per stream", _png(fig)))
    cal = res.plots.get("camera")
    if cal is not None:
        fr = cal.extra["frames"]
        fig, ax = plt.subplots(3, 1, figsize=(9, 6), sharex=True)
        ok = np.all(np.isfinite(fr.rotvec), axis=1)
        tp = fr.t_pairs[ok]
        dt = np.diff(tp, axis=1)
        cam = fr.rotvec[ok] @ cal.R_imu_cam.T / dt
        gyr = cal.extra.get("psi")
        for j in range(3):
            ax[j].plot(tp[:, 0] + cal.offset_s, np.degrees(cam[:, j]), "C1.-", lw=0.8, label="camera (aligned)")
            ax[j].set_ylabel(f"{'xyz'[j]} [deg/s]")
        if gyr is not None:
            for j in range(3):
                ax[j].plot(tp[:, 0] + cal.offset_s, np.degrees(gyr[:, j]), "k-", lw=0.8, label="gyro")
        ax[0].legend(fontsize=8)
        ax[2].set_xlabel("t [s] (IMU clock; camera axes turned into the IMU's by the estimated rotation)")
        fig.tight_layout()
        figs.append(("Gyro vs camera rotation rates after alignment", _png(fig)))
        if cal.taus is not None:
            fig, ax = plt.subplots(figsize=(6, 2.6))
            ax.plot(cal.taus * 1e3, cal.residual_ss, "k-")
            ax.axvline(cal.offset_s * 1e3, color="C3")
            ax.set_xlabel("offset [ms]")
            ax.set_ylabel("hand-eye residual")
            fig.tight_layout()
            figs.append(("Clock offset: hand-eye residual per candidate", _png(fig)))
    if "gravity" in res.plots:
        fig, ax = plt.subplots(figsize=(4, 2.6))
        ax.bar(["x", "y", "z"], res.plots["gravity"])
        ax.set_ylabel("mean specific force [m/s^2]")
        fig.tight_layout()
        figs.append(("Gravity direction at rest (FRD: z = -9.8)", _png(fig)))
    if "mag" in res.plots:
        m, o, r = res.plots["mag"]
        fig, ax = plt.subplots(1, 2, figsize=(7, 3.2))
        for a, (i, j) in zip(ax, ((0, 1), (0, 2))):
            a.plot(m[:, i], m[:, j], ".", ms=2)
            a.plot(o[i], o[j], "r+", ms=12)
            a.set_aspect("equal")
            a.set_xlabel("xyz"[i])
            a.set_ylabel("xyz"[j])
        fig.tight_layout()
        figs.append(("Magnetometer ellipse (red: fitted offset)", _png(fig)))
    if "gps" in res.plots:
        lags, rho = res.plots["gps"]
        fig, ax = plt.subplots(figsize=(6, 2.6))
        ax.plot(lags * 1e3, rho)
        ax.set_xlabel("GPS latency [ms]")
        ax.set_ylabel("correlation")
        fig.tight_layout()
        figs.append(("GPS vs IMU acceleration correlation", _png(fig)))
    return figs


def write_check(res: CheckResult, out_dir: Path, title: str) -> dict:
    """``check.json`` (the summary keys plus the table) and ``check.html`` (table and plots)."""

    out_dir.mkdir(parents=True, exist_ok=True)
    doc = jsonable({**res.summary, "checks": [dict(zip(("check", "status", "measured", "expected"), r))
                                               for r in res.rows]})
    (out_dir / "check.json").write_text(json.dumps(doc, indent=2))
    colour = {OK: "#2a2", WARN: "#c80", PROBLEM: "#c22", NA: "#888"}
    rows = "".join(f"<tr><td>{escape(n)}</td><td style='color:{colour[s]}'><b>{s}</b></td><td>{escape(str(m))}</td>"
                   f"<td>{escape(str(e))}</td></tr>" for n, s, m, e in res.rows)
    imgs = "".join(f"<h3>{escape(t)}</h3><img src='data:image/png;base64,{p}'>" for t, p in _plots(res))
    probs = "".join(f"<li>{escape(p)}</li>" for p in res.summary["problems"]) or "<li>none</li>"
    (out_dir / "check.html").write_text(
        f"<html><head><meta charset='utf-8'><title>{escape(title)}</title></head><body><h1>{escape(title)}</h1>"
        f"<h2>Problems</h2><ul>{probs}</ul><table border=1 cellpadding=4><tr><th>check</th><th>status</th>"
        f"<th>measured</th><th>expected</th></tr>{rows}</table>{imgs}</body></html>")
    return doc
