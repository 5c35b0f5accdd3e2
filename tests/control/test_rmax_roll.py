"""Eq. 4.26 inner roll compensator of the PFCM (seed 002 §4.5): discretisation, design, closed loop."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from visnav.control.rmax import ROLL_DC
from visnav.control.rmax_path import COMPENSATED_LATERAL, PathFollowingController, PathLoopGains, design_path_loop
from visnav.control.rmax_roll import ROLL_COMPENSATOR, RollCompensator, compensator_tf, roll_loop, roll_plant
from visnav.guidance.pfcm import PointHold
from visnav.measurements import NavEstimate, VehicleState, YacsCommand
from visnav.vehicles.rmax import RmaxModel

G = 9.81


@pytest.mark.parametrize("params", [ROLL_COMPENSATOR, {"k": 1.7, "alpha": 0.3, "tau": 0.2, "ki": 2.5},
                                    {"k": 2.0, "alpha": 1.0, "tau": 0.1, "ki": 0.0}])
def test_discrete_step_response_matches_tustin(params):
    n = 300
    ref = np.squeeze(ct.step_response(ct.sample_system(compensator_tf(**params), 0.02, "tustin"),
                                      T=np.arange(n) * 0.02).outputs)
    c = RollCompensator(**params, rate_hz=50.0, input_limit=np.inf)
    out = np.array([c.step(1.0) for _ in range(n)])
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-9)
    # continuous forms: DC of the lead part K α, high-frequency gain K
    assert abs(compensator_tf(**{**params, "ki": 0.0})(0.0)) == pytest.approx(params["k"] * params["alpha"])
    assert abs(compensator_tf(**params)(1e7j)) == pytest.approx(params["k"], rel=1e-4)


def test_anti_windup_and_bumpless_start():
    c = RollCompensator(**ROLL_COMPENSATOR, input_limit=500.0)
    lim = 500.0 * ROLL_DC  # 22.5 deg of command
    c.reset(0.0, 5.0)
    assert c.last == pytest.approx(5.0)
    assert c.step(0.0) == pytest.approx(5.0)  # no error: the output holds (bumpless)
    for _ in range(200):  # 4 s of a 10 deg error: the integrator stops once the output is at the limit
        v = c.step(10.0)
    assert v == pytest.approx(lim, abs=1e-9) and c._i + c.kp_dc * 10.0 == pytest.approx(v)
    assert c._i < lim  # held, not wound up (free integration would reach 5 + 8*10*4 = 325 deg)
    v = c.step(-1.0)  # the error reverses: the output leaves the limit at once
    assert v < lim - 10.0
    with pytest.raises(ValueError, match="alpha must be in"):
        RollCompensator(3.0, 1.5, 0.5, 8.0)
    with pytest.raises(ValueError, match="roll error must be finite"):
        c.step(float("nan"))
    with pytest.raises(ValueError, match="tau must be finite and > 0"):
        PathLoopGains(roll_tau=0.0)


def test_inner_loop_design_margins_and_bandwidth():
    L, T = roll_loop(**ROLL_COMPENSATOR)
    gm, pm, _, w180, wc, _ = ct.stability_margins(L, returnall=True)
    pm, wc = np.atleast_1d(pm), np.atleast_1d(wc)
    assert wc.size == 1  # a single gain crossover (none near the 13 rad/s YACS resonance)
    assert pm[0] == pytest.approx(68.2, abs=0.3) and wc[0] == pytest.approx(4.78, abs=0.05)
    gm_db = 20 * np.log10(np.min(np.atleast_1d(gm)[np.atleast_1d(w180) > wc[0]]))
    assert gm_db == pytest.approx(17.2, abs=0.3)
    assert np.all(ct.poles(T).real < 0)
    assert ct.dcgain(T) == pytest.approx(1.0, abs=1e-9)  # the integral: unit DC gain from φ_c to φ
    bw, bw0 = ct.bandwidth(T), ct.bandwidth(roll_plant(0.01))
    assert bw == pytest.approx(5.58, abs=0.05) and bw0 == pytest.approx(3.05, abs=0.02) and bw > 1.7 * bw0
    w = np.geomspace(0.1, 300, 3000)
    assert np.abs(T(1j * w)).max() < 1.1  # no resonance peak
    assert abs(compensator_tf(**ROLL_COMPENSATOR)(1e7j)) == pytest.approx(3.0, rel=1e-4)  # noise gain K


def test_outer_lateral_loop_designed_on_the_inner_loop():
    d = design_path_loop(base=PathLoopGains(roll_compensator=True))
    d0 = design_path_loop()
    for name, v in COMPENSATED_LATERAL.items():
        assert getattr(d.gains, name) == pytest.approx(v, rel=1e-5), name
    m, m0 = d.margins["lateral"], d0.margins["lateral"]
    assert m.pm_deg == pytest.approx(45.0, abs=0.5) and m.gm_db >= 6.0
    assert m.w_gc > 1.5 * m0.w_gc and d.gains.k1r > 2 * d0.gains.k1r
    g = PathLoopGains.with_roll_compensator()
    assert g.roll_compensator and g.k1r == COMPENSATED_LATERAL["k1r"]


def _roll_step(compensated: bool, phi_c_deg: float = 5.0, t_end: float = 3.0) -> np.ndarray:
    """Roll of the identified R-MAX (vehicles/rmax.py) after a roll-command step at hover, 50 Hz."""
    init = VehicleState(t=0.0, position=np.array([0.0, 0.0, -20.0]), velocity=np.zeros(3), euler=np.zeros(3),
                        body_rates=np.zeros(3), specific_force=np.array([0, 0, -G]))
    heli = RmaxModel(dt=0.01, initial=init)
    comp = RollCompensator(**ROLL_COMPENSATOR) if compensated else None
    roll, ail = [], 0.0
    for k in range(int(t_end / 0.01)):
        if k % 2 == 0:
            phi = math.degrees(heli.state.euler[0])
            ail = (comp.step(phi_c_deg - phi) if comp else phi_c_deg) / ROLL_DC
            roll.append(phi)
        heli.step(YacsCommand(t=k * 0.01, ail=ail), 0.01)
    return np.array(roll)


def _rise_time(y: np.ndarray, final: float, dt: float = 0.02) -> float:
    return dt * (np.argmax(y >= 0.9 * final) - np.argmax(y >= 0.1 * final))


def test_compensated_roll_rises_faster_on_the_model():
    y0, y1 = _roll_step(False), _roll_step(True)
    tr0, tr1 = _rise_time(y0, 5.0), _rise_time(y1, 5.0)
    assert tr1 < 0.65 * tr0, (tr0, tr1)  # 0.40 s against 0.68 s
    # the model agrees with python-control's step of the designed loops (rise time, overshoot)
    info0, info1 = ct.step_info(roll_plant(0.01)), ct.step_info(roll_loop(**ROLL_COMPENSATOR)[1])
    assert tr0 == pytest.approx(info0["RiseTime"], abs=0.03) and tr1 == pytest.approx(info1["RiseTime"], abs=0.03)
    assert 100 * (y1.max() / 5.0 - 1) == pytest.approx(info1["Overshoot"], abs=1.0)  # 12.6 %
    assert y1[-10:].mean() == pytest.approx(5.0, abs=0.05)  # the integral: no steady error


def test_controller_uses_the_inner_loop():
    g = PathLoopGains.with_roll_compensator(pitch_feedforward=False, load_factor_feedforward=False)
    c = PathFollowingController(g)
    ref = PointHold([0, 0, -20], 0.0)

    def nav(t, roll):
        return NavEstimate(t=t, position=np.array([0.0, 1.0, -20.0]), velocity=np.zeros(3),
                           attitude=np.array([roll, 0.0, 0.0]))
    first = c.command(0.0, nav(0.0, 0.0), ref)
    phi_c = c.attitude_command[0]
    assert phi_c == pytest.approx(-g.k1r / G)
    assert first.ail == pytest.approx(math.degrees(phi_c) / ROLL_DC)  # bumpless: the DC inversion
    # the measured roll lags the command: the compensator asks for more than the DC inversion
    cmd = c.command(0.02, nav(0.02, 0.0), ref)
    assert cmd.ail < first.ail
    e = math.degrees(c.attitude_command[0])
    expect = RollCompensator(**ROLL_COMPENSATOR)
    expect.reset(math.degrees(phi_c), math.degrees(phi_c))
    assert cmd.ail == pytest.approx(expect.step(e) / ROLL_DC, rel=1e-9)
