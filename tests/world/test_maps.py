"""GeoImage: georeference, pyramid pixel centres, sampling, loading PNG + world file."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pymap3d
import pytest
from scipy import ndimage

from tests.shared_data import shared_data_dir
from visnav.world.maps import GeoImage

DATA = shared_data_dir()


def _blob_image(h: int, w: int, c0: float, r0: float, sigma: float) -> np.ndarray:
    rr, cc = np.mgrid[0:h, 0:w]
    return (20 + 200 * np.exp(-((cc - c0) ** 2 + (rr - r0) ** 2) / (2 * sigma**2))).astype(np.uint8)


@pytest.fixture
def geo() -> GeoImage:
    rng = np.random.default_rng(0)
    return GeoImage(rng.integers(0, 256, (300, 410), dtype=np.uint8), 100.0, -50.0, 0.25, "t")


def test_pixel_ned_round_trip_and_axes(geo: GeoImage) -> None:
    rng = np.random.default_rng(1)
    cr = rng.uniform(-10, 400, (50, 2))
    back = geo.ned_to_pixel(geo.pixel_to_ned(cr))
    np.testing.assert_allclose(back, cr, atol=1e-9)
    # one column east = +res east, one row down = -res north
    ne = geo.pixel_to_ned([[0, 0], [1, 0], [0, 1]])
    np.testing.assert_allclose(ne, [[100.0, -50.0], [100.0, -49.75], [99.75, -50.0]])
    assert geo.extent_ned() == pytest.approx((100 - 299.5 * 0.25, 100.125, -50.125, -50 + 409.5 * 0.25))


@pytest.mark.parametrize("level", [0, 1, 2, 3])
def test_affine_level_matches_blob_centre(level: int) -> None:
    """A blob's centroid at pyramid level L, mapped by affine(L), lands on its true NED position.

    Plain cv2.pyrDown would put it (2^L - 1)/2 level-0 pixels off (0.94 m at L = 3).
    """
    c0, r0 = 123.3, 87.6
    g = GeoImage(_blob_image(300, 410, c0, r0, 12.0), 100.0, -50.0, 0.25)
    truth = g.pixel_to_ned([[c0, r0]])[0]
    im = g.level(level).astype(float) - 20.0
    rr, cc = np.mgrid[0 : im.shape[0], 0 : im.shape[1]]
    c, r = (cc * im).sum() / im.sum(), (rr * im).sum() / im.sum()
    ne = (g.affine(level) @ [c, r, 1.0])[:2]
    assert np.hypot(*(ne - truth)) < 0.05 * 0.25 * 2**level
    assert im.shape == (math.ceil(300 / 2**level), math.ceil(410 / 2**level))


@pytest.mark.parametrize("level", [0, 1, 2, 3])
def test_affine_consistent_with_ned_to_pixel(geo: GeoImage, level: int) -> None:
    s = 2**level
    cr = np.array([[0.0, 0.0], [3.0, 7.0], [20.0, 11.0]])
    ne = (geo.affine(level) @ np.c_[cr, np.ones(3)].T).T[:, :2]
    expected0 = cr * s + (s - 1) / 2.0  # level-0 pixel of the level-L pixel centre
    np.testing.assert_allclose(geo.ned_to_pixel(ne), expected0, atol=1e-9)
    np.testing.assert_allclose(geo.affine(level)[2], [0, 0, 1])


def test_level_for_gsd(geo: GeoImage) -> None:
    assert geo.level_for_gsd(0.1) == 0  # finer than the map
    assert geo.level_for_gsd(0.25) == 0
    assert geo.level_for_gsd(0.49) == 0
    assert geo.level_for_gsd(0.5) == 1
    assert geo.level_for_gsd(1.99) == 2
    assert geo.level_for_gsd(1e6) == geo.max_level == 8
    for gsd in (0.3, 0.7, 1.3, 3.1):
        lv = geo.level_for_gsd(gsd)
        assert geo.level_resolution(lv) <= gsd < geo.level_resolution(lv) * 2
    with pytest.raises(ValueError, match="gsd_m"):
        geo.level_for_gsd(0.0)


def test_sample_matches_scipy_bilinear_and_nan_outside(geo: GeoImage) -> None:
    rng = np.random.default_rng(2)
    cr = np.c_[rng.uniform(0, 409, 200), rng.uniform(0, 299, 200)]
    vals = geo.sample(geo.pixel_to_ned(cr))
    ref = ndimage.map_coordinates(geo.image.astype(float), [cr[:, 1], cr[:, 0]], order=1)
    np.testing.assert_allclose(vals, ref, atol=1e-9)
    out = geo.sample(geo.pixel_to_ned([[-0.6, 10], [10, 299.6], [409.6, 3], [-0.4, 10]]))
    assert np.isnan(out[:3]).all()
    assert out[3] == geo.image[10, 0]  # inside the outer half pixel: edge value


def test_crop_keeps_pixels_and_georeference(geo: GeoImage) -> None:
    n, e = geo.pixel_to_ned([[200, 100]])[0]
    c = geo.crop(n, e, 10.0)
    assert c.shape == (40, 40)
    c0, r0 = np.rint(geo.ned_to_pixel([[c.north0, c.east0]])[0]).astype(int)
    np.testing.assert_array_equal(c.image, geo.image[r0 : r0 + 40, c0 : c0 + 40])
    nmin, nmax, emin, emax = c.extent_ned()
    assert abs(0.5 * (nmin + nmax) - n) <= 0.125 and abs(0.5 * (emin + emax) - e) <= 0.125
    pts = c.pixel_to_ned([[0, 0], [39, 39], [7.5, 3.25]])
    np.testing.assert_allclose(c.sample(pts), geo.sample(pts))
    edge = geo.crop(*geo.pixel_to_ned([[2, 2]])[0], 10.0)  # clipped at the map corner
    assert edge.shape == (23, 23)  # pixels -17..22 clipped to 0..22
    with pytest.raises(ValueError, match="outside"):
        geo.crop(1e4, 1e4, 5.0)


def test_constructor_validation() -> None:
    with pytest.raises(ValueError, match="image"):
        GeoImage(np.zeros((3, 3, 3), np.uint8), 0, 0, 1.0)
    with pytest.raises(ValueError, match="resolution_m"):
        GeoImage(np.zeros((3, 3), np.uint8), 0, 0, 0.0)
    with pytest.raises(ValueError, match="resolution_m"):
        GeoImage(np.zeros((3, 3), np.uint8), 0, 0, float("nan"))
    with pytest.raises(ValueError, match="image"):
        GeoImage(np.full((3, 3), 300.0), 0, 0, 1.0)
    g = GeoImage(np.full((3, 3), 7.0), 0, 0, 1.0)
    assert g.image.dtype == np.uint8 and g.image[0, 0] == 7
    with pytest.raises(ValueError, match="level"):
        g.level(5)


# ------------------------------------------------------------------ files


def _write_map(tmp_path: Path, lines: list[str], h: int = 40, w: int = 60) -> Path:
    img = np.random.default_rng(3).integers(0, 256, (h, w), dtype=np.uint8)
    p = tmp_path / "m.png"
    cv2.imwrite(str(p), img)
    (tmp_path / "m.pgw").write_text("\n".join(lines) + "\n")
    return p


def test_load_synthetic_world_file_against_pymap3d(tmp_path: Path) -> None:
    dlon, dlat = 1e-5, 5e-6  # at 45 deg: ~0.79 m east, ~0.56 m north per pixel
    p = _write_map(tmp_path, [str(dlon), "0", "0", str(-dlat), "7.0", "45.0"])
    g = GeoImage.load(p, origin=(45.0, 7.0))
    assert g.origin_geodetic == (45.0, 7.0)
    # the top-left pixel centre is the origin itself
    assert (g.north0, g.east0 - 0.5 * g.resolution_m) == pytest.approx((0.0, -0.5 * 0.7873), abs=2e-3)
    n_bot, e_right, _ = pymap3d.geodetic2ned(45.0 - 39.5 * dlat, 7.0 + 59.5 * dlon, 0, 45.0, 7.0, 0)
    nmin, nmax, emin, emax = g.extent_ned()
    assert nmin == pytest.approx(n_bot, abs=0.01)
    assert emax == pytest.approx(e_right, abs=0.5 * g.resolution_m + 0.01)
    assert g.shape[0] == 40 and g.shape[1] == round(60 * 0.7873 / g.resolution_m)


def test_load_errors_name_the_path_and_line(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="nope.png"):
        GeoImage.load(tmp_path / "nope.png")
    img = tmp_path / "lonely.png"
    cv2.imwrite(str(img), np.zeros((4, 4), np.uint8))
    with pytest.raises(FileNotFoundError, match="lonely.pgw"):
        GeoImage.load(img)
    with pytest.raises(FileNotFoundError, match="other.wld"):
        GeoImage.load(img, world_file=tmp_path / "other.wld")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png at all")
    (tmp_path / "bad.pgw").write_text("1\n0\n0\n-1\n0\n0\n")
    with pytest.raises(ValueError, match="bad.png"):
        GeoImage.load(bad)
    p = _write_map(tmp_path, ["1e-5", "0", "0", "-1e-5", "7.0"])
    with pytest.raises(ValueError, match=r"m\.pgw.*6 numbers"):
        GeoImage.load(p)
    p = _write_map(tmp_path, ["1e-5", "0", "0.001", "-1e-5", "7.0", "45"])
    with pytest.raises(ValueError, match=r"m\.pgw, line 3.*rotation"):
        GeoImage.load(p)
    p = _write_map(tmp_path, ["1e-5", "0", "0", "north", "7.0", "45"])
    with pytest.raises(ValueError, match=r"m\.pgw, line 4.*'north'"):
        GeoImage.load(p)


def _require(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"real data not found: {path}")
    return path


def test_load_real_satellite_column() -> None:
    png = _require(DATA / "satellite_column.png")
    meta = json.loads(_require(DATA / "satellite_column.json").read_text())
    g = GeoImage.load(png)
    nmin, nmax, emin, emax = g.extent_ned()
    # sidecar size from its pixel count and resolution, and independently from its bounds
    # on a sphere of the WGS84 mean radius (the two agree to ~0.3 %)
    h_json = meta["height_px"] * meta["resolution_m"]
    w_json = meta["width_px"] * meta["resolution_m"]
    r_earth = 6371008.8
    lat_mid = math.radians(0.5 * (meta["north_lat"] + meta["south_lat"]))
    h_bounds = math.radians(meta["north_lat"] - meta["south_lat"]) * r_earth
    w_bounds = math.radians(meta["east_lon"] - meta["west_lon"]) * r_earth * math.cos(lat_mid)
    height, width = nmax - nmin, emax - emin
    for got, ref in ((height, h_json), (width, w_json), (height, h_bounds), (width, w_bounds)):
        assert got == pytest.approx(ref, rel=0.01)
    assert 195 < emax - emin < 203 and 514 < nmax - nmin < 524
    assert g.resolution_m == pytest.approx(meta["resolution_m"], rel=0.01)
    # default origin = the image centre, which is then the middle of the NED extent
    assert 0.5 * (nmin + nmax) == pytest.approx(0.0, abs=g.resolution_m)
    assert 0.5 * (emin + emax) == pytest.approx(0.0, abs=g.resolution_m)
    lat0, lon0 = g.origin_geodetic
    assert meta["south_lat"] < lat0 < meta["north_lat"] and meta["west_lon"] < lon0 < meta["east_lon"]
    assert g.image.dtype == np.uint8 and g.image.std() > 10
