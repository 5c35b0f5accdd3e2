"""PFCM outer loop (seed 002 eq. 4.25) on the R-MAX: design, signs and units, limits, closed loop."""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
import pytest

from visnav.control.rmax import CLIMB_GAIN, PITCH_DC, ROLL_DC, YAW_RATE_DC
from visnav.control.rmax_path import PathFollowingController, PathLoopGains, design_path_loop
from visnav.control.rmax_path import PathReference, YacsCommand
from visnav.guidance.hermite import HermitePath
from visnav.guidance.pfcm import PfcmGuidance, PfcmLimits, PointHold
from visnav.measurements import NavEstimate, VehicleState
from visnav.vehicles.rmax import RmaxModel

G = 9.81


def _nav(p, v=(0, 0, 0), yaw=0.0, t=0.0):
    return NavEstimate(t=t, position=np.asarray(p, float), velocity=np.asarray(v, float),
                       attitude=np.array([0.0, 0.0, yaw]))


@pytest.fixture(scope="module")
def design():
    return design_path_loop()


def test_design_reproduces_the_default_gains_with_margins(design):
    d, g0 = design.gains, PathLoopGains()
    for f in fields(PathLoopGains):
        if f.name.startswith("k"):
            assert getattr(d, f.name) == pytest.approx(getattr(g0, f.name), rel=1e-4, abs=1e-9), f.name
    for axis in ("lateral", "longitudinal"):
        m = design.margins[axis]
        assert m.pm_deg == pytest.approx(45.0, abs=0.5) and m.gm_db >= 6.0
    assert design.margins["vertical"].pm_deg == pytest.approx(60.0, abs=0.5)
    assert design.margins["vertical"].w_gc == pytest.approx(2.0, rel=0.01)
    assert design.margins["yaw"].w_gc == pytest.approx(1.0, rel=0.01)
    # the 50 Hz loop is stiffer than the 10 Hz PALACE loop (less sample-and-hold delay)
    from visnav.control.rmax import RmaxPositionGains
    assert d.k1r > RmaxPositionGains().kp_lat


def test_yacs_unit_gains():
    g = PathLoopGains()
    u = g.yacs_units()
    assert u["K1r"] == pytest.approx(math.degrees(g.k1r / G) / ROLL_DC)
    assert u["K2p"] == pytest.approx(math.degrees(g.k2p / G) / PITCH_DC)
    assert u["K1t"] == pytest.approx(g.k1t / CLIMB_GAIN)
    assert u["K1y"] == pytest.approx(math.degrees(g.k1y) / YAW_RATE_DC)


def _straight_reference(v_target=0.0, position=(0.0, 0.0, -20.0)):
    """A PathReference on a straight north path (from a hold, then edited)."""
    import dataclasses

    r = PointHold(position, 0.0).step(0.0, _nav(position))
    return dataclasses.replace(r, velocity=np.array([v_target, 0.0, 0.0]), v_target=v_target)


def test_signs_and_units_of_eq_4_25():
    g = PathLoopGains(pitch_feedforward=False, load_factor_feedforward=False)
    c = PathFollowingController(g)
    # the helicopter 1 m right of and 0.5 m above the path, heading north, hovering
    cmd = c.command(0.0, _nav([0.0, 1.0, -20.5]), _straight_reference())
    assert cmd.ail == pytest.approx(math.degrees(-g.k1r * 1.0 / G) / ROLL_DC)  # roll left
    assert cmd.thr == pytest.approx(-g.k1t * 0.5 / CLIMB_GAIN)  # descend
    assert cmd.ele == 0.0 and cmd.rud == 0.0
    # slower than the target: pitch down (negative θ) by K2p δv_x / g
    c.reset()
    cmd = c.command(0.0, _nav([0.0, 0.0, -20.0], v=[3.0, 0, 0]), _straight_reference(v_target=5.0))
    assert cmd.ele == pytest.approx(math.degrees(-g.k2p * 2.0 / G) / PITCH_DC)
    # heading 10 deg left of the path: yaw right
    c.reset()
    cmd = c.command(0.0, _nav([0.0, 0.0, -20.0], yaw=math.radians(-10)), PointHold([0, 0, -20], 0.0))
    assert cmd.rud == pytest.approx(math.degrees(g.k1y * math.radians(10)) / YAW_RATE_DC)


