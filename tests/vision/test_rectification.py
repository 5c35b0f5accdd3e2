"""Seed 004 ch. 3: rectification against the pinhole projection, LUT calibration, eq. 3.25 partials."""

import math

import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.sensors.gimbal import centred_coords, project_points
from visnav.vision.distortion_lut import DistortionLUT, full_lut, synthetic_board, thesis_lut
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


def test_lut_interpolation_is_exact_on_bilinear_tables_one_point_and_batches():
    """Eq. 3.7's linear interpolation reproduces a bilinear function a + b x + c y + d x y exactly, inside
    the table, on its grid lines and (the end cells extended) beyond it: one point (the per-frame call) and
    a batch against that closed form, both table kinds (factor: mirrored to |x|, |y|; offset: added)."""
    from visnav.vision.distortion_lut import DistortionLUT

    def f(x, y, k):
        return [1.0, 0.9][k] + [0.03, -0.05][k] * x + [-0.02, 0.04][k] * y + [0.01, 0.02][k] * x * y

    rng = np.random.default_rng(3)
    for kind, g in (("factor", np.linspace(0.0, 1.0, 11)), ("offset", np.linspace(-1.0, 1.0, 9))):
        gx, gy = np.meshgrid(g, g, indexing="ij")
        lut = DistortionLUT(kind, g, g, f(gx, gy, 0), f(gx, gy, 1), W, H)
        on_grid = np.c_[rng.choice(g, 20) * W / 2, rng.choice(g, 20) * H / 2]
        pts = np.r_[np.c_[rng.uniform(-1.3, 1.3, 200) * W / 2, rng.uniform(-1.3, 1.3, 200) * H / 2], on_grid]
        nx, ny = pts[:, 0] / (W / 2), pts[:, 1] / (H / 2)
        if kind == "factor":
            nx, ny = np.abs(nx), np.abs(ny)
            want = pts[:, 0] * f(nx, ny, 0), pts[:, 1] * f(nx, ny, 1)
        else:
            want = pts[:, 0] + f(nx, ny, 0), pts[:, 1] + f(nx, ny, 1)
        np.testing.assert_allclose(lut.correct(pts[:, 0], pts[:, 1]), want, rtol=1e-13, atol=1e-12)
        one = np.array([[v[0] for v in lut.correct(np.array([x]), np.array([y]))] for x, y in pts])
        np.testing.assert_allclose(one.T, want, rtol=1e-13, atol=1e-12)
    assert np.isnan(lut.correct(np.array([np.nan]), np.array([0.0]))[0][0])  # NaN stays NaN


def test_one_pixel_estimate_is_the_true_range_of_projected_targets():
    """``estimate_range`` (one pixel, the per-frame call) against the geometry it inverts: ground points
    projected through a pinhole camera at height h, tilt and roll give back their horizontal distance
    and bearing; ``altimeter_correction`` of one float and of an array against eq. 2.1 by hand."""
    h, tilt, roll = 120.0, math.radians(-35.0), math.radians(6.0)
    pts, X, Y = _targets(np.random.default_rng(9), 40, h, tilt, 0.0, roll)
    for p, x, y in zip(pts, X, Y):
        if abs(x) > W / 2 or abs(y) > H / 2:
            continue
        r = estimate_range(float(x), float(y), h, tilt, roll, GEOM, "exact")
        assert r.valid
        assert r.ground_range == pytest.approx(math.hypot(p[0], p[1]), rel=1e-9)
        assert r.slant_range == pytest.approx(math.sqrt(p[0] ** 2 + p[1] ** 2 + h * h), rel=1e-9)
        assert r.bearing == pytest.approx(math.atan2(p[1], p[0]), abs=1e-9)
        th = estimate_range(float(x), float(y), h, tilt, roll, GEOM, "thesis")
        want = ground_range(np.array([x]), np.array([y]), h, tilt, roll, GEOM, "thesis")[0][0]
        assert th.valid and th.ground_range == pytest.approx(want, rel=1e-14)
    hb = np.random.default_rng(2).uniform(0.0, 400.0, 50)
    want = hb * (1.0 - (0.0004 + (15.0 - 20.0) * 5e-06) * hb)
    np.testing.assert_allclose(altimeter_correction(hb, 20.0, 0.0004, 5e-06), want, rtol=1e-15)
    assert all(altimeter_correction(float(v), 20.0, 0.0004, 5e-06) == pytest.approx(w, rel=1e-15)
               for v, w in zip(hb, want))


def test_lut_interpolation_is_scipys_regular_grid_interpolator():
    """DistortionLUT's own bilinear look-up (eq. 3.7) against scipy's RegularGridInterpolator, inside and
    outside the grid (extrapolated), at 1e-12."""
    from scipy.interpolate import RegularGridInterpolator

    rng = np.random.default_rng(4)
    for kind in ("factor", "offset"):
        g0 = 0.0 if kind == "factor" else -1.0
        gx, gy = np.linspace(g0, 1.0, 9), np.linspace(g0, 1.0, 7)
        lut = DistortionLUT(kind, gx, gy, rng.normal(1, 0.1, (9, 7)), rng.normal(1, 0.1, (9, 7)), 640, 480)
        X, Y = rng.uniform(-400, 400, 300), rng.uniform(-300, 300, 300)
        got = lut.correct(X, Y)
        nx, ny = X / 320.0, Y / 240.0
        q = np.c_[np.abs(nx), np.abs(ny)] if kind == "factor" else np.c_[nx, ny]
        cx, cy = (RegularGridInterpolator((gx, gy), t, bounds_error=False, fill_value=None)(q)
                  for t in (lut.table_x, lut.table_y))
        ref = (X * cx, Y * cy) if kind == "factor" else (X + cx, Y + cy)
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-9)
        one = lut.correct(np.array([X[0]]), np.array([Y[0]]))
        assert one[0].shape == (1,) and abs(one[0][0] - got[0][0]) <= 1e-12 * abs(got[0][0])
