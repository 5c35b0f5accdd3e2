"""CondorNavigator.estimate(t) is kept for the same t until the next update / command / initialize: asked
again it is the same object; after any of them it is computed again (and equals a fresh navigator's)."""

import numpy as np

from visnav.measurements import AttitudeSample, GpsSample, ImuSample, NavCommand, NavInit
from visnav.scenarios.schema import load_scenario
from visnav.app.condor_parts import build_navigator
from visnav.sensors.condor_camera import condor_camera


def _nav():
    sc = load_scenario("condor-orbit")
    c = sc.sensors.camera
    return build_navigator(sc, condor_camera(c.width_px, c.height_px, c.hfov_deg, c.k1, c.k2, c.crop_dx_px,
                                              c.crop_dy_px))


def test_estimate_memo_follows_every_change():
    nav = _nav()
    nav.initialize(NavInit(0.0, "survey", position=np.zeros(3)))
    nav.update(GpsSample(0.0, np.array([120.0, 0.0, -100.0]), np.array([0.0, 17.0, 0.0])))
    e1 = nav.estimate(0.02)
    assert nav.estimate(0.02) is e1
    assert nav.estimate(0.04) is not e1
    nav.update(AttitudeSample(0.02, np.array([0.3, 0.05, 1.6])))
    e2 = nav.estimate(0.02)
    assert e2 is not e1 and e2.attitude[0] == 0.3
    nav.update(ImuSample(0.02, np.array([0.0, 0.0, -9.81]), np.array([0.0, 0.01, 0.1])))
    e3 = nav.estimate(0.02)
    assert e3 is not e2 and e3.body_rates[2] == 0.1
    nav.command(NavCommand(0.02, "set_source", {"source": "vision"}))
    e4 = nav.estimate(0.02)
    assert e4.source == "vision" and e3.source == "gps"
    nav.initialize(NavInit(0.02, "survey", position=np.array([5.0, 0.0, 0.0])))
    assert nav.estimate(0.02) is not e4
