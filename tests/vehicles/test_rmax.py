"""Tests of the augmented RMAX model (seed 002 eq. 3.4, 3.7, 3.9, 3.10)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal
from scipy.linalg import expm

from visnav.measurements import VehicleState, YacsCommand
from visnav.vehicles.base import Environment
from visnav.vehicles.rmax import (
    RMAX_TRANSFER_FUNCTIONS,
    RmaxModel,
    RmaxParams,
    dc_gain,
    heave_height_gain,
    rmax_state_space,
)

DT = 0.01
G = 9.81


def run(model: RmaxModel, cmd: YacsCommand, seconds: float, wind=(0.0, 0.0, 0.0)):
    """States and eq. 3.4 outputs after each step."""
    states, outs = [], []
    for _ in range(int(round(seconds / DT))):
        states.append(model.step(cmd, DT, Environment(wind)))
        outs.append(model.yacs_outputs)
    return states, outs


def lsim_step(num, den, amplitude: float, n: int) -> np.ndarray:
    t = DT * np.arange(n + 1)
    _, y, _ = signal.lsim((num, den), amplitude * np.ones_like(t), t)
    return y[1:]


@pytest.mark.parametrize("field,channel,key", [
    ("ail", "roll", "roll_deg"), ("ele", "pitch", "pitch_deg"),
    ("rud", "yaw_rate", "yaw_rate_deg_s"), ("thr", "heave", "az_g")])
def test_step_response_matches_scipy_lsim(field, channel, key):
    model = RmaxModel(position=(0, 0, -50))
    _, outs = run(model, YacsCommand(0.0, **{field: 50.0}), 6.0)
    got = np.array([o[key] for o in outs])
    want = lsim_step(*RMAX_TRANSFER_FUNCTIONS[channel], 50.0, len(got))
    np.testing.assert_allclose(got, want, atol=1e-6)


def test_attitude_and_rates_in_si_from_the_tf_outputs():
    model = RmaxModel(position=(0, 0, -50))
    states, outs = run(model, YacsCommand(0.0, ail=50.0), 3.0)
    roll = np.array([s.euler[0] for s in states])
    np.testing.assert_allclose(np.degrees(roll), [o["roll_deg"] for o in outs], atol=1e-9)
    # pitch = yaw rate = 0 here, so eq. 3.7 gives p = φ̇: the impulse response (relative degree 2)
    t = DT * np.arange(1, len(states) + 1)
    _, imp = signal.impulse(RMAX_TRANSFER_FUNCTIONS["roll"], T=t)
    np.testing.assert_allclose([s.body_rates[0] for s in states], np.radians(50 * imp), atol=1e-6)


def test_dc_gains_closed_form():
    assert dc_gain("roll") == pytest.approx(2.3 * 53.3 / (16.2 * 168))
    assert dc_gain("pitch") == pytest.approx(0.5 * 75.5 / (5.55 * 123.5))
    assert dc_gain("yaw_rate") == pytest.approx(9.7 * 12.25 / (4.17 * 213.4))
    assert dc_gain("heave") == 0.0
    model = RmaxModel(position=(0, 0, -50))
    run(model, YacsCommand(0.0, ail=50.0, ele=-40.0), 20.0)
    out = model.yacs_outputs
    assert out["roll_deg"] == pytest.approx(50 * 2.3 * 53.3 / (16.2 * 168), rel=1e-6)
    assert out["pitch_deg"] == pytest.approx(-40 * 0.5 * 75.5 / (5.55 * 123.5), rel=1e-6)


def test_discrete_channels_are_zoh_of_the_continuous_ones():
    h = 0.02
    w = np.array([0.3, 2.0, 11.0])
    for name, m in rmax_state_space(h).items():
        n = m.A.shape[0]
        # the continuous realisation has the eq. 3.4 frequency response
        resp = [(m.C @ np.linalg.solve(1j * x * np.eye(n) - m.A, m.B))[0, 0] for x in w]
        num, den = RMAX_TRANSFER_FUNCTIONS[name]
        np.testing.assert_allclose(resp, np.polyval(num, 1j * w) / np.polyval(den, 1j * w), rtol=1e-9)
        # zero-order hold: expm([[A, B], [0, 0]] h) = [[Ad, Bd], [0, I]]
        big = np.zeros((n + 1, n + 1))
        big[:n, :n], big[:n, n:] = m.A * h, m.B * h
        e = expm(big)
        np.testing.assert_allclose(m.Ad, e[:n, :n], atol=1e-12)
        np.testing.assert_allclose(m.Bd, e[:n, n:], atol=1e-12)
    ch = rmax_state_space(h)
    for name in ("roll", "pitch", "yaw_rate"):  # relative degree 2: ẏ = C A x
        assert (ch[name].C @ ch[name].B)[0, 0] == pytest.approx(0.0, abs=1e-12)


def test_hover_equilibrium_holds_for_60_s():
    model = RmaxModel(position=(3.0, -2.0, -20.0), yaw=0.7)
    states, _ = run(model, YacsCommand(0.0), 60.0)
    assert np.max(np.abs(states[-1].position - [3.0, -2.0, -20.0])) < 1e-6
    assert states[-1].t == pytest.approx(60.0, abs=1e-9)
    np.testing.assert_allclose(states[-1].specific_force, [0.0, 0.0, -G], atol=1e-12)


def test_specific_force_equals_inertial_acceleration_minus_gravity():
    model = RmaxModel(position=(0, 0, -50))
    cmd = YacsCommand(0.0, ail=120.0, ele=-80.0, rud=40.0, thr=60.0)
    states, _ = run(model, cmd, 4.0, wind=(2.0, -1.0, 0.5))
    v = np.array([s.velocity for s in states])
    a_n = (v[2:] - v[:-2]) / (2 * DT)  # central differences at the middle samples
    for k in (50, 150, 300):
        s = states[k + 1]
        phi, th, psi = s.euler
        cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(th), np.sin(th), np.cos(psi), np.sin(psi)
        c_bn = np.array([[ct * cp, -cf * sp + sf * st * cp, sf * sp + cf * st * cp],
                         [ct * sp, cf * cp + sf * st * sp, -sf * cp + cf * st * sp],
                         [-st, sf * ct, cf * ct]])
        f = c_bn.T @ (a_n[k] - [0.0, 0.0, G])
        np.testing.assert_allclose(s.specific_force, f, atol=2e-3)


def test_steady_roll_terminal_velocity_closed_form():
    """Held φ: v̇ = Yv v + g sinφ -> v∞ = −g sinφ/Yv;
    ẇ = Zw w − g + g cosφ -> w∞ = g(1 − cosφ)/Zw (either heave damping: thr = 0)."""
    p = RmaxParams()
    model = RmaxModel(p, position=(0, 0, -500))
    states, _ = run(model, YacsCommand(0.0, ail=50.0), 100.0)
    phi = math.radians(50 * dc_gain("roll"))
    v_inf, w_inf = -G * math.sin(phi) / p.Yv, G * (1 - math.cos(phi)) / p.Zw
    east = v_inf * math.cos(phi) - w_inf * math.sin(phi)  # body -> NED for a pure roll
    down = v_inf * math.sin(phi) + w_inf * math.cos(phi)
    np.testing.assert_allclose(states[-1].velocity, [0.0, east, down], rtol=5e-3, atol=1e-9)
    # the early acceleration is g tanφ-like: g sinφ once the roll has settled and v is still small
    v = np.array([s.velocity[1] for s in states])
    acc = (v[300] - v[299]) / DT
    assert acc == pytest.approx(G * math.sin(phi) + p.Yv * v[300], rel=2e-2)


def test_constant_throttle_climb_rate_default_heave_damping():
    """Default: Zw on the air mass only, so ḣ/thr = g H(s) with aZ/thr = s H(s): a climb-rate step."""
    model = RmaxModel(RmaxParams(), position=(0, 0, -50))
    states, _ = run(model, YacsCommand(0.0, thr=100.0), 20.0)
    num, den = RMAX_TRANSFER_FUNCTIONS["heave"]
    climb = lsim_step(G * np.asarray(num)[:-1], den, 100.0, len(states))
    np.testing.assert_allclose([-s.velocity[2] for s in states], climb, atol=1e-6)
    assert -states[-1].velocity[2] == pytest.approx(100 * G * num[-2] / den[-1], rel=1e-3)


def test_constant_throttle_climb_rate_and_height_closed_form():
    """Literal eq. 3.9: ḣ/thr = g aZ/(s − Zw): zero steady climb rate, height step g H(0)/(−Zw)."""
    p = RmaxParams(heave_damping="full")
    model = RmaxModel(p, position=(0, 0, -50))
    states, _ = run(model, YacsCommand(0.0, thr=100.0), 20.0)
    num, den = RMAX_TRANSFER_FUNCTIONS["heave"]
    climb = lsim_step(G * num, np.polymul(den, [1.0, -p.Zw]), 100.0, len(states))
    np.testing.assert_allclose([-s.velocity[2] for s in states], climb, atol=1e-6)
    h0 = num[-2] / den[-1]
    assert heave_height_gain(p.Zw) == pytest.approx(G * h0 / 0.6)
    assert -states[-1].position[2] - 50 == pytest.approx(100 * G * h0 / 0.6, rel=1e-3)
    assert abs(states[-1].velocity[2]) < 1e-3


def test_yaw_integrates_the_yaw_rate_channel():
    model = RmaxModel(position=(0, 0, -50), yaw=0.2)
    states, _ = run(model, YacsCommand(0.0, rud=30.0), 4.0)
    num, den = RMAX_TRANSFER_FUNCTIONS["yaw_rate"]
    psi = 0.2 + np.radians(lsim_step(num, np.polymul(den, [1.0, 0.0]), 30.0, len(states)))
    np.testing.assert_allclose([s.euler[2] for s in states], psi, atol=1e-6)


@pytest.mark.parametrize("raw,clipped", [(800.0, 500.0), (-900.0, -500.0)])
def test_inputs_saturate_at_500(raw, clipped):
    a, b = RmaxModel(position=(0, 0, -50)), RmaxModel(position=(0, 0, -50))
    run(a, YacsCommand(0.0, ail=raw, ele=raw), 2.0)
    run(b, YacsCommand(0.0, ail=clipped, ele=clipped), 2.0)
    assert a.yacs_outputs == b.yacs_outputs
    c = RmaxModel(RmaxParams(trim=(100.0, 0.0, 0.0, 0.0)), position=(0, 0, -50))
    d = RmaxModel(position=(0, 0, -50))
    run(c, YacsCommand(0.0, ail=450.0), 2.0)  # trim + 450 clips at 500: increment 400
    run(d, YacsCommand(0.0, ail=400.0), 2.0)
    assert c.yacs_outputs["roll_deg"] == pytest.approx(d.yacs_outputs["roll_deg"], abs=1e-12)


def test_drag_acts_on_air_relative_body_velocity():
    for yaw, drag in ((0.0, -0.1), (math.pi / 2, -0.025)):  # east wind: side-on (Yv) or head-on (Xu)
        model = RmaxModel(position=(0, 0, -50), yaw=yaw)
        s = model.step(YacsCommand(0.0), 1e-3, Environment((0.0, 3.0, 0.0)))
        assert s.velocity[1] / 1e-3 == pytest.approx(-drag * 3.0, rel=1e-3)
    model = RmaxModel(RmaxParams(heave_damping="full"), position=(0, 0, -50))
    states, _ = run(model, YacsCommand(0.0), 12.0, wind=(0.0, 0.0, -2.0))  # updraft, 1/|Zw| = 1.7 s
    assert states[-1].velocity[2] == pytest.approx(-2.0, abs=2e-3)
    # default (YACS-held climb velocity): an updraft is a bounded velocity error, the same here
    model = RmaxModel(position=(0, 0, -50))
    states, _ = run(model, YacsCommand(0.0), 12.0, wind=(0.0, 0.0, -2.0))
    assert states[-1].velocity[2] == pytest.approx(-2.0, abs=2e-3)


def test_touchdown_and_lift_off():
    p = RmaxParams()
    model = RmaxModel(p, position=(0, 0, -1.0))
    states, _ = run(model, YacsCommand(0.0, thr=-200.0), 6.0)
    assert states[-1].on_ground and model.on_ground
    assert states[-1].position[2] == 0.0 and np.all(states[-1].velocity == 0.0)
    np.testing.assert_allclose(states[-1].specific_force, [0, 0, -G], atol=1e-12)
    # linear prediction of the descent: h(t) = 1 + g H(s)/s thr (default heave damping)
    num, den = RMAX_TRANSFER_FUNCTIONS["heave"]
    h = 1.0 + lsim_step(G * num[:-1], np.polymul(den, [1.0, 0.0]), -200.0, 600)
    k = int(np.argmax(h <= 0.0))
    sink = (h[k - 1] - h[k]) / DT
    assert model.touchdown_speed == pytest.approx(sink, rel=3e-2)
    assert states[k - 2].on_ground is False and states[k].on_ground is True
    states, _ = run(model, YacsCommand(0.0, thr=300.0), 3.0)
    assert not states[-1].on_ground and states[-1].height_agl > 0.1


def test_starts_on_the_ground_and_stays_without_climb_command():
    model = RmaxModel()
    states, _ = run(model, YacsCommand(0.0), 2.0)
    assert all(s.on_ground for s in states) and states[-1].position[2] == 0.0


def test_initial_state_and_bad_input():
    init = VehicleState(t=5.0, position=np.array([1.0, 2.0, -10.0]), velocity=np.array([0.0, 2.0, 0.0]),
                        euler=np.array([0.0, 0.0, math.pi / 2]), body_rates=np.zeros(3),
                        specific_force=np.zeros(3))
    model = RmaxModel(initial=init)
    np.testing.assert_allclose(model.state.velocity, [0.0, 2.0, 0.0], atol=1e-12)
    assert model.state.t == 5.0 and model.state.euler[2] == pytest.approx(math.pi / 2)
    with pytest.raises(ValueError, match="roll"):
        RmaxModel(initial=VehicleState(0.0, np.zeros(3), np.zeros(3), np.array([0.1, 0, 0]),
                                       np.zeros(3), np.zeros(3)))
    with pytest.raises(ValueError, match="dt"):
        model.step(YacsCommand(0.0), 0.0)
    with pytest.raises(ValueError, match="wind_ned"):
        model.step(YacsCommand(0.0), DT, Environment((1.0, 2.0)))
    with pytest.raises(ValueError, match="command"):
        model.step(YacsCommand(0.0, ail=float("nan")), DT)
    with pytest.raises(ValueError, match="Yv"):
        RmaxParams(Yv=0.1)
    with pytest.raises(ValueError, match="dt"):
        rmax_state_space(-1.0)
    with pytest.raises(ValueError, match="position"):
        RmaxModel(position=(0.0, 0.0, 0.5))  # below the ground


def test_other_step_sizes_are_rediscretised():
    a, b = RmaxModel(position=(0, 0, -50)), RmaxModel(position=(0, 0, -50))
    for _ in range(100):
        a.step(YacsCommand(0.0, ail=80.0), 0.01)
    for _ in range(40):
        b.step(YacsCommand(0.0, ail=80.0), 0.025)
    assert a.yacs_outputs["roll_deg"] == pytest.approx(b.yacs_outputs["roll_deg"], abs=1e-10)
    np.testing.assert_allclose(a.state.position, b.state.position, atol=1e-6)


def test_translational_derivative_is_eq_3_9_component_by_component():
    """``_deriv`` (eq. 3.9 in matrix form) against the thesis' component form, written out here, at random
    states, attitudes and winds: u' = X_u u_a - q w + r v - g sin(theta), v' = Y_v v_a - r u + p w
    + g cos(theta) sin(phi), w' = Z_w (w_a - w_yacs) - g (1 + dAz) - p v + q u + g cos(theta) cos(phi), with
    (u_a, v_a, w_a) the air-relative body velocity; position rate C_bn v; psi' of eq. 3.7."""
    model = RmaxModel(position=(0, 0, -30), yaw=2.0)
    P = model.params
    rng = np.random.default_rng(7)
    for _ in range(200):
        y = rng.normal(0.0, 3.0, 8)
        phi, theta, p, q, r, az = *rng.normal(0, 0.3, 2), *rng.normal(0, 0.5, 3), rng.normal(0, 0.1)
        wind = rng.normal(0.0, 3.0, 3)
        d, f = model._deriv(y, (phi, theta, p, q, r, az), wind)
        cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(y[6]), np.sin(y[6])
        Rx = np.array([[1, 0, 0], [0, cf, -sf], [0, sf, cf]])
        Ry = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
        Rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1]])
        C = Rz @ Ry @ Rx  # body -> NED, yaw-pitch-roll
        ua, va, wa = y[0:3] - C.T @ wind
        u, v, w = y[0:3]
        want = [P.Xu * ua - q * w + r * v - P.g * st,
                P.Yv * va - r * u + p * w + P.g * ct * sf,
                P.Zw * (wa - y[7]) - P.g * (1 + az) - p * v + q * u + P.g * ct * cf,
                *(C @ y[0:3]), (q * sf + r * cf) / ct, -P.g * az]
        np.testing.assert_allclose(d, want, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(f, [P.Xu * ua, P.Yv * va, P.Zw * (wa - y[7]) - P.g * (1 + az)], rtol=1e-12,
                                   atol=1e-12)


def test_the_discretisation_is_computed_once_per_step_size_and_shared_read_only():
    """A campaign worker builds a model per run: the matrix exponentials are taken once per dt in the process,
    equal to a fresh ``_block_diag_model`` (dt and dt / 2), and no model can change them."""
    from visnav.vehicles.rmax import _block_diag_model

    a, b = RmaxModel(dt=0.01), RmaxModel(dt=0.01)
    ma, mb = a._matrices(0.01), b._matrices(0.01)
    assert all(x is y for x, y in zip(ma, mb))
    fresh = _block_diag_model(0.01) + _block_diag_model(0.005)[:2]
    for x, y in zip(ma, fresh):
        assert np.array_equal(x, y) and not x.flags.writeable
    assert not np.array_equal(RmaxModel(dt=0.02)._matrices(0.02)[0], ma[0])
