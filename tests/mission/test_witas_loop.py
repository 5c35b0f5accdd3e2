import math
import types

import numpy as np
import pytest

from visnav.guidance.hermite import HermitePath
from visnav.mission.witas import loop_waypoints
from visnav.world.witas_map import fit_loop
from visnav.scenarios.config_witas import WitasPathConfig


@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_loop_is_closed_rounded_rectangle(direction):
    P, T = loop_waypoints(320.0, 200.0, 30.0, 60.0, centre=(10.0, -5.0), direction=direction)
    np.testing.assert_allclose(P[0], P[-1])
    assert np.all(P[:, 2] == -60.0)
    path = HermitePath.from_waypoints(P, T, scale="arc")
    # straight legs + four quarter circles
    exact = 2 * (320 + 200) - 8 * 30 + 2 * math.pi * 30
    assert path.length == pytest.approx(exact, rel=2e-3)
    s = path.sample(50)["position"]
    assert s[:, 0].max() == pytest.approx(10 + 160, abs=1e-6) and s[:, 1].min() == pytest.approx(-5 - 100, abs=1e-6)
    if direction == "cw":  # first leg north along the west side
        np.testing.assert_allclose(P[0, :2], [10.0, -105.0])
        np.testing.assert_allclose(T[0, :2], [1.0, 0.0])


def test_fit_loop_inside_a_map_and_refuses_a_tiny_one():
    cfg = WitasPathConfig(margin_m=35.0)
    sn, se, r, c = fit_loop(cfg, (-259.5, 259.5, -99.5, 99.5), footprint_m=37.3)
    assert sn == 320.0 and se == pytest.approx(199.0 - 2 * (35 + 18.65))
    assert c == (0.0, 0.0) and r <= 0.45 * se
    with pytest.raises(ValueError, match="too small"):
        fit_loop(cfg, (0, 100, 0, 100), footprint_m=37.3)


def test_geotiff_via_rasterio(tmp_path, monkeypatch):
    """GeoTIFF path with a stand-in for rasterio: GDAL's corner transform -> world-file centres."""
    import sys

    from visnav.world.maps import GeoImage

    band = np.zeros((40, 60), np.float32)
    band[10, 20] = 500.0

    class _Src:
        transform = types.SimpleNamespace(a=2.0, b=0.0, c=300000.0, d=0.0, e=-2.0, f=6600000.0)

        def read(self, i):
            return band

        def __enter__(self):
            return self

        def __exit__(self, *a):
            return False

    monkeypatch.setitem(sys.modules, "rasterio", types.SimpleNamespace(open=lambda p: _Src()))
    p = tmp_path / "m.tif"
    p.write_bytes(b"II*\x00")
    g = GeoImage.load(p)
    assert g.resolution_m == pytest.approx(2.0) and g.shape == (40, 60)
    np.testing.assert_allclose(g.extent_ned(), (-40.0, 40.0, -60.0, 60.0), atol=1e-6)
    r, c = np.unravel_index(np.argmax(g.image), g.shape)
    assert (r, c) == (10, 20)
