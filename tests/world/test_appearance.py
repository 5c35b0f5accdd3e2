"""The ground on another day (world/appearance.py): relief changes and moves, flat oriented structure stays."""

import cv2
import numpy as np
import pytest

from visnav.world.appearance import appearance_change, coherence, relief_weight


def _scene(n=240, seed=0):
    """Left half: isotropic strong texture (crowns); right half: straight stripes (field boundaries, roads)."""
    rng = np.random.default_rng(seed)
    tex = 110 + 30 * cv2.GaussianBlur(rng.standard_normal((n, n)).astype(np.float32), (0, 0), 1.5) / 0.19
    xx = np.mgrid[0:n, 0:n][1]
    stripes = 110 + 60 * (np.sin(2 * np.pi * xx / 24.0) > 0)
    img = np.where(xx < n // 2, tex, stripes)
    return np.clip(img, 0, 255).astype(np.uint8)


def _corr(a, b):
    a, b = a - a.mean(), b - b.mean()
    return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum()))


def test_coherence_is_one_on_a_straight_edge_and_low_on_isotropic_texture():
    img = _scene()
    c = coherence(img, 8.0)
    assert np.median(c[40:-40, 150:-40]) > 0.95
    assert np.median(c[40:-40, 30:90]) < 0.3
    assert np.all(coherence(np.full((50, 50), 80, np.uint8), 4.0) == 0.0)  # flat: no structure


def test_relief_weight_marks_strong_unoriented_texture_only():
    img = _scene()
    w = relief_weight(img, 4.0, 10.0)
    assert np.median(w[40:-40, 30:90]) > 0.5
    assert np.median(w[40:-40, 150:-40]) < 0.05
    rng = np.random.default_rng(1)
    faint = np.clip(110 + 2.0 * rng.standard_normal((120, 120)), 0, 255).astype(np.uint8)  # weak texture: flat ground
    assert np.median(relief_weight(faint, 4.0, 10.0)) < 0.1


def test_another_day_keeps_the_stripes_and_changes_the_relief():
    img = _scene()
    out = appearance_change(img, 4.0, np.random.default_rng(2), keep=0.3, relief_level=10.0, shift_px=5.0,
                            shift_corr_px=14.0)
    f, o = img.astype(np.float32), out.astype(np.float32)
    fine = lambda a: a - cv2.GaussianBlur(a, (0, 0), 4.0)  # noqa: E731
    s = np.s_[40:-40, 150:-40]
    t = np.s_[40:-40, 30:90]
    assert _corr(f[s], o[s]) > 0.97  # the oriented structure is where it was
    assert _corr(fine(f)[t], fine(o)[t]) < 0.5  # the relief's fine texture no longer matches
    assert fine(o)[t].std() == pytest.approx(fine(f)[t].std(), rel=0.3)  # ... at the same power
    # the uniform model (relief_level None) and no change at scale 0
    assert np.array_equal(appearance_change(img, 0.0, np.random.default_rng(0)), img)
    with pytest.raises(ValueError):
        appearance_change(img, 4.0, np.random.default_rng(0), keep=0.3, shift_px=3.0)
    with pytest.raises(ValueError):
        appearance_change(img, 4.0, np.random.default_rng(0), keep=1.5)
