"""Real frames through the vision front ends (analysis/real_frames.py, issue 28 item 4): the KLT and PALACE
trackers on EuRoC V1_01 cam0 against OpenCV's LK, the PALACE distinctness guard, and the three-circle pad
detector on the 100 real marker photos (none a three-circle pad: every pose would be false).

The data tests skip when ``../shared/data`` is absent. The first 30 EuRoC frames are used (the micro
excerpt's camera barely moves: ~1.5 px over all 95 frames, so lengths and survival say little; the
sub-pixel agreement and the jumps to a copy of the texture are what these frames measure)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.shared_data import missing_reason, shared_data_dir
from visnav.vision.correlation import distinct_points, self_coherence

EUROC = shared_data_dir() / "euroc_v1_01"
MARKERS = shared_data_dir() / "markers_downward"


@pytest.fixture(scope="module")
def frames():
    if not (EUROC / "mav0" / "cam0" / "data.csv").is_file():
        pytest.skip(missing_reason(EUROC))
    from visnav.analysis.real_frames import load_euroc_frames

    t, imgs = load_euroc_frames(EUROC, limit=30)
    assert len(imgs) == 30 and imgs[0].shape == (480, 752)
    assert np.allclose(np.diff(t), 0.05, atol=1e-3)  # 20 Hz, data.csv's ns stamps
    return imgs


def test_klt_agrees_with_opencv_lk_below_a_tenth_of_a_pixel(frames):
    from visnav.analysis.real_frames import klt_on_frames

    r = klt_on_frames(frames)
    assert r["features_first"] == 50 and r["survival_all"] >= 0.9
    assert r["lk_steps"] >= 0.9 * 50 * 29
    assert r["lk_diff_median_px"] < 0.02 and r["lk_diff_p90_px"] < 0.05


def test_palace_tracker_subpixel_and_integer_agreement_with_lk(frames):
    """Integer PNCC (the thesis): rounding to whole pixels, median error of a uniform ±0.5 px square
    ≈ 0.38 px is the bound; sub-pixel PNCC must do ten times better."""
    from visnav.analysis.real_frames import palace_on_frames

    thesis = palace_on_frames(frames, n_points=20, max_self_coherence=0.9)
    sub = palace_on_frames(frames, n_points=20, max_self_coherence=0.9, subpixel=True)
    assert thesis["lk_diff_median_px"] < 0.38
    assert sub["lk_diff_median_px"] < 0.038 < thesis["lk_diff_median_px"] / 4
    assert thesis["tracks_jumped"] == sub["tracks_jumped"] == 0 and sub["survival_all"] == 1.0


def test_distinctness_guard_removes_the_jumps_to_a_copy_of_the_texture(frames):
    """Unguarded, 40 Förstner points on these frames include points of the repeated texture whose PNCC
    track jumps > 2 px off LK (to a copy ~20 px away); with the guard (self-coherence <= 0.9) none does."""
    from visnav.analysis.real_frames import palace_on_frames

    off = palace_on_frames(frames, n_points=40, max_self_coherence=1.0)
    on = palace_on_frames(frames, n_points=40, max_self_coherence=0.9)
    assert off["tracks_jumped"] >= 1 and off["lk_diff_max_px"] > 10
    assert on["tracks_jumped"] == 0 and on["lk_diff_max_px"] < 2.0


def test_self_coherence_of_a_repeated_pattern_and_of_a_single_blob():
    """Closed cases: a vertical grating of period 12 px has a copy at 12 px (coherence 1 on a perfect
    grating); a single Gaussian blob on flat ground has no other local maximum above 0.5."""
    x = np.arange(200)
    grating = np.tile((128 + 100 * np.sin(2 * np.pi * x / 12.0)), (200, 1)).astype(np.uint8)
    assert self_coherence(grating, 100, 100) > 0.97
    yy, xx = np.mgrid[:200, :200]
    blob = (30 + 200 * np.exp(-((xx - 100) ** 2 + (yy - 100) ** 2) / (2 * 4.0**2))).astype(np.uint8)
    assert self_coherence(blob, 100, 100) < 0.5

    class P:
        def __init__(self, x, y):
            self.x, self.y = x, y

    img = np.hstack([grating[:, :100], blob[:, 50:150]])  # grating left, blob centred at x = 150
    pts = [P(50, 100), P(150, 100)]
    assert [p.x for p in distinct_points(img, pts, max_self_coherence=0.9)] == [150]
    assert len(distinct_points(img, pts, max_self_coherence=1.0)) == 2


def test_pad_detector_gives_no_pose_on_any_real_marker_photo():
    if not MARKERS.is_dir():
        pytest.skip(missing_reason(MARKERS))
    from visnav.analysis.real_frames import marker_photos, pad_on_photos

    photos = marker_photos(MARKERS)
    assert len(photos) == 100
    r = pad_on_photos(photos)
    assert r["photos"] == 100
    assert r["false_poses"] == 0, r["false_pose_photos"]
    assert np.isfinite(r["ms_median"]) and r["ms_max"] >= r["ms_median"] > 0


def test_pad_validation_rejects_three_real_rings_of_different_markers():
    """2x2 mosaics of the photos with rings put 3+ real rings in one frame, so they reach the association
    and the homography checks (single photos never do: at most 2 rings); still no pose."""
    if not MARKERS.is_dir():
        pytest.skip(missing_reason(MARKERS))
    from visnav.analysis.real_frames import marker_photos, pad_on_tiles

    r = pad_on_tiles(marker_photos(MARKERS), limit=40)
    assert r["photos_with_rings"] >= 10 and r["tiles"] == 40
    assert r["tiles_with_3_rings"] >= 10
    assert r["false_poses"] == 0, r["reasons"]
