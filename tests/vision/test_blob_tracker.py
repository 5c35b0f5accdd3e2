"""Blob tracker on rendered tent frames: sub-pixel centre, re-acquisition, loss."""

import math

import numpy as np
import pytest

from visnav.sensors.condor_camera import TargetCamera, condor_camera, target_outline
from visnav.vision.blob_tracker import BlobTracker

CAM = condor_camera(640, 480, 53.0, -0.25, 0.05, 12.0, -7.0)
TC = TargetCamera(CAM, np.random.default_rng(0))
OUT = target_outline([110.0, 0.0], 3.0, 2.0, 0.3)


@pytest.mark.parametrize("pan_deg,tilt_deg", [(0, -42), (8, -45), (-12, -38), (15, -48)])
def test_tracks_the_projected_centre(pan_deg, tilt_deg):
    pose = ([0, 0, -100.0], math.radians(pan_deg), math.radians(tilt_deg), math.radians(-2))
    truth = TC.project(*pose, np.array([[110.0, 0.0, 0.0]]))[0]
    tr = BlobTracker()
    tr.start(*(truth + [15, -10]))  # the operator clicks near the tent
    r = tr.track(TC.render(*pose, OUT))
    assert r.ok and math.hypot(r.u - truth[0], r.v - truth[1]) < 0.6


def test_lost_and_reacquired():
    tr = BlobTracker(window_px=30)
    tr.start(100, 100)  # far from the tent: the window misses it, the full-frame search finds it
    pose = ([0, 0, -100.0], 0.0, math.radians(-42), 0.0)
    r = tr.track(TC.render(*pose, OUT))
    assert r.ok
    away = ([0, 0, -100.0], math.pi / 2, math.radians(-42), 0.0)
    assert not tr.track(TC.render(*away, OUT)).ok and tr.last is None
    with pytest.raises(ValueError):
        BlobTracker(window_px=2)


def test_byte_image_search_equals_the_float_path():
    """The integer search of byte frames (``_search_u8``) against the float path it replaces (the frame
    as int32, which takes the general path): the same pixel count and bit-identical centroids, on
    rendered frames, on noise and on frames with several blobs, windows and the full frame."""
    rng = np.random.default_rng(7)
    tr = BlobTracker()
    frames = [TC.render([0, 0, -100.0], math.radians(p), math.radians(t), 0.02, OUT)
              for p, t in ((0, -42), (8, -45), (-12, -38), (3, -40))]
    frames += [rng.integers(0, 256, (480, 640, 3), dtype=np.uint8) for _ in range(3)]
    for img in frames:
        for u0, v0, u1, v1 in ((0, 0, 640, 480), (200, 150, 321, 271), (300, 200, 420, 330), (0, 0, 61, 61)):
            a = tr._search(img, u0, v0, u1, v1)
            b = tr._search(img.astype(np.int32), u0, v0, u1, v1)
            assert (a.ok, a.pixels) == (b.ok, b.pixels)
            assert a.u == b.u and a.v == b.v
