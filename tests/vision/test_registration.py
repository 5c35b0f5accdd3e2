import cv2
import numpy as np
import pytest

from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.sensors.camera import ground_homography
from visnav.vision.registration import MapRegistration, ncc_to_likelihood
from visnav.world.maps import GeoImage

K = np.array([[463.0, 0, 191.5], [0, 463.0, 143.5], [0, 0, 1]])
MOUNT = FixedMount.depressed(90, lever_arm=(0.3, 0.0, 0.4))


def _worlds(seed=0):
    rng = np.random.default_rng(seed)
    base = cv2.GaussianBlur(rng.normal(0, 1, (400, 400)).astype(np.float32), (0, 0), 3.0)
    base = cv2.normalize(base, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    fine = cv2.resize(base, (1600, 1600), interpolation=cv2.INTER_CUBIC)  # 0.25 m/px world
    world = GeoImage(fine, 200.0 - 0.125, -200.0 + 0.125, 0.25)
    ref = GeoImage(base, 200.0 - 0.5, -200.0 + 0.5, 1.0)  # 1 m/px reference, same extent
    return world, ref


def _frame(world, pos, euler):
    cam, C = MOUNT.camera_pose(pos, euler_to_dcm(euler))
    return cv2.warpPerspective(world.image, ground_homography(K, cam, C, world.affine(0)), (384, 288),
                               flags=cv2.INTER_LINEAR)


@pytest.mark.parametrize("euler", [[0.0, 0.0, 0.0], [0.05, -0.04, 0.7]])
def test_ncc_peak_at_known_shift(euler):
    world, ref = _worlds()
    pos = np.array([12.3, -20.6, -60.0])
    img = _frame(world, pos, euler)
    reg = MapRegistration(ref, K, MOUNT).register(img, np.array(euler), 60.0 - 0.4 * np.cos(euler[0]),
                                                  pos[:2] + [7.0, -5.0], radius_m=15.0)
    assert reg.ok and reg.peak > 0.8
    np.testing.assert_allclose(reg.peak_ne, pos[:2], atol=1.0)  # within one reference pixel
    # the surface sampled at the truth is near its peak; the likelihood peaks there too
    v = reg.sample(np.array([[pos[0]]]), np.array([[pos[1]]]), fill=-1.0)
    assert v[0, 0] > reg.peak - 0.15
    L = ncc_to_likelihood(reg.ncc, gain=10.0, floor=1e-3)
    assert L.max() == pytest.approx(1.001)


def test_textureless_frame_gives_no_registration():
    _, ref = _worlds()
    rng = np.random.default_rng(1)
    water = np.clip(80 + rng.normal(0, 2.0, (288, 384)), 0, 255).astype(np.uint8)
    reg = MapRegistration(ref, K, MOUNT).register(water, np.zeros(3), 60.0, [0.0, 0.0], 15.0)
    assert not reg.ok and "textureless" in reg.reason


def test_window_off_the_map():
    world, ref = _worlds()
    img = _frame(world, np.array([0.0, 0.0, -60.0]), [0, 0, 0])
    reg = MapRegistration(ref, K, MOUNT).register(img, np.zeros(3), 60.0, [1000.0, 0.0], 15.0)
    assert not reg.ok and "outside" in reg.reason
