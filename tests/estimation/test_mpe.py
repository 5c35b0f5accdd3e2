"""MPE (seed 000 Alg. 3/4, eq. 2.5, eq. 3.2-3.3): exactness and pixel-quantisation statistics."""

import numpy as np
import pytest

from visnav.estimation.mpe import MonocularPositionEstimator, quantisation_sigma
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.sensors.rangefinder import range_to_ground

CAM = PinholeCamera.ideal(640, 480, 1073.0)


def _view(mount, pos, euler, point):
    C_bn = euler_to_dcm(np.asarray(euler))
    cam_pos, C_cn = mount.camera_pose(np.asarray(pos), C_bn)
    p_c = C_cn.T @ (point - cam_pos)
    uv = CAM.project(p_c.reshape(1, 3))[0]
    laser = range_to_ground(cam_pos, C_cn[:, 2])
    return C_bn, uv, laser, p_c[2]


@pytest.mark.parametrize("seed", range(5))
def test_plane_model_is_exact_on_flat_ground(seed):
    rng = np.random.default_rng(seed)
    mount = FixedMount.depressed(60.0, lever_arm=(0.8, 0.0, -0.6))
    point = np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), 0.0])
    mpe = MonocularPositionEstimator(CAM, mount, model="plane")
    for k in range(4):
        h = rng.uniform(5, 30)
        eul = np.deg2rad([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-20, 20)])
        # place the vehicle so the point is in view (near the slope), then jitter
        back = -np.array([np.cos(eul[2]), np.sin(eul[2]), 0]) * h / np.tan(np.deg2rad(60))
        pos = point + back + np.array([rng.uniform(-1, 1) * 0.05 * h, rng.uniform(-1, 1) * 0.05 * h, -h])
        C_bn, uv, laser, _ = _view(mount, pos, eul, point)
        assert CAM.in_image(uv.reshape(1, 2))[0]
        if k == 0:
            ref = mpe.initialize(uv, laser, C_bn, pos)
            np.testing.assert_allclose(ref, point, atol=1e-9)
        else:
            fix = mpe.estimate(0.0, uv, laser, C_bn)
            np.testing.assert_allclose(fix.position, pos, atol=1e-9)


def test_thesis_model_exact_when_range_is_the_depth():
    mount = FixedMount.depressed(60.0)
    mpe = MonocularPositionEstimator(CAM, mount, model="thesis")
    point = np.array([1.0, -2.0, 0.0])
    poses = [([-10.0, -2.5, -17.0], [0.02, -0.03, 0.1]), ([-6.0, -1.0, -11.0], [-0.03, 0.05, -0.05])]
    for i, (pos, eul) in enumerate(poses):
        C_bn, uv, _, depth = _view(mount, np.array(pos), eul, point)
        if i == 0:
            np.testing.assert_allclose(mpe.initialize(uv, depth, C_bn, np.array(pos)), point, atol=1e-9)
        else:
            np.testing.assert_allclose(mpe.estimate(0.0, uv, depth, C_bn).position, pos, atol=1e-9)


def test_thesis_model_differs_from_plane_off_axis():
    """eq. 2.5 takes the axis range as the point's depth: wrong for an off-centre point on flat ground."""
    mount = FixedMount.depressed(60.0)  # camera 20 m over flat ground
    C_bn = np.eye(3)
    uv = np.array([CAM.cx, CAM.cy + 200.0])
    laser = 20.0 / np.sin(np.deg2rad(60))
    a = MonocularPositionEstimator(CAM, mount, "thesis").camera_offset(uv, laser, C_bn)
    b = MonocularPositionEstimator(CAM, mount, "plane").camera_offset(uv, laser, C_bn)
    assert abs(b[2] - 20.0) < 1e-9  # plane model lands on the ground
    assert abs(a[2] - 20.0) > 0.5


def test_pixel_quantisation_noise_matches_eq_3_3():
    """Floor-quantised pixels give a bias R/(2f) (eq. 3.2) and sigma R/(f sqrt 12) (eq. 3.3)."""
    rng = np.random.default_rng(7)
    mount = FixedMount.depressed(90.0)  # straight down: camera x = east, camera y = south
    mpe = MonocularPositionEstimator(CAM, mount, model="thesis")
    R = 25.0
    mpe.ground_reference = np.zeros(3)
    n = 20000
    true_x = rng.uniform(CAM.cx - 100, CAM.cx + 100, n)
    east_err = np.empty(n)
    C_bn = np.eye(3)
    for i in range(n):
        uv_true = np.array([true_x[i], CAM.cy])
        exact = mpe.estimate(0.0, uv_true, R, C_bn).position
        quant = mpe.estimate(0.0, np.array([np.floor(true_x[i]), CAM.cy]), R, C_bn).position
        east_err[i] = quant[1] - exact[1]
    sigma = quantisation_sigma(R, CAM.fx)
    assert abs(np.std(east_err) - sigma) / sigma < 0.05
    # estimate = R - offset: flooring the pixel moves the offset west, the estimate east by R/(2f)
    assert abs(np.mean(east_err) - R / (2 * CAM.fx)) / (R / (2 * CAM.fx)) < 0.05


def test_bad_range_rejected():
    mpe = MonocularPositionEstimator(CAM, FixedMount.depressed(60.0))
    with pytest.raises(ValueError, match="range"):
        mpe.camera_offset((320, 240), float("nan"), np.eye(3))
    with pytest.raises(ValueError, match="range"):
        mpe.camera_offset((320, 240), -3.0, np.eye(3))
    with pytest.raises(ValueError, match="model"):
        MonocularPositionEstimator(CAM, FixedMount.depressed(60.0), model="stereo")
