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


def test_free_fall_and_full_throttle_climb_are_the_closed_forms():
    """No drag, level attitude, a thrust lag shorter than the step: with zero throttle the vehicle falls as
    z = z0 + g t^2 / 2 and with full throttle it climbs at (T_max / m - g); the trapezoidal position update is
    exact for a constant acceleration. The IMU's specific force is the thrust alone."""
    p = MultirotorParams(drag=0.0, thrust_tau=1e-3)
    dt = 0.01
    for throttle, acc in ((0.0, G), (1.0, G - p.max_thrust * p.ground_effect(50.0) / p.mass)):
        v = Multirotor(p, [1.0, 2.0, -50.0], yaw=0.4)
        for _ in range(200):
            s = v.step(AttitudeThrustCommand(0.0, 0.0, 0.0, 0.0, throttle), dt, Environment(rotor_height_m=50.0))
        t = 200 * dt
        np.testing.assert_allclose(s.position, [1.0, 2.0, -50.0 + 0.5 * acc * t * t], atol=1e-9)
        np.testing.assert_allclose(s.velocity, [0.0, 0.0, acc * t], atol=1e-9)
        np.testing.assert_allclose(s.specific_force, [0.0, 0.0, acc - G], atol=1e-9)
