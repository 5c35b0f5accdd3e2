"""Landing-field textures: determinism, intensity statistics, no periodicity, detail tile."""

from __future__ import annotations

import numpy as np
import pytest

from visnav.world.textures import PHOTO_SPAN_M, SURFACES, detail_tile, landing_field

WIN = 61


def _ncc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = a - a.mean(axis=(1, 2), keepdims=True)
    b = b - b.mean(axis=(1, 2), keepdims=True)
    return (a * b).sum(axis=(1, 2)) / np.sqrt((a * a).sum(axis=(1, 2)) * (b * b).sum(axis=(1, 2)))


def _windows(im: np.ndarray, r: np.ndarray, c: np.ndarray) -> np.ndarray:
    i = np.arange(WIN)
    return im[(r[:, None] + i)[:, :, None], (c[:, None] + i)[:, None, :]].astype(float)


@pytest.fixture(scope="module", params=["grass", "asphalt", "concrete"])
def field(request):
    return landing_field(request.param, rng=np.random.default_rng(5))


def test_field_size_georeference_and_statistics(field) -> None:
    im = field.image
    assert im.shape == (4000, 4000) and im.dtype == np.uint8
    assert field.resolution_m == 0.02
    nmin, nmax, emin, emax = field.extent_ned()
    assert (nmin, nmax, emin, emax) == pytest.approx((-40, 40, -40, 40), abs=1e-9)
    assert abs(im.mean() - 128) < 3
    assert 25 < im.std() < 60
    assert np.mean((im == 0) | (im == 255)) < 1e-3  # no saturation
    assert int(im.max()) - int(im.min()) > 170  # but the range is used
    # low-frequency albedo: 1 m block means vary by a few percent, never by more than ~+-25 %
    blocks = im.astype(float).reshape(80, 50, 80, 50).mean(axis=(1, 3))
    assert 0.02 < blocks.std() / blocks.mean() < 0.12
    assert np.abs(blocks / blocks.mean() - 1).max() < 0.3


def test_no_two_windows_alike(field) -> None:
    """NCC of 61x61 windows a tiling period apart stays < 0.9 at pyramid levels 0..4
    (2 cm .. 32 cm, a 640 px camera at ~1 m .. 200 m AGL)."""
    rng = np.random.default_rng(0)
    cell_m = 0.75 * PHOTO_SPAN_M
    for level in range(5):
        im = field.level(level)
        res = field.level_resolution(level)
        n = im.shape[0]
        offsets_m = [1.0, cell_m, PHOTO_SPAN_M, 2 * cell_m, 5.0, 10.0, 20.0]
        if level > 0:  # only offsets beyond the window: overlapping windows correlate anyway
            offsets_m = [o for o in offsets_m if o / res >= WIN]
        for off_m in offsets_m:
            off = int(round(off_m / res))
            if off + WIN >= n:
                continue
            r = rng.integers(0, n - WIN - off, 150)
            c = rng.integers(0, n - WIN - off, 150)
            down = rng.integers(0, 2, 150).astype(bool)
            v = _ncc(_windows(im, r, c), _windows(im, r + off * down, c + off * ~down))
            assert v.max() < 0.9, (level, off_m, v.max())
            assert abs(np.median(v)) < 0.15


def test_deterministic_per_seed_and_center() -> None:
    a = landing_field("grass", 10.0, rng=np.random.default_rng(1), center_ne=(100.0, -20.0))
    b = landing_field("grass", 10.0, rng=np.random.default_rng(1), center_ne=(100.0, -20.0))
    c = landing_field("grass", 10.0, rng=np.random.default_rng(2))
    np.testing.assert_array_equal(a.image, b.image)
    corr = np.corrcoef(a.image.ravel().astype(float), c.image.ravel().astype(float))[0, 1]
    assert abs(corr) < 0.1
    nmin, nmax, emin, emax = a.extent_ned()
    assert (0.5 * (nmin + nmax), 0.5 * (emin + emax)) == pytest.approx((100.0, -20.0))
    g = landing_field("gravel", 10.0, rng=np.random.default_rng(1))
    s = landing_field("asphalt", 10.0, rng=np.random.default_rng(1))
    np.testing.assert_array_equal(g.image, s.image)


def test_bad_arguments() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"surface.*asphalt.*concrete.*grass.*'snow'"):
        landing_field("snow", rng=rng)
    with pytest.raises(ValueError, match="surface"):
        detail_tile("snow", rng=rng)
    with pytest.raises(ValueError, match="size_m"):
        landing_field("grass", -1.0, rng=rng)
    with pytest.raises(ValueError, match="resolution_m"):
        landing_field("grass", 10.0, 0.0, rng=rng)
    with pytest.raises(ValueError, match="px"):
        landing_field("grass", 1e4, 0.01, rng=rng)
    assert set(SURFACES) == {"grass", "asphalt", "gravel", "concrete"}


@pytest.mark.parametrize("surface", ["grass", "asphalt", "concrete"])
def test_detail_tile_high_pass_and_seamless(surface: str) -> None:
    tile, res = detail_tile(surface, rng=np.random.default_rng(3))
    assert res == 0.002 and tile.dtype == np.uint8 and tile.shape == (500, 500)
    f = tile.astype(float) - 128.0
    assert abs(tile.mean() - 128) < 2
    assert f.std() > 15
    # low-pass content: averaged over 20 cm blocks (a map pixel seen from ~40 m) the detail
    # is a few percent of its std; over 4 cm blocks most of it is already gone
    n = tile.shape[0]
    for block_m, limit in ((0.20, 0.08), (0.04, 0.45)):
        b = int(round(block_m / res))
        means = f.reshape(n // b, b, n // b, b).mean(axis=(1, 3))
        assert means.std() < limit * f.std(), (block_m, means.std() / f.std())
    # seamless under wrap-around: the jump across the seam is like any neighbour step
    step_inside = np.abs(np.diff(f, axis=0)).mean()
    assert np.abs(f[0] - f[-1]).mean() < 1.5 * step_inside
    assert np.abs(f[:, 0] - f[:, -1]).mean() < 1.5 * np.abs(np.diff(f, axis=1)).mean()
    again, _ = detail_tile(surface, rng=np.random.default_rng(3))
    other, _ = detail_tile(surface, rng=np.random.default_rng(4))
    np.testing.assert_array_equal(tile, again)
    assert not np.array_equal(tile, other)
