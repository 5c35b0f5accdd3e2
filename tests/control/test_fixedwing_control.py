"""CONDOR inner loops (seed 004 eq. 5.5-5.9) on the 6-DOF model, and the turn coordinator."""

import math

import numpy as np

from visnav.vehicles.base import Environment
import pytest

from visnav.control.fixedwing import AirData, FixedWingAutopilot, InnerGains, heading_rate
from visnav.vehicles.fixedwing import FixedWingModel, FixedWingParams, trim

P = FixedWingParams()
TR = trim(P, 17.0)


def _fly(psidot_ref, rud_ref, seconds=20.0, h_des=100.0, start_h=100.0):
    m = FixedWingModel.from_trim(P, TR, [0, 0, -start_h], 0.0)
    ap = FixedWingAutopilot(InnerGains(), TR.controls)
    hist = []
    for k in range(int(seconds / 0.02)):
        x = m.x
        air = AirData(x[6], x[7], x[9], x[10], x[11], -x[2], m.air["Va"] or 17.0, float(m.air["specific_force"][1]))
        rr = rud_ref if rud_ref != "same" else psidot_ref
        u, info = ap.law(0.02, air, psidot_ref, rr, 17.0, h_des, 17.0)
        for _ in range(2):
            m.step(u, 0.01, Environment(np.zeros(3)))
        hist.append((x[6], info["phi_ref"], -x[2], m.air["beta"], info["psidot"], m.air["Va"]))
    return np.array(hist), ap


def test_heading_rate_formula():
    # level turn: p = -psidot sin(theta), q = psidot sin(phi) cos(theta), r = psidot cos(phi) cos(theta)
    phi, th, pd = 0.4, 0.05, 0.15
    q, r = pd * math.sin(phi) * math.cos(th), pd * math.cos(phi) * math.cos(th)
    assert heading_rate(phi, th, q, r) == pytest.approx(pd)


@pytest.mark.parametrize("rudder", ["same", None])
def test_bank_and_altitude_hold_in_a_turn(rudder):
    psidot = 17.0 / 110.0
    h, ap = _fly(psidot, rudder, 25.0)
    last = h[-500:]
    phi_ref = math.atan(17.0 * psidot / 9.81)  # eq. 5.4
    assert np.mean(last[:, 1]) == pytest.approx(phi_ref, abs=1e-9)
    # the PD bank loop (eq. 5.5, no integral) settles a little short of its reference
    assert np.mean(last[:, 0]) == pytest.approx(phi_ref, abs=math.radians(1.5))
    assert np.abs(last[:, 2] - 100.0).max() < 1.5  # eq. 5.8-5.9 altitude hold
    assert np.abs(last[:, 5] - 17.0).max() < 0.3
    assert np.mean(last[:, 4]) == pytest.approx(psidot, rel=0.15)
    if rudder is None:  # the turn coordinator nulls the sideslip: psidot = g tan(phi) / V
        assert abs(np.mean(last[:, 3])) < math.radians(0.5)
        assert np.mean(last[:, 4]) == pytest.approx(9.81 * math.tan(np.mean(last[:, 0])) / 17.0, rel=0.02)


def test_bank_reference_limit_and_hold():
    h, ap = _fly(1.0, "same", 2.0)
    assert np.max(h[:, 1]) == pytest.approx(math.radians(35.0))  # phi_ref limited to 35 deg
    ap = FixedWingAutopilot(InnerGains(), TR.controls)
    air = AirData(math.radians(50), 0.0, 0.0, 0.0, 0.3, 100.0, 17.0, 0.0)
    u, info = ap.law(0.02, air, 0.0, 0.0, 17.0, 100.0, 17.0)
    assert info["bank_hold"]  # eq. 5.7: above 45 deg the bank hold takes over
    assert u.aileron < TR.controls.aileron  # rolls back toward 45 deg
    assert u.rudder - TR.controls.rudder == pytest.approx(math.radians(10.0))


def test_nan_input_is_refused():
    ap = FixedWingAutopilot(InnerGains(), TR.controls)
    with pytest.raises(ValueError, match="Va"):
        ap.law(0.02, AirData(0, 0, 0, 0, 0, 100, math.nan, 0), 0.1, 0.1, 17, 100, 17)


def test_scalar_clip_equals_numpy_clip():
    """The autopilot's and the gimbal's scalar clip gives what float(np.clip(...)) gave, NaN and
    signed zeros included."""
    from visnav.control.fixedwing import _clip as clip_ap
    from visnav.sensors.gimbal import _clip as clip_gb

    rng = np.random.default_rng(2)
    xs = list(rng.normal(0.0, 2.0, 200)) + [math.nan, -0.0, 0.0, 1.0, -1.0, math.inf, -math.inf]
    for lo, hi in ((-1.0, 1.0), (0.0, 1.0), (-0.5, 0.0)):
        for x in xs:
            want = float(np.clip(x, lo, hi))
            for clip in (clip_ap, clip_gb):
                got = clip(x, lo, hi)
                assert (math.isnan(got) and math.isnan(want)) or (got == want and math.copysign(1, got)
                                                                   == math.copysign(1, want))


def test_scaled_gains_carry_the_loops_to_the_pingwing():
    """The geo-location MAV's gains: the CONDOR gains tuned on the 1.1 m airframe at 13 m/s, scaled by the
    control power; exactly the same gains on the reference itself."""
    from dataclasses import replace

    from visnav.control.fixedwing import control_power, scaled_gains
    from visnav.vehicles.fixedwing import micro_params

    ref, ping = micro_params(0.434, 1.1, 13.0), micro_params()
    g = InnerGains()
    assert scaled_gains(g, ref, 13.0, ref, 13.0) == g
    s = scaled_gains(g, ping, 19.0, ref, 13.0)
    (a0, e0, r0), (a1, e1, r1) = control_power(ref, 13.0), control_power(ping, 19.0)
    assert a1 > 4 * a0 and e1 > 30 * e0  # the small, fast airframe
    assert s.kp_phi * a1 == pytest.approx(g.kp_phi * a0) and s.kd_theta * e1 == pytest.approx(g.kd_theta * e0)
    assert s.kp_psi * r1 == pytest.approx(g.kp_psi * r0) and s.kp_theta == g.kp_theta

    def fly(gains, seconds=20.0):
        """A 35 deg-bank turn at 19 m/s and 70 m on the autopilot at 50 Hz, dynamics 50 Hz (the scenario's)."""
        tr = trim(ping, 19.0)
        m = FixedWingModel.from_trim(ping, tr, [0, 0, -70.0], 0.0)
        ap = FixedWingAutopilot(gains, tr.controls)
        out = []
        for _ in range(int(seconds / 0.02)):
            x = m.x
            air = AirData(x[6], x[7], x[9], x[10], x[11], -x[2], m.air["Va"] or 19.0, float(m.air["specific_force"][1]))
            u, _ = ap.law(0.02, air, 1.0, None, 19.0, 70.0, 19.0)
            m.step(u, 0.02, Environment(np.zeros(3)))
            out.append((x[6], -x[2], m.air["Va"]))
        return np.array(out)

    h = fly(s)
    last = h[-250:]
    assert np.degrees(np.abs(last[:, 0] - math.radians(35.0))).max() < 2.0  # the bank limit, held
    assert np.abs(last[:, 1] - 70.0).max() < 2.0 and np.abs(last[:, 2] - 19.0).max() < 0.5
    with pytest.raises((FloatingPointError, ValueError, OverflowError)):  # the unscaled gains: the 50 Hz roll and pitch loops diverge
        fly(replace(g))
