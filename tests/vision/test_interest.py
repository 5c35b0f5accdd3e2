"""Förstner interest operator (seed 000 §2.2.1, Algorithm 1)."""

from __future__ import annotations

import numpy as np
import pytest

from visnav.vision.interest import InterestPoint, forstner, forstner_response, forstner_top_k


def _square(shape=(160, 200), box=(60, 50, 130, 110), value=200) -> np.ndarray:
    """Dark image with a bright rectangle covering columns x0..x1-1, rows y0..y1-1."""
    img = np.zeros(shape, np.uint8)
    x0, y0, x1, y1 = box
    img[y0:y1, x0:x1] = value
    return img


def _corners(box=(60, 50, 130, 110)) -> np.ndarray:
    """Geometric corners of the rectangle: between pixels, at x0 - 0.5 and x1 - 0.5."""
    x0, y0, x1, y1 = box
    return np.array([(x, y) for x in (x0 - 0.5, x1 - 0.5) for y in (y0 - 0.5, y1 - 0.5)])


def _dist_to_nearest(p: InterestPoint, pts: np.ndarray) -> float:
    return float(np.min(np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y)))


@pytest.mark.parametrize("min_isotropy", [0.0, 0.2])
def test_square_refined_point_is_a_corner(min_isotropy):
    p = forstner(_square(), min_isotropy=min_isotropy, refine=True)
    assert p is not None
    assert _dist_to_nearest(p, _corners()) < 1.0


@pytest.mark.parametrize("feature_size", [5, 7, 9])
def test_square_argmax_pixel_has_a_corner_in_its_window(feature_size):
    # Alg. 1 without refinement: λ2 > 0 needs both edges of a corner inside the window.
    half = feature_size // 2
    p = forstner(_square(), feature_size=feature_size)
    d = np.abs(_corners() - [p.x, p.y]).max(axis=1)
    assert d.min() <= half + 0.5
    assert p.x == int(p.x) and p.y == int(p.y)


def _edge_and_weak_corner(rng: np.random.Generator) -> np.ndarray:
    img = np.full((200, 240), 80.0)
    img[:, 70:] = 200.0  # strong straight step at x = 69.5 across the whole image
    img[110:170, 160:220] += 30.0  # weak square, top-left corner at (159.5, 109.5)
    img += rng.normal(0.0, 2.0, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def test_thesis_mode_picks_edge_guard_picks_corner():
    img = _edge_and_weak_corner(np.random.default_rng(1))
    thesis = forstner(img, min_isotropy=0.0)
    assert abs(thesis.x - 69.5) <= 3.5  # on the step (within the 7x7 feature window)
    assert thesis.isotropy < 0.05  # aperture problem: one gradient direction only
    guarded = forstner(img, min_isotropy=0.2, refine=True)
    assert guarded.isotropy >= 0.2
    assert np.hypot(guarded.x - 159.5, guarded.y - 109.5) < 1.0
    assert guarded.lambda1 < 0.2 * thesis.lambda1  # the corner really is the weaker feature


def test_flat_image_gives_none():
    flat = np.full((120, 160), 77, np.uint8)
    assert forstner(flat) is None
    assert forstner(flat, min_isotropy=0.0) is None
    assert forstner_top_k(flat, 5) == []
    l1, l2 = forstner_response(flat)
    assert np.all(l1 == 0) and np.all(l2 == 0)


def test_eigenvalues_match_eigvalsh_of_hand_summed_matrix():
    rng = np.random.default_rng(7)
    img = rng.integers(0, 256, (60, 70)).astype(np.uint8)
    feature_size = 7
    half = feature_size // 2
    l1, l2 = forstner_response(img, feature_size)
    f = img.astype(np.float64)
    for x, y in [(10, 10), (33, 21), (50, 40), (20, 45)]:
        c = np.zeros((2, 2))
        for v in range(-half, half + 1):
            for u in range(-half, half + 1):
                ix = f[y + v, x + u - 1] - f[y + v, x + u + 1]
                iy = f[y + v - 1, x + u] - f[y + v + 1, x + u]
                c += np.array([[ix * ix, ix * iy], [ix * iy, iy * iy]])
        lo, hi = np.linalg.eigvalsh(c)
        assert l1[y, x] == pytest.approx(hi, rel=1e-5)
        assert l2[y, x] == pytest.approx(lo, rel=1e-4, abs=1e-5 * hi)


def test_region_restricts_search_and_keeps_full_image_values():
    img = _square()
    l1, l2 = forstner_response(img)
    # Only the bottom-right corner (129.5, 109.5) is near this region.
    p = forstner(img, region=(110, 90, 150, 130), border=0)
    assert 110 <= p.x < 150 and 90 <= p.y < 130
    assert np.hypot(p.x - 129.5, p.y - 109.5) <= 3 * np.sqrt(2) + 0.5
    assert p.lambda1 == l1[int(p.y), int(p.x)] and p.lambda2 == l2[int(p.y), int(p.x)]
    assert forstner(img, region=(0, 0, 30, 30), border=0) is None  # only flat pixels


def test_border_is_respected():
    img = _square(box=(5, 5, 60, 60), shape=(120, 120))  # corner (4.5, 4.5) too near the edge
    p = forstner(img, border=20)
    assert 20 <= p.x <= 120 - 20 and 20 <= p.y <= 120 - 20
    assert np.hypot(p.x - 59.5, p.y - 59.5) < 6


def test_exclude_disc_and_mask():
    img = _square()
    first = forstner(img, refine=True)
    other = forstner(img, exclude=[(first.x, first.y, 15.0)], refine=True)
    assert np.hypot(other.x - first.x, other.y - first.y) > 15
    assert _dist_to_nearest(other, _corners()) < 1.0
    mask = np.ones(img.shape, bool)
    assert forstner(img, exclude=mask) is None


def test_top_k_finds_all_four_corners_separated_and_sorted():
    pts = forstner_top_k(_square(), 10, min_distance=12, refine=True)
    assert len(pts) == 4
    xy = np.array([(p.x, p.y) for p in pts])
    assert np.all(np.min(np.hypot(*(xy[:, None, :] - _corners()[None]).transpose(2, 0, 1)), axis=1) < 1.0)
    d = np.hypot(*(xy[:, None, :] - xy[None]).transpose(2, 0, 1)) + np.eye(4) * 1e9
    assert d.min() >= 12
    lam = [p.lambda1 for p in pts]
    assert lam == sorted(lam, reverse=True)


def test_top_k_min_distance_on_texture():
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (200, 200)).astype(np.uint8)
    pts = forstner_top_k(img, 30, min_distance=15.0, border=10)
    assert len(pts) == 30
    xy = np.array([(p.x, p.y) for p in pts])
    d = np.hypot(*(xy[:, None, :] - xy[None]).transpose(2, 0, 1)) + np.eye(len(pts)) * 1e9
    assert d.min() >= 15.0
    best = forstner(img, border=10)
    assert (pts[0].x, pts[0].y) == (best.x, best.y)


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"feature_size": 0}, "feature_size"),
        ({"min_isotropy": 1.5}, "min_isotropy"),
        ({"region": (50, 50, 40, 60)}, "region"),
        ({"region": (500, 500, 600, 600)}, "region"),
        ({"border": -1}, "border"),
    ],
)
def test_bad_arguments_raise(kwargs, word):
    with pytest.raises(ValueError, match=word):
        forstner(_square(), **kwargs)


def test_bad_image_raises():
    with pytest.raises(ValueError, match="image"):
        forstner(np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match="k"):
        forstner_top_k(_square(), 0)
