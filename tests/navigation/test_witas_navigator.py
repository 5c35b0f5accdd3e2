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
    blank = np.full((288, 384), 100, np.uint8)
    for k in range(6):
        nav.update(Frame(3.0 + 0.2 * k, blank))
        _hover(nav, 3.0 + 0.2 * k, 3.2 + 0.2 * k, gps=False)
    notes = " ".join(nav.h.notes)
    assert "odometry skipped" in notes and "textureless frame" in notes
    assert not nav.h.tracking
    assert np.all(np.isfinite(nav.estimate(4.2).position))
