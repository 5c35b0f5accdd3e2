"""The Y6 multirotor model: hover equilibrium, autopilot step response, ground effect."""

import numpy as np
import pytest

from visnav.vehicles.base import Environment
from visnav.vehicles.multirotor import G, AttitudeThrustCommand, Multirotor, MultirotorParams


def test_hover_is_an_equilibrium():
    p = MultirotorParams()
    v = Multirotor(p, [0, 0, -2.0])
    for k in range(300):
        s = v.step(AttitudeThrustCommand(k * 0.01, 0, 0, 0, p.hover_throttle), 0.01)
    np.testing.assert_allclose(s.position, [0, 0, -2.0], atol=1e-9)
    np.testing.assert_allclose(s.specific_force, [0, 0, -G], atol=1e-9)


def test_roll_step_follows_second_order_response():
    p = MultirotorParams(attitude_omega=10.0, attitude_zeta=0.7)
    v = Multirotor(p, [0, 0, -5.0])
    dt, step = 0.001, np.radians(5)
    ts, phis = [], []
    for k in range(1000):
        s = v.step(AttitudeThrustCommand(k * dt, step, 0, 0, p.hover_throttle), dt)
        ts.append((k + 1) * dt)
        phis.append(s.euler[0])
    wn, z = 10.0, 0.7
    wd = wn * np.sqrt(1 - z * z)
    t = np.array(ts)
    want = step * (1 - np.exp(-z * wn * t) * (np.cos(wd * t) + z / np.sqrt(1 - z * z) * np.sin(wd * t)))
    np.testing.assert_allclose(phis, want, atol=5e-3 * step)  # semi-implicit Euler at 1 ms
    # a rolled vehicle accelerates sideways: a_y = g tan(phi) at constant height needs more thrust
    assert s.velocity[1] > 0


def test_ground_effect_cheeseman_bennett():
    p = MultirotorParams(rotor_radius=0.127)
    assert p.ground_effect(1.0) == pytest.approx(1 / (1 - (0.127 / 4) ** 2))
    assert p.ground_effect(10.0) == pytest.approx(1.0, abs=1e-4)
    assert p.ground_effect(0.001) == 1.3
    v = Multirotor(p, [0, 0, -0.2])
    s = v.step(AttitudeThrustCommand(0, 0, 0, 0, p.hover_throttle), 0.01, Environment(rotor_height_m=0.1))
    assert s.velocity[2] < 0  # more thrust near the ground: climbs


def test_gear_point_is_below_body():
    v = Multirotor(MultirotorParams(gear_offset=0.17), [1, 2, -3.0])
    np.testing.assert_allclose(v.gear_point(), [1, 2, -2.83])


def test_drag_acts_on_the_airspeed():
    """Level hover in a steady wind: the linear drag accelerates the vehicle at c_d * wind (eq. of the docstring)."""
    p = MultirotorParams()
    v = Multirotor(p, [0.0, 0.0, -5.0])
    s = v.step(AttitudeThrustCommand(0, 0, 0, 0, p.hover_throttle), 0.01, Environment(wind_ned=np.array([2.0, 0.0, 0.0])))
    assert s.velocity[0] == pytest.approx(p.drag * 2.0 * 0.01, rel=1e-9)


def test_gear_point_follows_each_step_and_returns_a_copy():
    p = MultirotorParams()
    m = Multirotor(p, [0.0, 0.0, -2.0])
    g0 = m.gear_point()
    g0[:] = 99.0  # the caller's copy
    np.testing.assert_allclose(m.gear_point(), [0.0, 0.0, -2.0 + p.gear_offset])
    m.step(AttitudeThrustCommand(0.0, 0.3, 0.0, 0.0, 0.6), 0.01)
    m.step(AttitudeThrustCommand(0.0, 0.3, 0.0, 0.0, 0.6), 0.01)
    from visnav.geometry.rotations import euler_to_dcm

    want = m.state.position + euler_to_dcm(m.state.euler) @ np.array([0.0, 0.0, p.gear_offset])
    np.testing.assert_array_equal(m.gear_point(), want)


