import numpy as np
import pytest

from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.vision.odometry import VisualOdometry, displacement_from_homography

K = np.array([[463.0, 0, 192], [0, 463.0, 144], [0, 0, 1]])
MOUNT = FixedMount.depressed(90)


def _plane_h(c1, e1, c2, e2):
    _, C1 = MOUNT.camera_pose(c1, euler_to_dcm(e1))
    _, C2 = MOUNT.camera_pose(c2, euler_to_dcm(e2))
    n = np.array([0, 0, 1.0])
    d = -c1[2]
    H = K @ C2.T @ (np.eye(3) - np.outer(c2 - c1, n) / d) @ C1 @ np.linalg.inv(K)
    return H / H[2, 2], C1, C2, d


def test_eq_5_9_recovers_known_translation():
    c1, c2 = np.array([10.0, 5.0, -60.0]), np.array([13.0, 3.0, -60.5])
    H, C1, C2, d = _plane_h(c1, [0.05, -0.03, 0.4], c2, [0.02, 0.04, 0.45])
    np.testing.assert_allclose(displacement_from_homography(H, K, C1, C2, d), c2 - c1, atol=1e-9)
    # the thesis' H33 normalization is exact without climb, approximate with it
    H0, C1, C2, d = _plane_h(c1, [0.05, -0.03, 0.4], c2 * [1, 1, 0] + [0, 0, -60], [0.02, 0.04, 0.45])
    np.testing.assert_allclose(displacement_from_homography(H0, K, C1, C2, d, "h33")[:2], [3.0, -2.0], atol=0.05)


def test_odometry_on_rendered_frames_and_too_few_inliers():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(0)
    tex = cv2.GaussianBlur(rng.integers(0, 255, (800, 800)).astype(np.uint8), (0, 0), 2.0)
    tex = cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX)
    affine = np.array([[0.0, -0.25, 100.0], [0.25, 0.0, -100.0], [0, 0, 1]])  # 0.25 m/px map
    from visnav.sensors.camera import ground_homography

    vo = VisualOdometry(K, rng=np.random.default_rng(1))
    poses = [(np.array([0.0, 0.0, -60.0]), [0.0, 0.0, 0.3]), (np.array([2.0, 1.0, -60.0]), [0.02, -0.01, 0.32])]
    steps = []
    for k, (p, e) in enumerate(poses):
        cam, C = MOUNT.camera_pose(p, euler_to_dcm(e))
        img = cv2.warpPerspective(tex, ground_homography(K, cam, C, affine), (384, 288))
        steps.append(vo.step(float(k), img, C, -cam[2]))
    assert steps[0] is None
    assert steps[1].ok and steps[1].n_inliers >= 30
    np.testing.assert_allclose(steps[1].displacement[:2], [2.0, 1.0], atol=0.1)
    # a blank frame: no features -> skipped with the reason
    blank = np.full((288, 384), 90, np.uint8)
    cam, C = MOUNT.camera_pose(poses[1][0], euler_to_dcm(poses[1][1]))
    s = vo.step(2.0, blank, C, 60.0)
    assert s is not None and not s.ok and "(< 8)" in s.reason
