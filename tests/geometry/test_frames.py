from __future__ import annotations

import numpy as np
import pytest

from visnav.geometry.frames import LocalTangentPlane

# WGS84
A = 6378137.0
F = 1 / 298.257223563
E2 = F * (2 - F)


def _meridian_radius(lat_rad: float) -> float:
    """Meridian radius of curvature M = a (1 - e^2) / (1 - e^2 sin^2 lat)^(3/2)."""
    return A * (1 - E2) / (1 - E2 * np.sin(lat_rad) ** 2) ** 1.5


def _prime_vertical_radius(lat_rad: float) -> float:
    return A / np.sqrt(1 - E2 * np.sin(lat_rad) ** 2)


def test_origin_maps_to_zero():
    ltp = LocalTangentPlane(58.4, 15.6, 80.0)
    np.testing.assert_allclose(ltp.geodetic_to_ned(58.4, 15.6, 80.0), [0, 0, 0], atol=1e-9)


def test_one_millidegree_north_near_60N_is_meridian_arc():
    ltp = LocalTangentPlane(60.0, 10.0, 0.0)
    ned = ltp.geodetic_to_ned(60.001, 10.0, 0.0)
    expected = _meridian_radius(np.radians(60.0005)) * np.radians(1e-3)
    assert expected == pytest.approx(111.4, rel=1e-3)  # ~111.4 km/deg at 60 N
    assert ned[0] == pytest.approx(expected, rel=1e-3)
    assert abs(ned[1]) < 1e-6
    # The ellipsoid curves away below the tangent plane: d ~ n^2 / (2 R).
    assert ned[2] == pytest.approx(ned[0] ** 2 / (2 * _meridian_radius(np.radians(60))), rel=0.01)


def test_one_millidegree_east_near_60N_is_parallel_arc():
    ltp = LocalTangentPlane(60.0, 10.0, 0.0)
    ned = ltp.geodetic_to_ned(60.0, 10.001, 0.0)
    lat = np.radians(60.0)
    expected = _prime_vertical_radius(lat) * np.cos(lat) * np.radians(1e-3)
    assert ned[1] == pytest.approx(expected, rel=1e-3)
    assert abs(ned[0]) < 1e-3


def test_height_is_minus_down():
    ltp = LocalTangentPlane(-33.0, 151.0, 20.0)
    np.testing.assert_allclose(ltp.geodetic_to_ned(-33.0, 151.0, 45.0), [0, 0, -25.0], atol=1e-8)


def test_round_trip_vectorized():
    rng = np.random.default_rng(11)
    ltp = LocalTangentPlane(58.4, 15.6, 100.0)
    ned = rng.uniform([-5000, -5000, -500], [5000, 5000, 50], (200, 3))
    lat, lon, h = ltp.ned_to_geodetic(ned)
    assert lat.shape == lon.shape == h.shape == (200,)
    back = ltp.geodetic_to_ned(lat, lon, h)
    assert back.shape == (200, 3)
    np.testing.assert_allclose(back, ned, atol=1e-6)


def test_single_point_round_trip():
    ltp = LocalTangentPlane(40.0, -111.6)
    lat, lon, h = ltp.ned_to_geodetic([120.0, -35.0, -12.0])
    np.testing.assert_allclose(ltp.geodetic_to_ned(lat, lon, h), [120.0, -35.0, -12.0], atol=1e-6)


@pytest.mark.parametrize(
    "args, name",
    [((91.0, 0.0), "lat0_deg"), ((0.0, np.nan), "lon0_deg"), ((0.0, 0.0, np.inf), "h0_m")],
)
def test_bad_origin_raises(args, name):
    with pytest.raises(ValueError, match=name):
        LocalTangentPlane(*args)


def test_bad_ned_shape_raises():
    with pytest.raises(ValueError, match="ned"):
        LocalTangentPlane(0.0, 0.0).ned_to_geodetic([1.0, 2.0])
