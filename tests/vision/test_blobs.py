"""Blob centroids, undistorted bearings and bearing rates (seed 003 §5.1, eq. 2.25, 5.3-5.7)."""

import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.sensors.led_camera import LedCamera
from visnav.estimation.deck import camera_rotation
from visnav.scenarios.config_deck import DIST_EQ_5_6_5_7
from visnav.vision.blobs import BearingTracker, find_blobs, pixels_to_bearings

CAM = PinholeCamera(752, 480, 420.0, 420.0, 375.5, 239.5, DIST_EQ_5_6_5_7)


def test_centroids_of_gaussian_spots_are_subpixel():
    img = np.full((120, 160), 20, np.uint8)
    yy, xx = np.mgrid[0:120, 0:160]
    pts = np.array([[40.3, 30.7], [100.8, 80.2], [130.5, 20.5]])
    f = np.zeros(img.shape)
    for u, v in pts:
        f = np.maximum(f, 230 * np.exp(-((xx - u) ** 2 + (yy - v) ** 2) / (2 * 1.3**2)))
    img = np.clip(img + f, 0, 255).astype(np.uint8)
    c = find_blobs(img, threshold=150)
    c = c[np.argsort(c[:, 0])]
    np.testing.assert_allclose(c, pts[np.argsort(pts[:, 0])], atol=0.1)  # thresholding biases < 0.1 px
    assert find_blobs(np.zeros((10, 10), np.uint8)).shape == (0, 2)
    with pytest.raises(ValueError, match="grayscale"):
        find_blobs(np.zeros((0, 3)))


def test_bearings_of_rendered_lights_match_geometry():
    T = camera_rotation(np.radians(43.5), np.radians(-3.4))
    rho = np.array([0.101, 0.008, 0.11])
    cam = LedCamera(CAM, T, rho, np.random.default_rng(0), noise_gray=2.0)
    lights = np.array([[0.9, -0.1, 1.1], [1.1, 0.1, 1.0], [1.0, 0.3, 0.95], [0.8, 0.35, 1.2]])
    img = cam.render(np.zeros(3), np.eye(3), lights, lights[:3] + 0.5)
    uv = find_blobs(img)
    assert len(uv) == 4
    b = pixels_to_bearings(uv, CAM)
    s = (lights - rho) @ T.T
    want = np.stack([np.arctan(s[:, 0] / s[:, 2]), np.arctan(s[:, 1] / s[:, 2])], axis=-1)
    d = np.abs(b[:, None, :] - want[None]).max(axis=-1)
    assert np.all(d.min(axis=1) < np.radians(0.05))  # each blob within 0.05 deg of its light


def test_rates_from_frame_to_frame_matching_and_new_blobs():
    tr = BearingTracker(PinholeCamera.ideal(640, 480, 500.0))
    f0 = tr.from_pixels(0.0, np.array([[100.0, 100.0], [300.0, 200.0]]))
    assert np.all(np.isnan(f0.rates))
    f1 = tr.from_pixels(0.1, np.array([[305.0, 200.0], [101.0, 100.0], [500.0, 400.0], [np.nan, 3.0]]))
    assert len(f1.bearings) == 3  # NaN row dropped
    b0 = np.arctan((np.array([[300.0, 200.0], [100.0, 100.0]]) - [319.5, 239.5]) / 500.0)
    np.testing.assert_allclose(f1.rates[:2], (f1.bearings[:2] - b0) / 0.1, rtol=1e-12)
    assert np.all(np.isnan(f1.rates[2]))  # a new blob has no rate (§3.1.2)


def test_centroid_noise_moves_each_spot_by_its_sigma():
    """LedCamera's centroid noise (the camera's property): blob centroids scatter about the noiseless ones by
    sigma (0.3 px; the render alone adds 0.025 px, so the scatter is hypot(0.3, 0.025) within sampling error)."""
    T = camera_rotation(np.radians(43.5), np.radians(-3.4))
    rho = np.array([0.101, 0.008, 0.11])
    lights = np.array([[0.9, -0.1, 1.1], [1.1, 0.1, 1.0], [1.0, 0.3, 0.95], [0.8, 0.35, 1.2]])
    clean = LedCamera(CAM, T, rho, np.random.default_rng(0), noise_gray=0.0)
    ref = find_blobs(clean.render(np.zeros(3), np.eye(3), lights, lights[:3] + 0.5))
    ref = ref[np.argsort(ref[:, 0])]
    noisy = LedCamera(CAM, T, rho, np.random.default_rng(0), noise_gray=0.0, centroid_noise_px=0.3,
                      jitter_rng=np.random.default_rng(1))
    d = []
    for _ in range(150):
        uv = find_blobs(noisy.render(np.zeros(3), np.eye(3), lights, lights[:3] + 0.5))
        uv = uv[np.argsort(uv[:, 0])]
        d.append(uv - ref)
    d = np.concatenate(d)
    assert np.std(d) == pytest.approx(0.3, rel=0.1)
    assert abs(np.mean(d)) < 4 * 0.3 / np.sqrt(d.size)