def _step_reference(v: Multirotor, cmd, dt: float, environment=None):
    """``Multirotor.step`` in its array form (before speed round 5): the new state it made."""
    from visnav.geometry.rotations import euler_rates_to_body_rates, euler_to_dcm
    from visnav.vehicles.multirotor import MultirotorState

    env = environment or Environment()
    rotor_height_m, wind = env.rotor_height_m, np.asarray(env.wind_ned, float)
    p, s = v.p, v.state
    wn, z = p.attitude_omega, p.attitude_zeta
    e, ed = s.euler.copy(), s.euler_rate.copy()
    target = np.array([cmd.roll, cmd.pitch])
    edd = wn * wn * (target - e[:2]) - 2.0 * z * wn * ed[:2]
    ed[:2] += edd * dt  # semi-implicit Euler
    ed[2] += (cmd.yaw_rate - ed[2]) * min(dt / p.yaw_rate_tau, 1.0)
    e += ed * dt
    ge = p.ground_effect(rotor_height_m)
    T_cmd = min(max(float(cmd.throttle), 0.0), 1.0) * p.max_thrust * ge
    thrust = s.thrust + (T_cmd - s.thrust) * min(dt / p.thrust_tau, 1.0)
    C = euler_to_dcm(e)
    f_n = C @ np.array([0.0, 0.0, -thrust / p.mass]) - p.drag * (s.velocity - wind)  # specific force, NED
    acc = f_n + np.array([0.0, 0.0, G])
    vel = s.velocity + acc * dt
    pos = s.position + (s.velocity + vel) * 0.5 * dt
    return MultirotorState(position=pos, velocity=vel, euler=e, euler_rate=ed, thrust=thrust,
                           specific_force=C.T @ f_n, body_rates=np.asarray(euler_rates_to_body_rates(e, ed)))


def test_step_in_floats_equals_the_array_form_bit_for_bit():
    """The step's attitude and translation in Python floats: the same state, to the bit (signs of zero included),
    over random commands, winds, ground effect, step sizes, integer parameters and states with exact zeros."""
    rng = np.random.default_rng(11)
    bits = lambda a: np.asarray(a, float).view(np.int64)  # noqa: E731
    for params in (MultirotorParams(), MultirotorParams(attitude_omega=10, attitude_zeta=0.7, drag=0.0, mass=3)):
        v = Multirotor(params, [0.0, -0.0, -1.0], yaw=0.3)
        for k in range(1500):
            if k % 300 == 0:  # restart at rest (exact zeros in the state)
                v = Multirotor(params, [0.0, -0.0, -1.0], yaw=float(rng.uniform(-3, 3)))
            cmd = AttitudeThrustCommand(k * 0.01, float(rng.normal(0, 0.3)), float(rng.normal(0, 0.3)),
                                        float(rng.normal(0, 0.5)), float(rng.uniform(-0.2, 1.2)))
            if k % 7 == 0:
                cmd = AttitudeThrustCommand(k * 0.01, 0.0, -0.0, 0.0, params.hover_throttle)
            wind = rng.normal(0, 2, 3) if k % 3 else np.zeros(3)
            env = Environment(wind_ned=wind, rotor_height_m=float(rng.uniform(0.0, 3.0))) if k % 5 else None
            dt = float(rng.choice([0.01, 0.005, rng.uniform(1e-4, 0.05)]))
            want = _step_reference(v, cmd, dt, env)
            got = v.step(cmd, dt, env)
            for f in ("position", "velocity", "euler", "euler_rate", "specific_force", "body_rates"):
                assert np.array_equal(bits(getattr(got, f)), bits(getattr(want, f))), f
            assert got.thrust == want.thrust
