"""Moravec pseudo-normalized correlation and the PNCC tracker (seed 000 §2.2.2, eq. 2.3, Alg. 2)."""

from __future__ import annotations

from fractions import Fraction

import cv2
import numpy as np
import pytest
import skimage.data

from visnav.vision.correlation import PnccTracker, TrackResult, pncc

# --- pncc -------------------------------------------------------------------------------------


def test_pncc_hand_computed_3x3_in_4x4():
    search = [[3, 7, 1, 4], [2, 9, 5, 0], [8, 6, 2, 7], [1, 3, 9, 5]]
    tmpl = [[4, 1, 0], [2, 6, 3], [5, 2, 8]]
    n = 9
    got = pncc(np.array(search, np.uint8), np.array(tmpl, np.uint8))
    assert got.shape == (2, 2)
    b = [tmpl[r][c] for r in range(3) for c in range(3)]
    mu_b = Fraction(sum(b), n)
    var_b = Fraction(sum(x * x for x in b), n) - mu_b * mu_b
    for v in range(2):
        for u in range(2):
            a = [search[v + r][u + c] for r in range(3) for c in range(3)]
            mu_a = Fraction(sum(a), n)
            var_a = Fraction(sum(x * x for x in a), n) - mu_a * mu_a
            ab = Fraction(sum(x * y for x, y in zip(a, b)), n)
            expected = (ab - mu_a * mu_b) / ((var_a + var_b) / 2)  # eq. 2.3, sums / N
            assert got[v, u] == pytest.approx(float(expected), abs=1e-6)
    # One value written out: placement (0, 0), a = 3 7 1 2 9 5 8 6 2.
    # Σa = 43, Σa² = 273, Σb = 31, Σb² = 159, Σab = 12+7+0+4+54+15+40+12+16 = 160.
    expected00 = (Fraction(160, 9) - Fraction(43 * 31, 81)) / (
        (Fraction(273, 9) - Fraction(43**2, 81) + Fraction(159, 9) - Fraction(31**2, 81)) / 2
    )
    assert got[0, 0] == pytest.approx(float(expected00), abs=1e-6)


@pytest.mark.parametrize("k", [0.5, 1.0, 2.0, 3.0, -1.0])
def test_pncc_contrast_change_closed_form(k):
    # b = k a + c: covariance k σ², variances σ² and k² σ², so coherence = 2k / (1 + k²)
    # (NCC would give sign(k)); an offset c changes nothing.
    rng = np.random.default_rng(2)
    a = rng.normal(0.0, 10.0, (21, 21))
    got = pncc(a, k * a + 40.0)
    assert got.shape == (1, 1)
    assert got[0, 0] == pytest.approx(2 * k / (1 + k * k), abs=1e-5)


def test_pncc_bounded_and_flat_is_zero():
    rng = np.random.default_rng(4)
    s = rng.integers(0, 256, (40, 50)).astype(np.uint8)
    c = pncc(s, s[5:26, 10:31])
    assert c.shape == (20, 30)
    assert np.all(c <= 1.0) and np.all(c >= -1.0)
    assert c[5, 10] == pytest.approx(1.0, abs=1e-6) and np.argmax(c) == 5 * 30 + 10
    assert np.all(pncc(np.full((30, 30), 9, np.uint8), np.full((21, 21), 9, np.uint8)) == 0)


def test_pncc_rejects_bad_shapes():
    with pytest.raises(ValueError, match="template"):
        pncc(np.zeros((10, 10)), np.zeros((11, 5)))
    with pytest.raises(ValueError, match="search"):
        pncc(np.zeros((10, 10, 3)), np.zeros((3, 3)))


