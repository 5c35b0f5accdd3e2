import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.measurements import AttitudeSample, BaroSample, Frame, GpsSample, ImuSample
from visnav.navigation.witas import WitasNavigator
from visnav.scenarios.config_witas import WitasFilterConfig
from visnav.world.rural import rural_map


def _nav(**kw):
    cam = PinholeCamera.ideal(384, 288, 463.0)
    ref = rural_map(200.0, 1.0, np.random.default_rng(0), pond_ne=None)
    return WitasNavigator(WitasFilterConfig(**kw), cam.K, FixedMount.depressed(90), ref)


def _hover(nav, t0, t1, gps=True):
    for k in range(int(round(t0 * 100)), int(round(t1 * 100))):
        t = k / 100
        nav.update(ImuSample(t, np.array([0.0, 0.0, -9.81]), np.zeros(3)))
        nav.update(AttitudeSample(t, np.zeros(3)))
        if gps and k % 10 == 0:
            nav.update(GpsSample(t, np.array([0.0, 0.0, -60.0]), np.zeros(3)))
        if k % 5 == 0:
            nav.update(BaroSample(t, 60.0))


def test_engages_vision_after_gps_loss_and_survives_bad_input():
    nav = _nav()
    _hover(nav, 0.0, 2.0)
    assert nav.estimate(2.0).source == "gps" and nav.backend is None
    _hover(nav, 2.0, 3.0, gps=False)  # GPS silent for > 0.5 s
    est = nav.estimate(3.0)
    assert est.source == "vision" and est.valid
    np.testing.assert_allclose(est.position, [0, 0, -60], atol=0.2)
    n = nav.h.rejected_samples
    nav.update(ImuSample(3.0, np.array([np.nan, 0, 0]), np.zeros(3)))
    nav.update(BaroSample(3.0, float("nan")))
    assert nav.h.rejected_samples == n + 2
    # blank frames: no features -> odometry skipped with the reason; textureless -> no registration
    for k in range(6):  # (not bit-identical: a repeated frame is a frozen link, dropped before the odometry)
        nav.update(Frame(3.0 + 0.2 * k, np.full((288, 384), 100 + k % 2, np.uint8)))
        _hover(nav, 3.0 + 0.2 * k, 3.2 + 0.2 * k, gps=False)
    notes = " ".join(nav.h.notes)
    assert "odometry skipped" in notes and "textureless frame" in notes
    assert not nav.h.tracking
    assert np.all(np.isfinite(nav.estimate(4.2).position))


def _engaged():
    nav = _nav()
    _hover(nav, 0.0, 2.0)
    _hover(nav, 2.0, 3.0, gps=False)
    assert nav.backend is not None
    return nav


def test_frozen_frame_is_dropped_and_degrades_until_a_live_frame():
    """A frame bit-identical to the previous one is a frozen link (issue #18): not odometry of no motion."""
    nav = _engaged()
    img = np.random.default_rng(1).integers(0, 255, (288, 384), dtype=np.uint8)
    nav.update(Frame(3.0, img))
    _hover(nav, 3.0, 3.2, gps=False)  # (a frame is processed when the filter has reached its instant)
    assert nav.n_frames == 0 and nav._frozen.count == 0
    for k in range(3):
        nav.update(Frame(3.2 + 0.2 * k, img.copy()))  # the same bits: dropped, never reaches the odometry
        _hover(nav, 3.2 + 0.2 * k, 3.4 + 0.2 * k, gps=False)
    assert nav.n_frames == 3 and nav._frozen.count == 3  # counted as frames (the last one queued), measured nothing
    assert nav.skipped_odometry >= 3 and nav.registrations == 0
    assert "frozen camera (frame repeated)" in " ".join(nav.h.notes)
    h = nav.health(3.8)
    assert h.integrity != "ok" and "frozen camera (3 frames" in h.integrity_reason
    live = img.copy()
    live[0, 0] ^= 1  # one bit differs: a live frame
    nav.update(Frame(3.8, live))
    _hover(nav, 3.8, 4.0, gps=False)
    nav.update(Frame(4.0, img))
    assert nav.n_frames == 5
    assert "frozen" not in nav.health(4.0).integrity_reason


def test_gyro_bias_step_excludes_the_gyros_within_a_second():
    """Gyros 0.5 deg/s off on every axis (the fault campaign's step) against the autopilot's attitude: flagged
    within 1 s, the navigator goes on with the autopilot's attitude and says why; without the step, nothing."""
    nav = _engaged()
    _hover(nav, 3.0, 6.0, gps=False)
    assert nav.gyro_check is not None and "gyros" not in nav.health(6.0).integrity_reason
    bias = np.radians([0.5, 0.5, 0.5])
    for k in range(600, 800):
        t = k / 100
        nav.update(ImuSample(t, np.array([0.0, 0.0, -9.81]), bias))
        nav.update(AttitudeSample(t, np.zeros(3)))
        if k % 5 == 0:
            nav.update(BaroSample(t, 60.0))
        if nav.gyro_check is None:
            break
    assert nav.gyro_check is None and 6.0 < t <= 7.0  # excluded within 1 s
    h = nav.health(t)
    assert h.integrity != "ok" and "gyros turned" in h.integrity_reason and "gyros excluded" in h.integrity_reason
    _hover(nav, t + 0.01, 12.0, gps=False)  # the biased gyros are no longer integrated into the attitude
    assert np.max(np.abs(nav.estimate(12.0).attitude)) < np.radians(0.5)
