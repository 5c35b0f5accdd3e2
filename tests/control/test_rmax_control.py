"""Tests of the PALACE position loop on the RMAX (seed 000 §2.1.2, §5.2; seed 002 eq. 3.4)."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest

from visnav.control.rmax import (
    CLIMB_GAIN,
    PLANT_TFS,
    RmaxPositionController,
    RmaxPositionGains,
    design_position_loop,
    loop_margins,
    position_loop,
)
from visnav.measurements import NavEstimate, PositionReference
from visnav.vehicles.base import Environment
from visnav.vehicles.rmax import RMAX_TRANSFER_FUNCTIONS, RmaxModel, RmaxParams

DT = 0.01


@pytest.fixture(scope="module")
def design():
    return design_position_loop()


def _loop_numpy(axis: str, kp: float, kd: float, ki: float, w: np.ndarray, delay: float) -> np.ndarray:
    """L(jω) from the raw eq. 3.4 / 3.9 coefficients with an exact delay e^{−jωτ}."""
    s = 1j * w
    num, den = RMAX_TRANSFER_FUNCTIONS["roll" if axis == "lateral" else "pitch"]
    drag = -0.1 if axis == "lateral" else -0.025
    att = np.polyval(num, s) / np.polyval(den, s) / (num[-1] / den[-1])
    return (kp + kd * s + ki / s) * att / (s * (s - drag)) * np.exp(-s * delay)


def _margins_numpy(L: np.ndarray, w: np.ndarray) -> tuple[float, float, float, float]:
    """PM at the (single) gain crossover and GM at the first −180° crossing above it, by interpolation."""
    lm = np.log(np.abs(L))
    i = np.flatnonzero(np.diff(np.sign(lm)) != 0)
    assert i.size == 1
    i = i[0]
    f = lm[i] / (lm[i] - lm[i + 1])
    w_gc = w[i] * (w[i + 1] / w[i]) ** f
    ph = np.degrees(np.unwrap(np.angle(L)))
    ph -= 360 * np.round(ph[0] / 360)  # two integrators + PID integrator -> starts near −180
    if ph[0] > 0:
        ph -= 360
    pm = 180 + ph[i] + f * (ph[i + 1] - ph[i])
    j = np.flatnonzero((ph[:-1] > -180) & (ph[1:] <= -180) & (np.arange(len(w) - 1) > i))[0]
    g = (ph[j] + 180) / (ph[j] - ph[j + 1])
    w_pc = w[j] * (w[j + 1] / w[j]) ** g
    gm_db = -20 * (lm[j] + g * (lm[j + 1] - lm[j])) / math.log(10)
    return pm, w_gc, gm_db, w_pc


def test_plant_copy_matches_the_vehicle_model():
    for name, (num, den) in PLANT_TFS.items():
        np.testing.assert_allclose(num, RMAX_TRANSFER_FUNCTIONS[name][0])
        np.testing.assert_allclose(den, RMAX_TRANSFER_FUNCTIONS[name][1])


def test_design_margins_positive_and_near_45_deg(design):
    for m in (design.lateral, design.longitudinal):
        assert m.gm_db > 0 and 40 <= m.pm_deg <= 50
        assert 0 < m.w_gc < m.w_pc
    for m in (design.vertical, design.yaw):
        assert m.gm_db > 6 and m.pm_deg > 45
    # a PD can never cross over higher than the velocity-feedback limit
    assert design.lateral.w_gc < design.crossover_limit["lateral"]
    assert design.longitudinal.w_gc < design.crossover_limit["longitudinal"]


@pytest.mark.parametrize("axis", ["lateral", "longitudinal"])
def test_margins_cross_checked_on_a_numpy_grid(design, axis):
    k = design.gains
    kp, kd, ki = (k.kp_lat, k.kd_lat, k.ki_lat) if axis == "lateral" else (k.kp_lon, k.kd_lon, k.ki_lon)
    w = np.geomspace(0.05, 30, 20000)
    pm, w_gc, gm_db, w_pc = _margins_numpy(_loop_numpy(axis, kp, kd, ki, w, 0.05), w)
    m = getattr(design, axis)
    assert pm == pytest.approx(m.pm_deg, abs=0.1)
    assert w_gc == pytest.approx(m.w_gc, rel=2e-3)
    assert gm_db == pytest.approx(m.gm_db, abs=0.1)
    assert w_pc == pytest.approx(m.w_pc, rel=3e-3)


@pytest.mark.parametrize("axis", ["lateral", "longitudinal"])
def test_design_maximises_position_gain_on_the_45_deg_locus(design, axis):
    """At a 45° crossover ω, Kp = Re(e^{−j135°}/P(jω)) for any Kd/Ki split: the design takes the max."""
    w = np.geomspace(0.2, 3.0, 5000)
    L1 = _loop_numpy(axis, 1.0, 0.0, 0.0, w, 0.05)  # = P(jω) (Padé replaced by the exact delay)
    kp_max = np.max(np.real(np.exp(-1j * np.radians(135)) / L1))
    kp = design.gains.kp_lat if axis == "lateral" else design.gains.kp_lon
    assert kp == pytest.approx(kp_max, rel=2e-3)


def test_default_gains_are_the_designed_ones(design):
    default = RmaxPositionGains()
    for f in fields(default):
        a, b = getattr(default, f.name), getattr(design.gains, f.name)
        if isinstance(a, float):
            assert a == pytest.approx(b, rel=1e-2), f.name


def test_extra_delay_costs_the_phase_it_should(design):
    """An added delay τ lowers the PM by ω_gc·τ (gains unchanged, crossover unchanged)."""
    m = loop_margins(position_loop("lateral", design.gains, delay_s=0.043))
    assert m.w_gc == pytest.approx(design.lateral.w_gc, rel=1e-6)
    lost = math.degrees(design.lateral.w_gc * 0.043)
    assert design.lateral.pm_deg - m.pm_deg == pytest.approx(lost, abs=0.05)


def test_climb_gain_closed_form():
    assert CLIMB_GAIN == pytest.approx(9.81 * 0.0828 * 3.37 / (0.95 * 214.1))


def _nav(state) -> NavEstimate:
    return NavEstimate(state.t, state.position, state.velocity, state.euler)


def simulate(ref: PositionReference, seconds: float, gains=None, wind=(0.0, 0.0, 0.0), yaw=0.0):
    model = RmaxModel(RmaxParams(), DT, position=(0.0, 0.0, -20.0), yaw=yaw)
    ctrl = RmaxPositionController(gains)
    st, pos = model.state, []
    for _ in range(int(round(seconds / DT))):
        st = model.step(ctrl.command(st.t, _nav(st), ref), DT, Environment(np.asarray(wind, float)))
        pos.append(st.position)
    return np.array(pos), st


@pytest.mark.parametrize("yaw,axis", [(0.0, 1), (math.pi / 2, 0)])
def test_lateral_step_settles_without_much_overshoot(yaw, axis):
    """5 m step east (yaw 0: lateral axis) or north with the nose east (yaw 90°: lateral again)."""
    target = np.array([0.0, 0.0, -20.0])
    target[axis] = 5.0
    pos, _ = simulate(PositionReference(0.0, target, yaw=yaw), 20.0, yaw=yaw)
    err = np.linalg.norm(pos - target, axis=1)
    assert pos[:, axis].max() < 5.0 + 0.3 * 5.0
    assert np.all(err[int(15 / DT):] < 0.1)


def test_heading_rotation_selects_the_cyclic_axis():
    ctrl = RmaxPositionController()
    nav = NavEstimate(0.0, np.array([0.0, 0.0, -20.0]), np.zeros(3), np.array([0.0, 0.0, math.pi / 2]))
    ref = PositionReference(0.0, np.array([5.0, 0.0, -20.0]), yaw=math.pi / 2)
    cmd = ctrl.command(0.0, nav, ref)
    assert cmd.ail < -10 and abs(cmd.ele) < 1e-9  # target north = to the left of a nose-east vehicle
    ctrl.reset()
    nav0 = NavEstimate(0.0, nav.position, np.zeros(3), np.zeros(3))
    cmd = ctrl.command(0.0, nav0, replace(ref, yaw=0.0))
    assert cmd.ele < -10 and abs(cmd.ail) < 1e-9  # target ahead: nose down


def test_output_is_held_between_10_hz_updates():
    ctrl = RmaxPositionController()
    ref = PositionReference(0.0, np.array([1.0, 2.0, -20.0]))
    cmds = []
    for k in range(100):
        t = k * DT
        nav = NavEstimate(t, np.array([0.0, 0.01 * k, -20.0]), np.zeros(3), np.zeros(3))
        cmds.append(ctrl.command(t, nav, ref))
    assert len({c.ail for c in cmds}) == 10 and len({c.t for c in cmds}) == 10
    assert cmds[9] == cmds[0] and cmds[10] != cmds[9]


def test_steady_wind_offset_without_integral_is_the_closed_form():
    """Without integral: Kp e = drag of the wind, e_y = Yv·v_w/Kp_lat, e_x = Xu·u_w/Kp_lon."""
    g = replace(RmaxPositionGains(), ki_lat=0.0, ki_lon=0.0)
    ref = PositionReference(0.0, np.array([0.0, 0.0, -20.0]))
    pos, _ = simulate(ref, 50.0, gains=g, wind=(2.0, 3.0, 0.0))
    assert -pos[-1, 1] == pytest.approx(-0.1 * 3.0 / g.kp_lat, rel=2e-2)
    assert -pos[-1, 0] == pytest.approx(-0.025 * 2.0 / g.kp_lon, rel=2e-2)


def test_hover_in_3_m_s_wind_holds_within_20_cm():
    ref = PositionReference(0.0, np.array([0.0, 0.0, -20.0]))
    pos, st = simulate(ref, 60.0, wind=(3.0 / math.sqrt(2), 3.0 / math.sqrt(2), 0.0))
    err = np.linalg.norm(pos - ref.position, axis=1)
    assert np.all(err[int(30 / DT):] < 0.2)
    assert abs(st.velocity).max() < 0.05


def test_climb_and_yaw_reach_the_reference():
    ref = PositionReference(0.0, np.array([0.0, 0.0, -25.0]), yaw=1.0)
    pos, st = simulate(ref, 25.0)
    assert st.position[2] == pytest.approx(-25.0, abs=0.05)
    assert st.euler[2] == pytest.approx(1.0, abs=1e-3)


def test_bad_input():
    with pytest.raises(ValueError, match="rate_hz"):
        RmaxPositionController(rate_hz=0.0)
    with pytest.raises(ValueError, match="kp_lat"):
        RmaxPositionGains(kp_lat=-1.0)
    with pytest.raises(ValueError, match="target_pm_deg"):
        design_position_loop(target_pm_deg=120.0)
    with pytest.raises(ValueError, match="axis"):
        position_loop("sideways")
    ctrl = RmaxPositionController()
    nav = NavEstimate(0.0, np.array([np.nan, 0.0, 0.0]), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="nav.position"):
        ctrl.command(0.0, nav, PositionReference(0.0, np.zeros(3)))