def test_pncc_argmax_agrees_with_opencv_ccoeff_normed():
    rng = np.random.default_rng(11)
    cam = skimage.data.camera().astype(np.float64)
    cases = 0
    while cases < 20:
        x, y = rng.integers(120, 392, 2)
        dx, dy = rng.integers(-25, 26, 2)
        tmpl = cam[y - 10 : y + 11, x - 10 : x + 11]
        if tmpl.std() < 8.0:  # textured patches only (the sky is flat under the noise)
            continue
        cases += 1
        # New frame: the scene moved by (dx, dy); mild sensor noise.
        moved = np.roll(cam, (dy, dx), axis=(0, 1)) + rng.normal(0.0, 2.0, cam.shape)
        moved = np.clip(moved, 0, 255).astype(np.uint8)
        search = moved[y - 40 : y + 41, x - 40 : x + 41]  # centres within +-30 of (x, y)
        t8 = tmpl.astype(np.uint8)
        for score in (pncc(search, t8), cv2.matchTemplate(search, t8, cv2.TM_CCOEFF_NORMED)):
            v, u = np.unravel_index(np.argmax(score), score.shape)
            assert (u - 30, v - 30) == (dx, dy)


# --- tracker ----------------------------------------------------------------------------------


def _texture(rng: np.random.Generator, size: int = 400, blur: float = 2.0) -> np.ndarray:
    t = cv2.GaussianBlur(rng.normal(0.0, 1.0, (size, size)).astype(np.float32), (0, 0), blur)
    return (t - t.min()) / np.ptp(t) * 255.0


def _frame(tex: np.ndarray, sx: float, sy: float, size: int = 160, x0: int = 120, y0: int = 120):
    """Camera frame in which the scene moved by (sx, sy) px.

    OpenCV warps quantise sub-pixel coordinates to 1/32 px and INTER_CUBIC shifts by a few
    hundredths of a pixel, so the truth uses 1/32-px steps and INTER_LANCZOS4.
    """
    m = np.float32([[1, 0, sx - x0], [0, 1, sy - y0]])
    f = cv2.warpAffine(tex, m, (size, size), flags=cv2.INTER_LANCZOS4)
    return np.clip(f, 0, 255).astype(np.uint8)


def _run(tex, traj, start=(80, 80), **kw) -> np.ndarray:
    """Tracking error [px] at each frame after the first."""
    t = PnccTracker(**kw)
    t.init(_frame(tex, *traj[0]), *start)
    err = []
    for s in traj[1:]:
        r = t.track(_frame(tex, *s))
        assert r.ok, r
        err.append(np.hypot(r.x - start[0] - (s[0] - traj[0][0]), r.y - start[1] - (s[1] - traj[0][1])))
    assert t.frames == len(traj) - 1
    return np.array(err)


def test_integer_shifts_recovered_exactly():
    rng = np.random.default_rng(5)
    cam = skimage.data.camera()
    steps = rng.integers(-8, 9, (30, 2))
    t = PnccTracker()
    x0, y0 = 256, 256
    t.init(cam[100:400, 100:400], x0 - 100, y0 - 100)
    pos = np.zeros(2, int)
    for st in steps:
        pos += st
        frame = cam[100 - pos[1] : 400 - pos[1], 100 - pos[0] : 400 - pos[0]]  # scene moved by pos
        r = t.track(frame)
        assert r.ok and r.reason == ""
        assert (r.x, r.y) == (x0 - 100 + pos[0], y0 - 100 + pos[1])
        assert r.coherence == pytest.approx(1.0, abs=1e-5)


def test_subpixel_tracks_slow_motion_thesis_mode_does_not():
    tex = _texture(np.random.default_rng(6))
    traj = np.arange(41)[:, None] * np.array([12, -7]) / 32.0  # 0.375, -0.219 px per frame
    sub = _run(tex, traj, subpixel=True)
    thesis = _run(tex, traj)
    assert np.sqrt(np.mean(sub**2)) < 0.15
    # Integer matches of a re-extracted template never move for |step| < 0.5: drift = motion.
    assert thesis[-1] == pytest.approx(np.hypot(*traj[-1]), abs=0.75)
    assert np.sqrt(np.mean(thesis**2)) > 10 * np.sqrt(np.mean(sub**2))


def test_subpixel_random_walk():
    rng = np.random.default_rng(8)
    tex = _texture(rng)
    traj = np.vstack([[0, 0], np.cumsum(rng.integers(-48, 49, (40, 2)) / 32.0, axis=0)])
    sub = np.sqrt(np.mean(_run(tex, traj, subpixel=True) ** 2))
    assert sub < 0.15
    assert np.sqrt(np.mean(_run(tex, traj) ** 2)) > 5 * sub  # integer rounding accumulates


