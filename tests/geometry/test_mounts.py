from __future__ import annotations

import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount, PanTiltMount
from visnav.geometry.rotations import euler_to_dcm

CAM = PinholeCamera.ideal()
H = 10.0
AHEAD = H / np.tan(np.radians(60.0))  # ground distance of the optical-axis point


def _centre_px(mount, position, euler, ground_point):
    p_cam = mount.world_to_camera(np.atleast_2d(ground_point), position, euler_to_dcm(euler))
    return CAM.project(p_cam)[0]


def test_depressed_mount_axes():
    R = FixedMount.depressed(60.0).R_cam_to_body
    d = np.radians(60.0)
    np.testing.assert_allclose(R[:, 2], [np.cos(d), 0, np.sin(d)], atol=1e-15)  # optical axis
    np.testing.assert_allclose(R[:, 0], [0, 1, 0], atol=1e-15)  # image right = body right
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)
    # Looking straight down, the top of the image is the nose (image y = body -x).
    np.testing.assert_allclose(FixedMount.depressed(90.0).R_cam_to_body[:, 1], [-1, 0, 0], atol=1e-15)


def test_level_vehicle_sees_ground_point_at_image_centre():
    mount = FixedMount.depressed(60.0)
    uv = _centre_px(mount, [0.0, 0.0, -H], [0.0, 0.0, 0.0], [AHEAD, 0.0, 0.0])
    np.testing.assert_allclose(uv, [CAM.cx, CAM.cy], atol=1e-9)
    # A point further ahead appears higher in the image, one to the right appears right.
    far, right = CAM.project(
        mount.world_to_camera(np.array([[AHEAD + 5, 0, 0], [AHEAD, 1, 0]]), [0, 0, -H], np.eye(3))
    )
    assert far[1] < CAM.cy and right[0] > CAM.cx


def test_yaw_90_moves_the_centre_point_east():
    mount = FixedMount.depressed(60.0)
    uv = _centre_px(mount, [3.0, -2.0, -H], [0.0, 0.0, np.pi / 2], [3.0, -2.0 + AHEAD, 0.0])
    np.testing.assert_allclose(uv, [CAM.cx, CAM.cy], atol=1e-9)


def test_ray_through_centre_hits_ground_ahead():
    mount = FixedMount.depressed(60.0)
    cam_pos, C_cn = mount.camera_pose(np.array([0.0, 0.0, -H]), euler_to_dcm([0, 0, 0.3]))
    axis_ned = C_cn @ [0.0, 0.0, 1.0]
    t = -cam_pos[2] / axis_ned[2]
    np.testing.assert_allclose(cam_pos + t * axis_ned, [AHEAD * np.cos(0.3), AHEAD * np.sin(0.3), 0], atol=1e-12)


def test_pitch_up_is_less_depression():
    # Nose up 10 deg on a 60 deg mount: the optical axis is 50 deg below the horizon.
    mount = FixedMount.depressed(60.0)
    ahead = H / np.tan(np.radians(50.0))
    uv = _centre_px(mount, [0.0, 0.0, -H], [0.0, np.radians(10.0), 0.0], [ahead, 0.0, 0.0])
    np.testing.assert_allclose(uv, [CAM.cx, CAM.cy], atol=1e-9)


def test_lever_arm_is_rotated_with_the_body():
    lever = np.array([0.5, 0.1, 0.2])  # forward, right, down of the reference point
    mount = FixedMount.depressed(60.0, lever_arm=lever)
    h_cam = H - lever[2]
    # Level, heading north.
    uv = _centre_px(mount, [0.0, 0.0, -H], [0, 0, 0], [lever[0] + h_cam / np.tan(np.radians(60)), lever[1], 0])
    np.testing.assert_allclose(uv, [CAM.cx, CAM.cy], atol=1e-9)
    # Heading east: the forward lever arm now points east, the right one south.
    cam_pos, _ = mount.camera_pose(np.array([0.0, 0.0, -H]), euler_to_dcm([0, 0, np.pi / 2]))
    np.testing.assert_allclose(cam_pos, [-lever[1], lever[0], -H + lever[2]], atol=1e-12)


def test_camera_pose_vectorized_over_leading_axis():
    rng = np.random.default_rng(31)
    mount = FixedMount.depressed(45.0, lever_arm=(0.3, 0.0, 0.1))
    pos = rng.normal(size=(5, 3))
    C = euler_to_dcm(rng.uniform(-0.5, 0.5, (5, 3)))
    cam_pos, C_cn = mount.camera_pose(pos, C)
    for i in range(5):
        ci, Ri = mount.camera_pose(pos[i], C[i])
        np.testing.assert_allclose(cam_pos[i], ci, atol=1e-15)
        np.testing.assert_allclose(C_cn[i], Ri, atol=1e-15)


def test_pan_tilt_equals_fixed_mount_at_zero_pan():
    pt = PanTiltMount(pan=0.0, tilt=np.radians(60.0), lever_arm=(0.2, 0.0, 0.1))
    fixed = FixedMount.depressed(60.0, lever_arm=(0.2, 0.0, 0.1))
    np.testing.assert_allclose(pt.R_cam_to_body, fixed.R_cam_to_body, atol=1e-15)
    C = euler_to_dcm([0.1, -0.2, 1.3])
    p = np.array([4.0, 5.0, -20.0])
    for a, b in zip(pt.camera_pose(p, C), fixed.camera_pose(p, C)):
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_pan_90_looks_right():
    pt = PanTiltMount(pan_limits=(-np.pi, np.pi))
    pt.set(np.pi / 2, np.radians(60.0))
    uv = CAM.project(pt.world_to_camera(np.array([[0.0, AHEAD, 0.0]]), [0, 0, -H], np.eye(3)))[0]
    np.testing.assert_allclose(uv, [CAM.cx, CAM.cy], atol=1e-9)


def test_pan_tilt_clamps_to_limits():
    pt = PanTiltMount(pan_limits=(-1.0, 1.0), tilt_limits=(0.0, np.pi / 2))
    pt.set(2.5, -0.3)
    assert (pt.pan, pt.tilt) == (1.0, 0.0)
    pt.tilt = 3.0
    assert pt.tilt == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(pt.R_cam_to_body[:, 2], [0, 0, 1], atol=1e-15)  # straight down


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: FixedMount(np.diag([1.0, 1.0, -1.0])), "R_cam_to_body"),
        (lambda: FixedMount(np.eye(3) * 2), "R_cam_to_body"),
        (lambda: FixedMount(np.eye(3), lever_arm=(1.0, 2.0)), "lever_arm"),
        (lambda: FixedMount.depressed(np.nan), "depression_deg"),
        (lambda: PanTiltMount(pan_limits=(1.0, -1.0)), "pan_limits"),
        (lambda: PanTiltMount(tilt=np.nan), "tilt"),
    ],
)
def test_bad_input_raises(make, name):
    with pytest.raises(ValueError, match=name):
        make()


def test_world_to_camera_bad_shape():
    with pytest.raises(ValueError, match="points_ned"):
        FixedMount.depressed(60.0).world_to_camera(np.zeros((3, 2)), np.zeros(3), np.eye(3))
