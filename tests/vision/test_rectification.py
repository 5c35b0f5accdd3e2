"""Seed 004 ch. 3: rectification against the pinhole projection, LUT calibration, eq. 3.25 partials."""

import math

import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.sensors.gimbal import centred_coords, project_points
from visnav.vision.distortion_lut import full_lut, synthetic_board, thesis_lut
from visnav.vision.rectification import (CameraGeometry, altimeter_correction, estimate_range, ground_range,
                                         roll_correct, tilt_rectification, vision_bearing)
from visnav.vision.rectification_errors import error_maps, radius_chain, radius_partials

W, H, F = 640, 480, 640.0
CAM = PinholeCamera.ideal(W, H, F)
GEOM = CameraGeometry.from_focal(W, H, F, F)


def _targets(rng, n, h, tilt, pan, roll):
    """Ground points that fall inside the image of a camera at (0, 0, -h) and their (X, Y)."""
    # shoot rays through random pixels and keep those that hit the ground
    uv = np.stack([rng.uniform(5, W - 5, 4 * n), rng.uniform(5, H - 5, 4 * n)], 1)
    from visnav.sensors.gimbal import camera_dcm

    rays = CAM.unproject(uv) @ camera_dcm(pan, tilt, roll)  # OpenCV -> NED
    down = rays[:, 2]
    keep = down > 0.05
    pts = np.array([0, 0, -h]) + rays[keep] * (h / down[keep])[:, None]
    pts = pts[:n]
    X, Y = centred_coords(CAM, project_points(CAM, [0, 0, -h], pan, tilt, roll, pts))
    return pts, X, Y