def test_anchored_mode_stops_the_random_walk():
    rng = np.random.default_rng(9)
    tex = _texture(rng)
    traj = rng.integers(-96, 97, (300, 2)) / 32.0  # zero-mean jitter of +-3 px, 300 frames
    thesis = _run(tex, traj)
    anchored = _run(tex, traj, mode="anchored")
    assert anchored.max() <= 0.5 * np.sqrt(2) + 0.05  # integer quantisation only, no growth
    assert np.sqrt(np.mean(thesis**2)) > 4 * np.sqrt(np.mean(anchored**2))
    assert thesis[-1] > 4 * anchored[-1]
    both = _run(tex, traj, mode="anchored", subpixel=True)
    assert both.max() < 0.15


def test_point_leaving_image_reports_edge_and_keeps_position():
    tex = _texture(np.random.default_rng(10))
    t = PnccTracker()
    t.init(_frame(tex, 0, 0), 145, 80)  # 14 px from the right edge of a 160 px frame
    r = t.track(_frame(tex, 25, 0))  # the point is now at x = 170: outside
    assert (r.ok, r.reason) == (False, "edge")
    assert (r.x, r.y) == (145, 80) and (t.x, t.y) == (145, 80)
    # Near the edge but still visible: the clipped search window still finds it.
    t.init(_frame(tex, 0, 0), 140, 80)
    r = t.track(_frame(tex, 5, 0))
    assert r.ok and (r.x, r.y) == (145, 80)


def test_unrelated_frame_reports_low_coherence():
    rng = np.random.default_rng(12)
    t = PnccTracker(min_coherence=0.5)
    t.init(_frame(_texture(rng), 0, 0), 80, 80)
    template = t.template.copy()
    r = t.track(rng.integers(0, 256, (160, 160)).astype(np.uint8))  # white noise: no match
    assert isinstance(r, TrackResult)
    assert (r.ok, r.reason) == (False, "low coherence") and r.coherence < 0.5
    assert np.array_equal(t.template, template)  # failed step keeps the template
    with pytest.raises(ValueError):
        t.template[0, 0] = 1.0


def test_tracker_argument_and_state_errors():
    with pytest.raises(ValueError, match="template_size"):
        PnccTracker(template_size=20)
    with pytest.raises(ValueError, match="search_radius"):
        PnccTracker(search_radius=0)
    with pytest.raises(ValueError, match="mode"):
        PnccTracker(mode="fancy")
    with pytest.raises(ValueError, match="min_coherence"):
        PnccTracker(min_coherence=2.0)
    t = PnccTracker()
    with pytest.raises(RuntimeError, match="init"):
        t.track(np.zeros((100, 100), np.uint8))
    with pytest.raises(ValueError, match="template"):
        t.init(np.zeros((100, 100), np.uint8), 5, 50)


@pytest.mark.parametrize("peak", [(0.3, -0.2), (-0.45, 0.1), (0.0, 0.0)])
def test_subpixel_peak_of_exact_quadratic_with_diagonal_ridge(peak):
    from visnav.vision.correlation import _quadratic_peak, _subpixel_peak

    u = np.array([-1.0, 0.0, 1.0])
    uu, vv = np.meshgrid(u, u)
    hess = np.array([[-2.0, 1.2], [1.2, -1.0]])  # tilted, elongated peak
    d = np.stack([uu - peak[0], vv - peak[1]], axis=-1)
    c3 = 0.9 + 0.5 * np.einsum("...i,ij,...j", d, hess, d)
    assert _quadratic_peak(c3) == pytest.approx(peak, abs=1e-12)
    big = np.zeros((5, 5))
    big[1:4, 1:4] = c3
    assert _subpixel_peak(big, 2, 2) == pytest.approx(peak, abs=1e-12)
    assert _quadratic_peak(-c3) is None  # a minimum is not a peak