def test_rotation_into_the_heading_frame():
    g = PathLoopGains(pitch_feedforward=False, load_factor_feedforward=False)
    c = PathFollowingController(g)
    # heading east; the helicopter 1 m north of the hold point = 1 m to its left: roll right
    cmd = c.command(0.0, _nav([1.0, 0.0, -20.0], yaw=math.pi / 2), PointHold([0, 0, -20], math.pi / 2))
    assert cmd.ail == pytest.approx(math.degrees(g.k1r / G) / ROLL_DC)
    assert cmd.ele == pytest.approx(0.0, abs=1e-9)


def test_limits_and_saturation_time():
    g = PathLoopGains()
    c = PathFollowingController(g)
    far = _nav([0.0, 100.0, -20.0])
    for k in range(51):  # 1 s at 50 Hz, 100 m off the path
        cmd = c.command(k * 0.02, far, PointHold([0, 0, -20], 0.0))
    assert math.radians(abs(cmd.ail) * ROLL_DC) == pytest.approx(g.max_roll)
    assert c.saturation_time_s == pytest.approx(1.0) and c.channel_saturation_s["ail"] == pytest.approx(1.0)
    assert c.channel_saturation_s["ele"] == 0.0
    assert np.linalg.norm(c._i_lat) == 0.0  # no wind-up while saturated


def test_bad_input():
    with pytest.raises(ValueError, match="k1r must be finite and >= 0"):
        PathLoopGains(k1r=-1.0)
    with pytest.raises(ValueError, match="rate_hz"):
        PathFollowingController(rate_hz=0.0)
    c = PathFollowingController()
    with pytest.raises(ValueError, match="nav.position must be 3 finite values"):
        c.command(0.0, _nav([np.nan, 0, 0]), PointHold([0, 0, -20], 0.0))
    with pytest.raises(ValueError, match="PathReference"):
        c.command(0.0, _nav([0, 0, -20]), object())


def test_closed_loop_on_the_model_follows_a_turn():
    """Guidance + eq. 4.25 at 50 Hz on the R-MAX model with perfect navigation (no wind):
    a 90 deg turn of 30 m radius at 5 m/s, about 25 s."""
    P = [[0, 0, -20], [20, 0, -20], [41.2132, 8.7868, -20], [50, 30, -20], [50, 45, -20]]
    T = [[1, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 1, 0]]
    path = HermitePath.from_waypoints(P, T)
    guide = PfcmGuidance(path, PfcmLimits(v_cruise=5.0))
    ctrl = PathFollowingController()
    init = VehicleState(t=0.0, position=np.array(P[0], float), velocity=np.zeros(3), euler=np.zeros(3),
                        body_rates=np.zeros(3), specific_force=np.array([0, 0, -G]))
    heli = RmaxModel(dt=0.01, initial=init)
    cmd, err, roll = None, [], []
    for k in range(3000):
        st = heli.state
        if k % 2 == 0:
            nav = NavEstimate(t=k * 0.01, position=st.position, velocity=st.velocity, attitude=st.euler)
            cmd = ctrl.command(k * 0.01, nav, guide)
            err.append(np.linalg.norm(guide.last.position - st.position))
            roll.append(st.euler[0])
            if guide.last.finished:
                break
        heli.step(cmd, 0.01)
    assert guide.last.finished or guide.last.distance_to_end < 0.5
    assert max(err) < 0.3 and np.sqrt(np.mean(np.square(err))) < 0.15
    # the bank of the trimmed turn: tan(phi) = v²/(g R) = 4.9 deg
    assert math.degrees(max(roll)) == pytest.approx(math.degrees(math.atan(25 / (G * 30))), abs=1.0)
