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