def test_led_projection_and_bearings_agree_with_opencv():
    """The lens distortion is applied once when the lights are drawn and removed once for the bearings:
    pixels equal cv2.projectPoints and bearings equal cv2.undistortPoints with the same K and distortion (a
    real, singly distorted image gives the right bearings; applying it twice on both sides would cancel in
    the closed loop and be off by up to ~0.03 rad at the field edge on a real image)."""
    import cv2

    T = camera_rotation(np.radians(43.5), np.radians(-3.4))
    rho = np.array([0.101, 0.008, 0.11])
    cam = LedCamera(CAM, T, rho, np.random.default_rng(0), noise_gray=0.0)
    rng = np.random.default_rng(3)
    s_want = np.column_stack([rng.uniform(-0.7, 0.7, (40, 2)), np.ones(40)]) * rng.uniform(1.0, 5.0, (40, 1))
    pts_ned = s_want @ T + rho  # camera frame -> body (= NED here: vehicle at the origin, level)
    uv, inside = cam.project(pts_ned, np.zeros(3), np.eye(3))
    K = np.array([[CAM.fx, 0, CAM.cx], [0, CAM.fy, CAM.cy], [0, 0, 1.0]])
    dist = np.asarray(CAM.dist, float)
    ref, _ = cv2.projectPoints(s_want.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, dist)
    assert inside.sum() > 20
    np.testing.assert_allclose(uv[inside], ref.reshape(-1, 2)[inside], atol=1e-6)
    b = pixels_to_bearings(uv[inside], CAM)
    want = np.arctan(s_want[inside, :2] / s_want[inside, 2:3])
    np.testing.assert_allclose(b, want, atol=1e-7)
    xy_cv = cv2.undistortPoints(uv[inside].reshape(-1, 1, 2), K, dist,
                                criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)).reshape(-1, 2)
    np.testing.assert_allclose(b, np.arctan(xy_cv), atol=1e-6)


def _find_blobs_reference(img, threshold=150, min_area=2, max_area=2000):
    """find_blobs as it was before speed round 4 (cv2.findNonZero over the thresholded frame)."""
    import cv2

    _, mask = cv2.threshold(img, threshold, 1, cv2.THRESH_BINARY)
    pts = cv2.findNonZero(mask)
    if pts is None:
        return np.zeros((0, 2))
    u0, v0, w, h = cv2.boundingRect(pts)
    sub_mask, sub = mask[v0:v0 + h, u0:u0 + w], img[v0:v0 + h, u0:u0 + w]
    n, labels, stats, _ = cv2.connectedComponentsWithStats(sub_mask, connectivity=8)
    vs, us = np.nonzero(labels)
    lab = labels[vs, us]
    wgt = sub[vs, us].astype(float) - threshold
    sw = np.bincount(lab, weights=wgt, minlength=n)
    cu = np.bincount(lab, weights=wgt * (us + u0), minlength=n)
    cv = np.bincount(lab, weights=wgt * (vs + v0), minlength=n)
    area = stats[:, cv2.CC_STAT_AREA]
    keep = np.arange(n)[1:]
    keep = keep[(area[keep] >= min_area) & (area[keep] <= max_area) & (sw[keep] > 0)]
    return np.stack([cu[keep] / sw[keep], cv[keep] / sw[keep]], axis=-1)


def test_find_blobs_equals_the_full_frame_reference():
    """find_blobs boxes the bright pixels by the rows, then the columns, above the threshold (no full-frame
    mask): the same centroids, in the same order, to the last bit, as the cv2.findNonZero version it
    replaced (spots anywhere, at the edges, none, touching; integer and fractional thresholds)."""
    rng = np.random.default_rng(0)
    for k in range(300):
        h, w = (int(x) for x in rng.integers(8, 120, 2))
        img = rng.integers(0, 140, (h, w), dtype=np.uint8)
        for _ in range(int(rng.integers(0, 6))):
            u, v = rng.integers(0, w), rng.integers(0, h)
            r = int(rng.integers(0, 4))
            img[max(v - r, 0):v + r + 1, max(u - r, 0):u + r + 1] = rng.integers(140, 256)
        thr = [150, 140, 139.5, 0, 254, 255][k % 6]
        got, ref = find_blobs(img, thr), _find_blobs_reference(img, thr)
        assert got.shape == ref.shape
        assert np.array_equal(got.view(np.int64), ref.view(np.int64))
