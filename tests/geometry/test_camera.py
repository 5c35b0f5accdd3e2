from __future__ import annotations

import cv2
import numpy as np
import pytest

from visnav.geometry.camera import (
    BLUEFOX_DIST,
    PinholeCamera,
    ground_sample_distance,
    ray_plane_intersection,
)

RANDOM_DIST = (-0.28, 0.09, 0.0012, -0.0007, 0.02, 0.05, -0.01, 0.004)


def _seed003_camera(f: float = 1073.0) -> PinholeCamera:
    return PinholeCamera(640, 480, f, f * 1.002, 321.3, 238.1, BLUEFOX_DIST)


def _pixel_grid(cam: PinholeCamera, step: float = 4.0) -> np.ndarray:
    u = np.append(np.arange(-0.5, cam.width - 0.5, step), cam.width - 0.5)
    v = np.append(np.arange(-0.5, cam.height - 0.5, step), cam.height - 0.5)
    uu, vv = np.meshgrid(u, v)
    return np.column_stack([uu.ravel(), vv.ravel()])


def test_ideal_camera_intrinsics():
    cam = PinholeCamera.ideal()
    assert (cam.width, cam.height, cam.cx, cam.cy) == (640, 480, 319.5, 239.5)
    np.testing.assert_array_equal(cam.K, [[1073.0, 0, 319.5], [0, 1073.0, 239.5], [0, 0, 1]])
    assert not cam.has_distortion
    assert _seed003_camera().has_distortion


def test_project_ideal_closed_form_and_behind_camera():
    cam = PinholeCamera.ideal()
    p = np.array([[0.0, 0.0, 5.0], [1.0, -0.5, 10.0], [1.0, 1.0, 0.0], [1.0, 1.0, -3.0]])
    uv = cam.project(p)
    np.testing.assert_allclose(uv[0], [319.5, 239.5], atol=1e-12)
    np.testing.assert_allclose(uv[1], [319.5 + 107.3, 239.5 - 53.65], atol=1e-12)
    assert np.all(np.isnan(uv[2:]))


