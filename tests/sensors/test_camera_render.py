"""Rendered frames put ground points where the pinhole model projects them (DESIGN §5)."""

import cv2
import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.sensors.camera import CameraRenderer
from visnav.world.maps import GeoImage
from visnav.world.scene import World
from visnav.world.wind import SteadyWind, Wind

CAM = PinholeCamera.ideal(640, 480, 1073.0)


def _dot_world(points_ne, res=0.02, size=1501):
    img = np.full((size, size), 60, np.uint8)
    g = GeoImage(img, north0=(size - 1) / 2 * res, east0=-(size - 1) / 2 * res, resolution_m=res)
    for n, e in points_ne:
        c, r = g.ned_to_pixel(np.array([[n, e]]))[0]
        cv2.circle(img, (int(round(c)), int(round(r))), 4, 255, -1)
    return World(ground=GeoImage(img, g.north0, g.east0, res), surface="concrete", wind=Wind(SteadyWind(0, 0)))


def _blob_centroids(frame):
    _, bw = cv2.threshold(frame, 150, 255, cv2.THRESH_BINARY)
    n, _, stats, cent = cv2.connectedComponentsWithStats(bw)
    return cent[1:][stats[1:, cv2.CC_STAT_AREA] > 3]


@pytest.mark.parametrize("pose", [
    ([-8.0, 0.0, -14.0], [0.0, 0.0, 0.0]),
    ([-5.0, 1.0, -9.0], [0.03, -0.05, 0.2]),
    ([-3.0, -1.0, -6.0], [-0.04, 0.06, -0.3]),
])
def test_ground_points_render_where_they_project(pose):
    pts = [(0.0, 0.0), (1.5, 1.0), (-1.0, -1.5), (2.0, -2.0)]
    world = _dot_world(pts)
    mount = FixedMount.depressed(60.0)
    pos, eul = np.array(pose[0]), np.array(pose[1])
    cam_pos, C_cn = mount.camera_pose(pos, euler_to_dcm(eul))
    frame = CameraRenderer(CAM, noise_sigma=0.0, rng=np.random.default_rng(0)).render(cam_pos, C_cn, world)
    found = _blob_centroids(frame)
    p_c = (C_cn.T @ (np.array([[n, e, 0.0] for n, e in pts]) - cam_pos).T).T
    uv = CAM.project(p_c)
    vis = uv[CAM.in_image(uv, margin=10)]
    assert len(vis) >= 2 and len(found) == len(vis)
    for p in vis:
        d = np.min(np.linalg.norm(found - p, axis=1))
        assert d < 0.6, f"blob {p} rendered {d:.2f} px away"


def test_sky_above_horizon_and_noise_statistics():
    world = _dot_world([])
    mount = FixedMount.depressed(0.0)  # looking at the horizon: the upper half is sky
    cam_pos, C_cn = mount.camera_pose(np.array([0.0, 0.0, -5.0]), np.eye(3))
    r = CameraRenderer(CAM, noise_sigma=3.0, rng=np.random.default_rng(1))
    f = r.render(cam_pos, C_cn, world).astype(float)
    assert abs(f[:200].mean() - world.sky_level) < 1.0
    assert abs(f[:200].std() - 3.0) < 0.3
    assert abs(f[300:].mean() - 60) < 2.0


def test_noise_is_the_bank_added_with_saturation():
    """The noise pass (two uint8 passes: + the bank's positive part, - its negative part) equals the int16 bank
    added to the noise-free frame and saturated to [0, 255], pixel for pixel, where it clips at both ends."""
    img = np.tile(np.linspace(0, 255, 1501).astype(np.uint8), (1501, 1))  # black to white: both ends clip
    res = 0.02
    world = World(ground=GeoImage(img, 750 * res, -750 * res, res), surface="concrete", wind=Wind(SteadyWind(0, 0)))
    cam_pos, C_cn = FixedMount.depressed(90.0).camera_pose(np.array([0.0, 0.0, -12.0]), np.eye(3))
    clean = CameraRenderer(CAM, noise_sigma=0.0, rng=np.random.default_rng(0)).render(cam_pos, C_cn, world)
    r = CameraRenderer(CAM, noise_sigma=40.0, rng=np.random.default_rng(5))
    draw = np.random.default_rng(0)
    draw.bit_generator.state = r.rng.bit_generator.state  # the offsets render() will draw
    noisy = r.render(cam_pos, C_cn, world)
    k = int(draw.integers(0, r._noise.shape[0]))
    dy, dx = (int(x) for x in draw.integers(0, r._pad, 2))
    want = np.clip(clean.astype(int) + r._noise[k, dy:dy + 480, dx:dx + 640], 0, 255).astype(np.uint8)
    assert noisy.dtype == np.uint8 and np.array_equal(noisy, want)
    assert (noisy == 0).sum() > 100 and (noisy == 255).sum() > 100 and (r._noise < -50).any()


def test_blended_levels_are_the_two_levels_weighted_whatever_the_order_they_are_asked_in():
    """Trilinear sampling: level L blended with level L + 1 (upsampled) at q/8; the upsampled level is made once
    per L and shared by the weights, each blend equal to the blend made from scratch."""
    rng = np.random.default_rng(3)
    ground = GeoImage(rng.integers(0, 256, (256, 256), dtype=np.uint8), 12.8, -12.8, resolution_m=0.1)
    r = CameraRenderer(PinholeCamera.ideal(), 0.0, rng)
    for L, q in [(0, 3), (1, 5), (0, 7), (1, 1), (0, 3)]:
        lo = ground.level(L)
        up = cv2.resize(ground.level(L + 1), (lo.shape[1], lo.shape[0]), interpolation=cv2.INTER_LINEAR)
        assert np.array_equal(r._blended_level(ground, L, q), cv2.addWeighted(lo, 1 - q / 8, up, q / 8, 0.0))
    assert r._blended_level(ground, 1, 0) is ground.level(1)
