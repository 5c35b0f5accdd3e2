"""Feature registration of nadir views (vision/features.py) and the frame-only VO navigator (navigation/vo.py)
on views rendered here of a textured ground plane, where the true motion is known in closed form."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.geometry.camera import PinholeCamera
from visnav.measurements import Frame, GpsSample
from visnav.navigation.vo import R_CHAIN0, VOConfig, VONavigator, umeyama_2d
from visnav.vision.features import FeatureMatcher, similarity_of

RES = 0.1  # ground texture metres per pixel
CAM = PinholeCamera.ideal(480, 360, 400.0)


@pytest.fixture(scope="module")
def texture():
    """A 200 m x 200 m ground: blobs and noise at several scales (no repetition)."""
    rng = np.random.default_rng(3)
    n = 2000
    img = np.zeros((n, n), np.float32)
    for k, amp in ((3, 1.0), (9, 0.7), (25, 0.5)):
        img += amp * cv2.GaussianBlur(rng.standard_normal((n, n)).astype(np.float32), (0, 0), k)
    img = (img - img.min()) / np.ptp(img) * 255
    return cv2.equalizeHist(img.astype(np.uint8))


def render(texture, C, yaw_deg=0.0, roll_deg=0.0, pitch_deg=0.0):
    """The view of a camera centred at C (north, east, down; ground at down 0), nadir with image top = heading
    ``yaw_deg``, tilted by roll / pitch: p ~ K R^T (P - C) for ground points P (texture pixel -> P affine)."""
    R = Rotation.from_euler("ZYX", [yaw_deg, pitch_deg, roll_deg], degrees=True).as_matrix() @ R_CHAIN0
    r0 = c0 = texture.shape[0] / 2
    A = np.array([[0, -RES, RES * r0 - C[0]], [RES, 0, -RES * c0 - C[1]], [0, 0, -C[2]]])
    H = CAM.K @ R.T @ A
    return cv2.warpPerspective(texture, H, (CAM.width, CAM.height), flags=cv2.INTER_LINEAR), R


def test_similarity_of_a_pure_translation_and_rotation(texture):
    fm = FeatureMatcher(work_width=480)
    a, _ = render(texture, (0, 0, -40))
    b, _ = render(texture, (12, 0, -40), yaw_deg=10)
    m = fm.match(fm.detect(a), fm.detect(b), CAM.K)
    assert m.ok and m.inliers > 100
    t, theta, s = similarity_of(m.H, CAM.K)
    # b's centre lies 12 m north = up in a's image: normalized (0, -12/40); b turned 10 deg; same height
    np.testing.assert_allclose(t, [0.0, -0.3], atol=0.005)
    assert math.degrees(theta) == pytest.approx(10.0, abs=0.3)
    assert s == pytest.approx(1.0, abs=0.01)


def test_unrelated_views_are_not_registered(texture):
    fm = FeatureMatcher(work_width=480)
    a, _ = render(texture, (0, 0, -40))
    far, _ = render(texture, (80, 60, -40))  # no overlap
    assert not fm.match(fm.detect(a), fm.detect(far), CAM.K).ok


def test_relative_pose_from_the_homography_with_tilt(texture):
    """The decomposition gives b's centre and tilt: b 8 m north, 3 m east, 5 m higher, rolled 6 deg."""
    nav = VONavigator(CAM, VOConfig(work_width=480))
    a, _ = render(texture, (0, 0, -40))
    b, Rb = render(texture, (8, 3, -45), yaw_deg=15, roll_deg=6)
    nav.update(Frame(0.0, a))  # the first photo: chain height 1 = 40 m, nadir
    fa, fb = nav.photos[0].feats, nav.matcher.detect(b)
    m = nav.matcher.match(fa, fb, CAM.K)
    Rw, C = nav._relative(0, m.H)
    np.testing.assert_allclose(C * 40, [8, 3, -45], atol=0.4)
    assert Rotation.from_matrix(Rw.T @ Rb).magnitude() < math.radians(0.5)


def test_umeyama_2d_recovers_a_similarity():
    rng = np.random.default_rng(0)
    X = rng.standard_normal((10, 2))
    ang = 0.7
    R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    s, Rf, tau = umeyama_2d(X, 3.5 * X @ R.T + [2.0, -1.0])
    assert s == pytest.approx(3.5) and np.allclose(Rf, R) and np.allclose(tau, [2, -1])


def test_vo_navigator_gps_then_frames_only(texture):
    """A path with a 30 deg turn: GPS for the first three photos ties the chain (scale = height, heading);
    the last photos are placed by VO alone; a photo of elsewhere is not registered and is bridged over."""
    nav = VONavigator(CAM, VOConfig(work_width=480, overlap_tries=0))
    path = [(0, 0), (10, 0), (20, 1), (29, 5), (37, 10), (45, 15)]
    yaws = [0, 0, 5, 20, 30, 30]
    for k, ((n, e), yaw) in enumerate(zip(path, yaws)):
        t = 5.0 * k
        if k < 3:
            nav.update(GpsSample(t, np.array([n, e, -40.0]), np.zeros(3), 1.0))
        if k == 4:  # an unrelated view between two photos (the link glitched): not registered
            nav.update(Frame(t - 2.5, render(texture, (-70, -70, -40))[0]))
        nav.update(Frame(t, render(texture, (n, e, -40), yaw_deg=yaw)[0]))
    est = nav.estimate(25.0)
    assert est.source == "vo"
    assert np.linalg.norm(est.position[:2] - path[-1]) < 0.6
    assert est.position[2] == pytest.approx(-40.0, abs=1.0)
    assert math.degrees(est.attitude[2]) == pytest.approx(30.0, abs=1.0)
    m = nav.replay_metrics()
    assert m["photos"] == 7 and m["pairs_registered_share"] == pytest.approx(5 / 6)
    assert m["vo_scale_m"] == pytest.approx(40.0, rel=0.02)