@pytest.mark.parametrize("dist", [(0.0,) * 8, BLUEFOX_DIST, RANDOM_DIST])
def test_project_unproject_round_trip(dist):
    rng = np.random.default_rng(21)
    cam = PinholeCamera(640, 480, 500.0, 510.0, 322.0, 241.0, dist)
    p = np.column_stack([rng.uniform(-0.5, 0.5, 300), rng.uniform(-0.4, 0.4, 300), np.ones(300)])
    p *= rng.uniform(1.0, 100.0, (300, 1))
    rays = cam.unproject(cam.project(p))
    np.testing.assert_allclose(rays[:, 2], 1.0)
    np.testing.assert_allclose(rays * p[:, 2:], p, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("dist", [BLUEFOX_DIST, RANDOM_DIST, (-0.3, 0.1, 0, 0, 0, 0, 0, 0)])
def test_distortion_matches_cv2_project_points(dist):
    rng = np.random.default_rng(22)
    cam = PinholeCamera(640, 480, 420.0, 425.0, 318.0, 243.0, dist)
    xy = rng.uniform(-0.8, 0.8, (500, 2))
    obj = np.column_stack([xy, np.ones(len(xy))])
    ref, _ = cv2.projectPoints(obj, np.zeros(3), np.zeros(3), cam.K, np.array(cam.dist))
    np.testing.assert_allclose(cam.normalized_to_pixel(xy), ref.reshape(-1, 2), atol=1e-9)
    np.testing.assert_allclose(cam.project(obj * 7.0), ref.reshape(-1, 2), atol=1e-9)


def test_distortion_single_radial_term_closed_form():
    k1 = -0.3
    cam = PinholeCamera(640, 480, 500.0, 500.0, 319.5, 239.5, (k1, 0, 0, 0, 0, 0, 0, 0))
    xy = np.array([[0.3, -0.4]])  # r^2 = 0.25
    np.testing.assert_allclose(cam.distort_normalized(xy), xy * (1 + k1 * 0.25), atol=1e-15)


@pytest.mark.parametrize("f", [1073.0, 400.0])
@pytest.mark.parametrize("dist", [BLUEFOX_DIST, (-0.3, 0.1, 0, 0, 0, 0, 0, 0)])
def test_undistortion_inverts_distortion_over_whole_image(f, dist):
    cam = PinholeCamera(640, 480, f, f, 319.5, 239.5, dist)
    uv = _pixel_grid(cam)
    xy = cam.pixel_to_normalized(uv)
    assert not np.isnan(xy).any()
    np.testing.assert_allclose(cam.normalized_to_pixel(xy), uv, atol=1e-6, rtol=0)
    # Barrel distortion: undistorted corners lie further out than the distorted ones.
    corner = np.array([[-0.5, -0.5]])
    xd = (corner - [cam.cx, cam.cy]) / f
    assert np.linalg.norm(cam.pixel_to_normalized(corner)) > np.linalg.norm(xd)


def test_undistortion_beyond_model_fold_is_nan():
    # k1 = -0.3 alone: r (1 + k1 r^2) peaks at r^2 = 1/(3*0.3); beyond that no inverse exists.
    cam = PinholeCamera(640, 480, 100.0, 100.0, 319.5, 239.5, (-0.3, 0, 0, 0, 0, 0, 0, 0))
    r_max = np.sqrt(1 / 0.9) * (1 - 0.3 / 0.9)
    xy = cam.pixel_to_normalized(np.array([[319.5 + 100 * 0.9 * r_max, 239.5], [319.5 + 100 * 1.1 * r_max, 239.5]]))
    assert np.isfinite(xy[0]).all()
    assert np.isnan(xy[1]).all()


def test_in_image():
    cam = PinholeCamera.ideal()
    uv = np.array([[-0.5, -0.5], [639.5, 479.5], [-0.6, 10], [10, 479.6], [np.nan, 1], [5, 5]])
    np.testing.assert_array_equal(cam.in_image(uv), [True, True, False, False, False, True])
    np.testing.assert_array_equal(cam.in_image(uv, margin=10.0), [False] * 6)


def test_ray_plane_intersection_closed_form():
    origin = np.array([2.0, -1.0, -10.0])
    dirs = np.array([[1.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
    pts, t = ray_plane_intersection(origin, dirs, np.zeros(3), np.array([0.0, 0.0, -2.0]))
    np.testing.assert_allclose(pts[0], [12.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(pts[1], [2.0, -1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(t[:2], [10.0, 10.0])
    assert np.isnan(t[2:]).all() and np.isnan(pts[2:]).all()  # parallel, behind


def test_ray_plane_intersection_random_tilted_plane():
    rng = np.random.default_rng(23)
    n = rng.normal(size=3)
    p0 = rng.normal(size=3)
    origin = p0 + 5.0 * n / np.linalg.norm(n)
    dirs = rng.normal(size=(100, 3))
    pts, t = ray_plane_intersection(origin, dirs, p0, n)
    hit = np.isfinite(t)
    assert hit.sum() > 20 and (~hit).sum() > 20
    np.testing.assert_allclose((pts[hit] - p0) @ n, 0.0, atol=1e-10)
    np.testing.assert_allclose(pts[hit], origin + t[hit, None] * dirs[hit], atol=1e-12)
    assert np.all(dirs[~hit] @ n >= 0)  # misses point away from the plane


def test_ground_sample_distance():
    assert ground_sample_distance(100.0, 1000.0) == pytest.approx(0.1)
    np.testing.assert_allclose(ground_sample_distance(np.array([10.0, 50.0]), 500.0), [0.02, 0.1])
    with pytest.raises(ValueError, match="f_px"):
        ground_sample_distance(10.0, 0.0)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(width=0), "width"),
        (dict(height=-3), "height"),
        (dict(fx=0.0), "fx"),
        (dict(fy=np.nan), "fy"),
        (dict(cx=np.inf), "cx"),
        (dict(dist=(0.1, 0.2)), "dist"),
        (dict(dist=(np.nan,) * 8), "dist"),
    ],
)
def test_invalid_parameters_name_the_field(kwargs, name):
    base = dict(width=640, height=480, fx=500.0, fy=500.0, cx=319.5, cy=239.5, dist=(0.0,) * 8)
    base.update(kwargs)
    with pytest.raises(ValueError, match=name):
        PinholeCamera(**base)


def test_bad_point_shape_raises():
    with pytest.raises(ValueError, match="p_cam"):
        PinholeCamera.ideal().project(np.zeros((4, 2)))


@pytest.mark.parametrize("dist", [BLUEFOX_DIST, RANDOM_DIST])
def test_undistortion_of_single_points_matches_opencv(dist):
    """One pixel at a time (the per-frame calls) against OpenCV's ``undistortPoints`` run to
    convergence, and against the same pixels in one batch; off-image pixels (some beyond the fold: NaN) give
    the same in one call and in a batch, a NaN pixel stays NaN."""
    cam = PinholeCamera(752, 480, 420.0, 421.0, 375.5, 239.5, dist)
    rng = np.random.default_rng(7)
    uv = rng.uniform([0, 0], [752, 480], (60, 2))
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    ref = cv2.undistortPoints(uv[:, None, :], cam.K, np.array(dist), None, None, None, crit)[:, 0, :]
    one = np.array([cam.pixel_to_normalized(p[None, :])[0] for p in uv])
    np.testing.assert_allclose(one, ref, atol=1e-9)
    np.testing.assert_allclose(one, cam.pixel_to_normalized(uv), rtol=1e-13, atol=1e-15)
    far = np.vstack([rng.uniform([-3000, -3000], [4000, 4000], (200, 2)), [[np.nan, 100.0]]])
    with np.errstate(all="ignore"):  # (diverging points overflow before they are rejected)
        batch = cam.pixel_to_normalized(far)
        one = np.array([cam.pixel_to_normalized(p[None, :])[0] for p in far])
    np.testing.assert_allclose(one, batch, rtol=1e-13, atol=1e-15)  # NaN where NaN
    assert np.isnan(batch[-1]).all()
    assert cam.pixel_to_normalized(np.zeros((0, 2))).shape == (0, 2)
