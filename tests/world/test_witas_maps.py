"""Reference maps for the WITAS navigator: world-file checks, projected CRS, degraded reference, rural map."""

import json

import cv2
import numpy as np
import pytest

from visnav.world.maps import GeoImage, degrade_reference
from visnav.world.rural import rural_map


def _blob(h, w, c0, r0, s=6.0):
    rr, cc = np.mgrid[0:h, 0:w]
    return (20 + 200 * np.exp(-((cc - c0) ** 2 + (rr - r0) ** 2) / (2 * s * s))).astype(np.uint8)


def test_world_file_that_does_not_match_its_image_is_refused(tmp_path):
    img = np.zeros((100, 80), np.uint8)
    cv2.imwrite(str(tmp_path / "m.png"), img)
    (tmp_path / "m.pgw").write_text("0.00001\n0\n0\n-0.00001\n22.4\n60.4\n")
    (tmp_path / "m.json").write_text(json.dumps({"crs": "EPSG:4326", "width_px": 797, "height_px": 2076}))
    with pytest.raises(ValueError, match="does not match"):
        GeoImage.load(tmp_path / "m.png")
    # without a sidecar a degree world file whose image would run off the globe is refused too
    (tmp_path / "m.json").unlink()
    (tmp_path / "m.pgw").write_text("0.005\n0\n0\n-0.005\n179.9\n60.4\n")
    with pytest.raises(ValueError, match="does not match its image size"):
        GeoImage.load(tmp_path / "m.png")


def test_projected_world_file_in_metres(tmp_path):
    cv2.imwrite(str(tmp_path / "p.jpg"), _blob(200, 300, 210.0, 50.0), [cv2.IMWRITE_JPEG_QUALITY, 100])
    # UTM-like: 0.5 m pixels, top-left pixel centre at x=500000.25, y=6700000.0
    (tmp_path / "p.jgw").write_text("0.5\n0\n0\n-0.5\n500000.25\n6700000.0\n")
    g = GeoImage.load(tmp_path / "p.jpg")
    assert g.resolution_m == pytest.approx(0.5)
    ext = g.extent_ned()
    assert ext[1] - ext[0] == pytest.approx(100.0) and ext[3] - ext[2] == pytest.approx(150.0)
    assert (ext[0] + ext[1]) / 2 == pytest.approx(0.0) and (ext[2] + ext[3]) / 2 == pytest.approx(0.0)
    # the blob at pixel (210, 50) is at x = 500000.25 + 105, y = 6700000 - 25 -> relative to the centre
    ne = g.pixel_to_ned([[210.0, 50.0]])[0]
    np.testing.assert_allclose(ne, [(99.5 / 2 - 25.0), (105.0 - 149.5 / 2)], atol=1e-9)


def test_geotiff_needs_rasterio_or_says_so(tmp_path):
    p = tmp_path / "g.tif"
    cv2.imwrite(str(p), np.zeros((10, 10), np.uint8))
    try:
        import rasterio  # noqa: F401
    except ImportError:
        with pytest.raises(ValueError, match="rasterio"):
            GeoImage.load(p)


def test_degraded_reference_keeps_geometry_and_changes_radiometry():
    c0, r0 = 301.3, 157.8
    g = GeoImage(_blob(400, 600, c0, r0, 10.0), 100.0, -50.0, 0.25)
    ref = degrade_reference(g, resolution_m=1.0, gain=0.7, offset=30.0, gamma=1.3, blur_m=1.0)
    assert ref.resolution_m == 1.0 and ref.shape == (100, 150)
    np.testing.assert_allclose(ref.extent_ned(), g.extent_ned(), atol=1e-9)
    # the blob's intensity-weighted centroid lands on the same NED point (sub-metre)
    im = ref.image.astype(float) - np.median(ref.image)
    im[im < 0] = 0
    rr, cc = np.mgrid[0 : ref.shape[0], 0 : ref.shape[1]]
    cen = ref.pixel_to_ned([[(cc * im).sum() / im.sum(), (rr * im).sum() / im.sum()]])[0]
    np.testing.assert_allclose(cen, g.pixel_to_ned([[c0, r0]])[0], atol=0.15)
    # brightness and contrast differ: the background is 255 (20/255)^1.3 * 0.7 + 30 = 37.3
    assert np.median(ref.image) == pytest.approx(255 * (20 / 255) ** 1.3 * 0.7 + 30, abs=1.0)
    with pytest.raises(ValueError, match="resolution_m"):
        degrade_reference(g, resolution_m=0.1)


def test_rural_map_is_seeded_and_has_a_textureless_pond():
    a = rural_map(200.0, 0.5, np.random.default_rng(3), pond_ne=(20.0, -30.0), pond_radii_m=(20.0, 15.0))
    b = rural_map(200.0, 0.5, np.random.default_rng(3), pond_ne=(20.0, -30.0), pond_radii_m=(20.0, 15.0))
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_allclose(a.extent_ned(), (-100.0, 100.0, -100.0, 100.0))
    pond = a.crop(20.0, -30.0, 16.0).image
    land = a.crop(-60.0, 60.0, 16.0).image
    assert pond.std() < 3.0 and land.std() > 10.0
    with pytest.raises(ValueError, match="px a side"):
        rural_map(10000.0, 0.1)