def test_straight_down_exact():
    h = 80.0
    rng = np.random.default_rng(1)
    pts, X, Y = _targets(rng, 50, h, -math.pi / 2, 0.3, 0.0)
    D, L, _, _ = ground_range(X, Y, h, -math.pi / 2, 0.0, GEOM, "exact")
    np.testing.assert_allclose(D, np.hypot(pts[:, 0], pts[:, 1]), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(L, np.linalg.norm(pts - [0, 0, -h], axis=1), rtol=1e-9)


@pytest.mark.parametrize("tilt_deg,roll_deg", [(-20, 0), (-30, 4), (-40, -11), (-60, 2), (-85, 0)])
def test_exact_ground_range_for_projected_targets(tilt_deg, roll_deg):
    h, pan = 100.0, math.radians(37.0)
    tilt, roll = math.radians(tilt_deg), math.radians(roll_deg)
    pts, X, Y = _targets(np.random.default_rng(tilt_deg + 100), 60, h, tilt, pan, roll)
    D, L, DX, DY = ground_range(X, Y, h, tilt, roll, GEOM, "exact")
    np.testing.assert_allclose(D, np.hypot(pts[:, 0], pts[:, 1]), rtol=1e-8)
    # eq. 3.23: bearing from the camera heading
    psi_vb, psi_b = vision_bearing(DX, DY, gimbal_yaw=0.1, sideslip=0.02)
    true_b = np.arctan2(pts[:, 1], pts[:, 0]) - pan
    np.testing.assert_allclose(np.angle(np.exp(1j * (psi_vb - true_b))), 0.0, atol=1e-8)
    np.testing.assert_allclose(psi_b - psi_vb, 0.12)


def test_tilt_rectification_is_misulia_exact():
    """Eq. 3.14-3.17 sum to h tan(eta + theta_Y) for every tilt and pixel row."""
    h = 55.0
    for tilt in np.radians([-89.9, -60, -45, -30, -15]):
        Y = np.linspace(-H / 2, H / 2, 41)
        D_Y, L_Y = tilt_rectification(Y, tilt, h, GEOM)
        ang = math.pi / 2 + tilt + np.arctan(Y / GEOM.fy)
        ok = ang < math.pi / 2 - 1e-6
        np.testing.assert_allclose(D_Y[ok], h * np.tan(ang[ok]), rtol=1e-9)
        assert np.all(np.isnan(D_Y[~ok]))


def test_thesis_method_differs_only_by_pan_and_roll():
    h, tilt = 100.0, math.radians(-35)
    pts, X, Y = _targets(np.random.default_rng(5), 80, h, tilt, 0.0, 0.0)
    D_th = ground_range(X, Y, h, tilt, 0.0, GEOM, "thesis")[0]
    rel = D_th / np.hypot(pts[:, 0], pts[:, 1]) - 1
    centre = np.abs(X) < 2
    np.testing.assert_allclose(rel[centre], 0.0, atol=1e-3)  # no pan: identical
    assert 1e-3 < np.abs(rel).max() < 0.2  # the linear pan law of eq. 3.20 is an approximation


def test_roll_rotation_vs_printed():
    X, Y, phi = np.array([100.0]), np.array([50.0]), math.radians(10)
    xr, yr = roll_correct(X, Y, phi, "exact")
    assert math.isclose(float(np.hypot(xr, yr)[0]), float(np.hypot(X, Y)[0]), rel_tol=1e-12)  # a rotation
    xt, yt = roll_correct(X, Y, phi, "thesis")
    assert abs(xt[0] - xr[0]) > 1.0  # the garbled line is not


def test_altimeter_correction_eq_2_1():
    assert altimeter_correction(100.0, 15.0) == pytest.approx(100.0 * (1 - 0.004 * 100.0))
    assert altimeter_correction(100.0, 25.0) == pytest.approx(100.0 * (1 - 0.0035 * 100.0))


def test_bad_input_gives_no_estimate():
    cases = [
        (dict(X=0, Y=0, h=100, tilt=0.0, roll=0), "horizon"),
        (dict(X=0, Y=0, h=100, tilt=0.2, roll=0), "horizon"),
        (dict(X=0, Y=0, h=0.0, tilt=-0.5, roll=0), "altitude"),
        (dict(X=0, Y=0, h=-3.0, tilt=-0.5, roll=0), "altitude"),
        (dict(X=400, Y=0, h=100, tilt=-0.5, roll=0), "outside"),
        (dict(X=0, Y=math.nan, h=100, tilt=-0.5, roll=0), "not finite"),
        (dict(X=0, Y=230, h=100, tilt=math.radians(-15), roll=0), "horizon"),  # ray above the horizon
    ]
    for kw, word in cases:
        r = estimate_range(geom=GEOM, **kw)
        assert not r.valid and word in r.reason, (kw, r)
        assert math.isfinite(r.ground_range)
    ok = estimate_range(0.0, 0.0, 100.0, math.radians(-45), 0.0, GEOM)
    assert ok.valid and ok.ground_range == pytest.approx(100.0)


@pytest.mark.parametrize("method", ["exact", "thesis"])
def test_partials_match_finite_differences(method):
    rng = np.random.default_rng(3)
    n = 30
    X, Y = rng.uniform(-300, 300, n), rng.uniform(-230, 0, n)
    h, tilt, roll = rng.uniform(50, 150, n), np.radians(rng.uniform(-60, -25, n)), np.radians(rng.uniform(-5, 5, n))
    D, g = radius_partials(X, Y, h, tilt, roll, GEOM, method)
    np.testing.assert_allclose(D, ground_range(X, Y, h, tilt, roll, GEOM, method)[0], rtol=1e-12)
    base = [h, tilt, roll, X, Y]
    steps = [1e-3, 1e-6, 1e-6, 1e-3, 1e-3]
    for k in range(5):
        up, dn = list(base), list(base)
        up[k] = base[k] + steps[k]
        dn[k] = base[k] - steps[k]
        fd = (radius_chain(up[3], up[4], up[0], up[1], up[2], GEOM, method)
              - radius_chain(dn[3], dn[4], dn[0], dn[1], dn[2], GEOM, method)) / (2 * steps[k])
        np.testing.assert_allclose(g[k], fd, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(g[0], D / h, rtol=1e-12)  # D_T is linear in h


def test_error_maps_grow_towards_horizon():
    m20, m40 = error_maps(GEOM, 100.0, -20.0), error_maps(GEOM, 100.0, -40.0)
    assert np.isnan(m20["total"]).any() and not np.isnan(m40["total"]).any()  # -20 deg sees the horizon
    centre = (m40["X_px"] == 0) & (m40["Y_px"] == 0)
    # at the image centre of a -40 deg camera at 100 m: dD/dh = D/h = 1/tan(40 deg)
    assert m40["h"][centre][0] == pytest.approx(1 / math.tan(math.radians(40)), rel=1e-9)
    assert np.nanmax(m20["tilt"]) > np.nanmax(m40["tilt"]) > 0


def test_lut_calibration_corrects_distortion():
    cam = PinholeCamera(W, H, F, F, (W - 1) / 2 + 14.0, (H - 1) / 2 - 8.0, (-0.28, 0.08, 0, 0, 0, 0, 0, 0))
    geom = CameraGeometry.from_focal(W, H, F, F)
    board = synthetic_board(cam, 2.0, 0.04)
    ours, th = full_lut(board, geom), thesis_lut(board, geom)
    # check points: a fresh board with other marks
    chk = synthetic_board(cam, 3.0, 0.11)
    ideal_x, ideal_y = geom.fx * chk.dx / chk.distance, geom.fy * chk.dy / chk.distance
    xo, yo = ours.correct(chk.Xm, chk.Ym)
    err_ours = np.hypot(xo - ideal_x, yo - ideal_y)
    err_raw = np.hypot(chk.Xm - ideal_x, chk.Ym - ideal_y)
    xt, yt = th.correct(chk.Xm, chk.Ym)
    err_th = np.hypot(xt - ideal_x, yt - ideal_y)
    assert err_raw.max() > 40.0  # strong barrel distortion in the corners
    assert np.median(err_ours) < 0.3 and err_ours.max() < 3.0
    # the mirrored quadrant cannot see the crop offset: worse than ours, better than nothing at the edges
    assert np.median(err_th) > 5 * np.median(err_ours)


def test_lut_one_point_path_equals_the_interpolator():
    """``DistortionLUT.correct`` of one point (scalar bilinear, the per-frame call) gives the same bits as
    the array path (scipy's ``RegularGridInterpolator``), inside the table, on its grid lines and
    extrapolated beyond it, for both table kinds."""
    cam = PinholeCamera(W, H, F, F, (W - 1) / 2 + 14.0, (H - 1) / 2 - 8.0, (-0.28, 0.08, 0, 0, 0, 0, 0, 0))
    board = synthetic_board(cam, 2.0, 0.04)
    rng = np.random.default_rng(3)
    for lut in (full_lut(board, GEOM), thesis_lut(board, GEOM)):
        assert lut._scalar_ok
        on_grid = np.c_[rng.choice(lut.gx, 40) * W / 2, rng.choice(lut.gy, 40) * H / 2]
        pts = np.r_[np.c_[rng.uniform(-1.3, 1.3, 400) * W / 2, rng.uniform(-1.3, 1.3, 400) * H / 2], on_grid]
        xa, ya = lut.correct(pts[:, 0], pts[:, 1])  # array path
        n_diff = 0
        for (x, y), ex, ey in zip(pts, xa, ya):
            x1, y1 = lut.correct(np.array([x]), np.array([y]))
            assert x1.shape == (1,) and y1.shape == (1,)
            n_diff += (x1[0] != ex) + (y1[0] != ey)
        assert n_diff == 0
    assert np.isnan(lut.correct(np.array([np.nan]), np.array([0.0]))[0][0])  # NaN stays NaN (array path)


def test_one_pixel_path_equals_the_vectorised_chain_bit_for_bit():
    """``estimate_range``'s scalar chain (``_ground_range_1``) against ``ground_range`` on arrays: the same
    D_T, L_T, D_X, D_Y and bearing bits (NaN where it gives NaN), both methods, rays above and below the
    horizon; ``altimeter_correction`` of one float against its array path."""
    import math

    import numpy as np

    from visnav.vision.rectification import (CameraGeometry, _ground_range_1, altimeter_correction, ground_range,
                                             vision_bearing)

    geom = CameraGeometry(640, 480, math.radians(26.5), math.atan(math.tan(math.radians(26.5)) * 480 / 640))
    rng = np.random.default_rng(3)
    n = 4000
    X, Y = rng.uniform(-320, 320, n), rng.uniform(-240, 240, n)
    h, tilt, roll = rng.uniform(1.0, 300.0, n), rng.uniform(-1.6, 0.3, n), rng.normal(0.0, 0.3, n)
    for method in ("exact", "thesis"):
        want = ground_range(X, Y, h, tilt, roll, geom, method)
        bearing = vision_bearing(want[2], want[3])[0]
        for i in range(n):
            got = _ground_range_1(float(X[i]), float(Y[i]), float(h[i]), float(tilt[i]), float(roll[i]), geom, method)
            ref = tuple(float(w[i]) for w in want)
            assert np.array_equal(got, ref, equal_nan=True), (i, got, ref)
            if math.isfinite(got[0]):
                assert float(np.arctan2(got[2], got[3])) == float(bearing[i])
    hb = rng.uniform(0.0, 400.0, 500)
    arr = altimeter_correction(hb, 20.0, 0.0004, 5e-06)
    assert all(altimeter_correction(float(v), 20.0, 0.0004, 5e-06) == a for v, a in zip(hb, arr))
