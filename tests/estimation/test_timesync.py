"""Camera/IMU clock offset: the correlation peak on a closed-form signal, the frame rotation on rendered views."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from visnav.estimation.timesync import (calibrate_camera_imu, estimate_offset, gyro_angles, gyro_rotvecs,
                                        rotation_angle_deg)
from visnav.vision.frame_rotation import frame_rotation_angles


def _gyro(t):
    """A body rate with turns entered and left (smooth, several time scales)."""
    return np.column_stack([0.2 * np.sin(1.3 * t) + 0.05 * np.sin(7.1 * t), 0.1 * np.sin(0.7 * t + 1) ** 3,
                            0.15 * np.tanh(np.sin(0.4 * t) * 4)])


@pytest.mark.parametrize("offset", [0.08, -0.0371])
def test_offset_recovered_from_exact_rotation_angles(offset):
    t = np.arange(0.0, 40.0, 0.005)
    w = _gyro(t)
    tc = np.arange(1.0, 39.0, 0.2)  # camera stamps, camera clock
    pairs = np.column_stack([tc[:-1], tc[1:]])
    cam = gyro_angles(t, w, pairs, [offset])[0]  # what the camera saw: the rotation at t_cam + offset
    est = estimate_offset(t, w, pairs, cam, max_offset_s=0.2, step_s=0.002)
    assert est.offset_s == pytest.approx(offset, abs=2e-4)  # grid 2 ms, parabola refines below it
    assert est.peak > 0.999


def test_offset_with_noise_has_an_honest_uncertainty():
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 40.0, 0.005)
    w = _gyro(t)
    tc = np.arange(1.0, 39.0, 0.2)
    pairs = np.column_stack([tc[:-1], tc[1:]])
    cam = gyro_angles(t, w, pairs, [0.08])[0] + rng.normal(0, 2e-3, len(pairs))
    est = estimate_offset(t, w + rng.normal(0, 2e-3, w.shape), pairs, cam, rng=rng)
    assert 0 < est.sigma_s < 0.01
    assert abs(est.offset_s - 0.08) < 4 * est.sigma_s + 1e-3


def test_flat_signal_is_refused():
    t = np.arange(0.0, 5.0, 0.01)
    with pytest.raises(ValueError, match="at least 10"):
        estimate_offset(t, np.zeros((len(t), 3)), np.array([[0.0, 0.2]] * 5), np.zeros(5))


def test_frame_rotation_from_rendered_pure_rotations():
    """Views of a textured plane under known camera rotations (homography K R K^-1): the angle comes back."""
    rng = np.random.default_rng(2)
    tex = cv2.GaussianBlur(rng.integers(0, 256, (480, 640)).astype(np.uint8), (0, 0), 2.0)
    K = np.array([[500.0, 0, 319.5], [0, 500.0, 239.5], [0, 0, 1]])
    angles = [0.0, 0.02, 0.05, 0.03, 0.06]
    axes = [np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0.3, -0.2, 1.0])]
    R_acc = np.eye(3)
    imgs, truth = [], []
    for k, a in enumerate(angles):
        ax = axes[k % 3] / np.linalg.norm(axes[k % 3])
        R = cv2.Rodrigues(ax * a)[0]
        R_acc = R @ R_acc
        H = K @ R_acc @ np.linalg.inv(K)
        imgs.append(cv2.warpPerspective(tex, H, (640, 480), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT))
        truth.append(a)
    pairs, ang = frame_rotation_angles(np.arange(len(imgs)) * 0.2, imgs, K)
    assert pairs.shape == (4, 2)
    np.testing.assert_allclose(ang, truth[1:], atol=1.5e-3)


@pytest.mark.parametrize("offset", [0.0, -0.03, 0.08])
def test_hand_eye_rotation_offset_and_bias_recovered(offset):
    """Camera rotations = R^T (gyro rotation at t_cam + offset - bias dt) + noise: R (10 deg off the identity), the
    offset and the bias come back, the declared identity's error is the 10 deg, and the sigmas are honest."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(1)
    t = np.arange(0.0, 12.0, 0.005)
    bias = np.array([0.01, -0.02, 0.005])
    w = _gyro(t) + bias
    tc = np.arange(0.5, 11.5, 0.05)
    pairs = np.column_stack([tc[:-1], tc[1:]])
    R = Rotation.from_rotvec(np.radians(10.0) * np.array([0.6, 0.0, 0.8])).as_matrix()
    psi = gyro_rotvecs(t, w - bias, pairs, offset)
    cam = psi @ R + rng.normal(0, 2e-4, psi.shape)  # R^T psi per row
    cal = calibrate_camera_imu(t, w, pairs, cam, np.eye(3), max_offset_s=0.2)
    assert cal.offset_s == pytest.approx(offset, abs=2e-3)
    assert 0 < cal.offset_sigma_s < 3e-3
    assert rotation_angle_deg(cal.R_imu_cam @ R.T) < 0.3
    assert cal.rotation_error_deg == pytest.approx(10.0, abs=0.3)
    assert 0 < cal.rotation_sigma_deg < 0.5
    np.testing.assert_allclose(cal.gyro_bias, bias, atol=2e-3)
