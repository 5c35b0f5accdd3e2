"""`visnav check` (issue 29) on recordings written here with known faults, and on EuRoC V1_01.

The synthetic recording: a nadir camera over a textured plane under pure rotation (frames rendered as
K R K^-1 warps, so the frame rotations are exact up to tracking), a gyro of turns entered and left
plus a steady yaw, the accelerometer and attitude.csv consistent with it, and a magnetometer. Each
fault is put into the files and must come out named in ``problems``; the clean one has none."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tests.shared_data import missing_reason, shared_data_dir
from visnav.analysis.check import run_check, write_check
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import dcm_to_euler
from visnav.io.recording import Recording, write_camera_yaml, write_csv

EUROC = shared_data_dir() / "euroc_v1_01"
G = 9.80665


def _write(d, *, flip_gyro_x=False, swap_accel_xy=False, mount_err_deg=0.0, shift_s=0.0, mag_offset=(0, 0, 0),
           n_frames=36):
    d.mkdir(parents=True)
    t = np.arange(0.0, 4.0, 0.005)
    w = np.column_stack([0.25 * np.sin(2 * np.pi * 1.1 * t), 0.2 * np.sin(2 * np.pi * 0.7 * t + 1.0),
                         0.6 + 0.2 * np.sin(2 * np.pi * 0.9 * t)])
    rots = [Rotation.identity()]
    for k in range(1, len(t)):
        rots.append(rots[-1] * Rotation.from_rotvec(0.5 * (w[k] + w[k - 1]) * 0.005))
    C = np.array([r.as_matrix() for r in rots])  # body -> NED
    f = C.transpose(0, 2, 1) @ np.array([0.0, 0.0, -G])
    gw, fa = w.copy(), f.copy()
    if flip_gyro_x:
        gw[:, 0] *= -1
    if swap_accel_xy:
        fa[:, [0, 1]] = fa[:, [1, 0]]
    write_csv(d / "imu.csv", {"t_s": t, "ax_mps2": fa[:, 0], "ay_mps2": fa[:, 1], "az_mps2": fa[:, 2],
                              "gx_radps": gw[:, 0], "gy_radps": gw[:, 1], "gz_radps": gw[:, 2]})
    e = dcm_to_euler(C)
    write_csv(d / "attitude.csv", {"t_s": t[::2], "roll_rad": e[::2, 0], "pitch_rad": e[::2, 1], "yaw_rad": e[::2, 2]})
    m = C.transpose(0, 2, 1) @ np.array([0.2, 0.0, 0.45]) + np.asarray(mag_offset, float)
    write_csv(d / "magnetometer.csv", {"t_s": t[::4], "mx": m[::4, 0], "my": m[::4, 1], "mz": m[::4, 2]})
    cam = PinholeCamera(320, 240, 250.0, 250.0, 159.5, 119.5)
    true = FixedMount.depressed(90.0)
    R_err = Rotation.from_rotvec(np.radians(mount_err_deg) * np.array([1.0, 0.0, 0.0])).as_matrix()
    write_camera_yaml(d / "camera.yaml", cam, FixedMount(R_err @ true.R_cam_to_body, np.zeros(3)))
    rng = np.random.default_rng(3)
    tex = cv2.GaussianBlur(rng.integers(0, 256, (240, 320)).astype(np.uint8), (0, 0), 1.5)
    (d / "frames").mkdir()
    tf = 0.3 + np.arange(n_frames) * 0.05  # true instants (IMU clock)
    R_bc = true.R_cam_to_body
    C0 = C[0]
    files = []
    for k, tk in enumerate(tf):
        Ck = Rotation.from_matrix(C[np.searchsorted(t, tk)]).as_matrix()
        R = R_bc.T @ C0.T @ Ck @ R_bc  # camera k's orientation in camera 0's frame
        H = cam.K @ R.T @ np.linalg.inv(cam.K)  # p_k = R^T p_0 (pure rotation)
        img = cv2.warpPerspective(tex, H, (320, 240), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
        files.append(f"frames/{k:04d}.png")
        cv2.imwrite(str(d / files[-1]), img)
    write_csv(d / "frames.csv", {"t_s": tf - shift_s, "file": np.array(files), "index": np.arange(n_frames)})
    return Recording.open(d)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    rec = _write(tmp_path_factory.mktemp("chk") / "clean")
    return rec, run_check(rec)


def test_clean_recording_has_no_problem(clean, tmp_path):
    rec, res = clean
    s = res.summary
    assert s["problems"] == [], s["problems"]
    assert s["imu_axes"] == "FRD"
    assert s["imu_rate_hz"] == pytest.approx(200.0) and s["camera_rate_hz"] == pytest.approx(20.0)
    assert abs(s["camera_time_offset_s"]) < 0.003 and s["camera_imu_rotation_error_deg"] < 1.0
    assert np.linalg.norm(s["mag_offset"]) < 0.02
    doc = write_check(res, tmp_path, "clean")
    for k in ("problems", "imu_rate_hz", "camera_rate_hz", "imu_axes", "camera_time_offset_s",
              "camera_time_offset_sigma_s", "camera_imu_rotation_error_deg", "camera_imu_rotation_sigma_deg",
              "mag_offset", "gps_latency_s"):
        assert k in doc and k in json.loads((tmp_path / "check.json").read_text())
    assert "data:image/png;base64" in (tmp_path / "check.html").read_text()


def _problems(tmp_path, **fault):
    rec = _write(tmp_path / "r", **fault)
    if not any(k in fault for k in ("mount_err_deg", "shift_s")):
        del rec.streams["frames"]  # the camera is not what this fault is about (saves the tracking)
    return run_check(rec).summary


def test_wrong_sign_of_one_gyro_axis_is_named(tmp_path):
    s = _problems(tmp_path, flip_gyro_x=True)
    assert any("gyro axes look x sign flipped" in p for p in s["problems"]), s["problems"]


def test_swapped_accelerometer_axes_are_named(tmp_path):
    s = _problems(tmp_path, swap_accel_xy=True)
    assert any("accelerometer axes look x/y swapped" in p for p in s["problems"]), s["problems"]


def test_mount_error_of_10_deg_is_found(tmp_path):
    s = _problems(tmp_path, mount_err_deg=10.0)
    assert s["camera_imu_rotation_error_deg"] == pytest.approx(10.0, abs=1.0)
    assert any(p.startswith("camera-to-IMU rotation") for p in s["problems"]) and len(s["problems"]) == 1


def test_camera_clock_shift_of_80_ms_is_found(tmp_path):
    s = _problems(tmp_path, shift_s=0.08)  # frame stamps 80 ms early: t_imu = t_camera + 0.08
    assert s["camera_time_offset_s"] == pytest.approx(0.08, abs=0.003)
    assert any(p.startswith("camera clock offset") for p in s["problems"]) and len(s["problems"]) == 1


def test_magnetometer_offset_is_found(tmp_path):
    s = _problems(tmp_path, mag_offset=(0.15, -0.1, 0.05))
    np.testing.assert_allclose(s["mag_offset"], [0.15, -0.1, 0.05], atol=0.02)
    assert any(p.startswith("magnetometer hard iron") for p in s["problems"]), s["problems"]


@pytest.mark.slow
@pytest.mark.skipif(not EUROC.is_dir(), reason=missing_reason(EUROC))
def test_euroc_v1_01_camera_calibration_agrees():
    from visnav.io.logs import open_recording

    s = run_check(open_recording(EUROC)).summary
    assert s["camera_imu_rotation_error_deg"] <= 2.0 and abs(s["camera_time_offset_s"]) <= 0.005
    assert not any("camera" in p for p in s["problems"])
