"""Trajectory follower, attitude commander and throttle law (seed 003 eq. 4.25-4.33)."""

import numpy as np
import pytest

from visnav.control.multirotor import ThrottleController, attitude_command, follow
from visnav.geometry.rotations import euler_to_dcm

G = 9.81


@pytest.mark.parametrize("a", [[0.5, -0.3, -0.4], [-1.0, 1.2, 0.8], [0.0, 0.0, 0.0]])
def test_attitude_command_inverts_eq_4_28(a):
    T, phi, theta = attitude_command(np.array(a), np.radians(30))
    # forward model: a = g e3 + C_b^n [0, 0, -T]  (yaw 0)
    got = np.array([0, 0, G]) + euler_to_dcm([phi, theta, 0.0]) @ np.array([0, 0, -T])
    np.testing.assert_allclose(got, a, atol=1e-12)
    # small-angle form, eq. 4.29-4.31
    assert phi == pytest.approx(a[1] / (G - a[2]), abs=0.01)
    assert theta == pytest.approx(-a[0] / (G - a[2]), abs=0.01)


def test_tilt_limit():
    T, phi, theta = attitude_command(np.array([20.0, 0.0, 0.0]), np.radians(15))
    assert abs(theta) == pytest.approx(np.radians(15))


def test_spring_damper_with_feed_forward():
    a = follow([1, 0, 0], [0, 1, 0], [0, 0, 2], np.zeros(3), np.zeros(3), K=4.0, B=3.0)
    np.testing.assert_allclose(a, [4.0, 3.0, 2.0])


def test_throttle_hover_interpolation_and_pi():
    c = ThrottleController(hover_throttle_1m=0.5, hover_throttle_ground=0.45, kp=0.02, ki=0.05)
    assert c.hover_throttle(2.0) == 0.5 and c.hover_throttle(0.0) == 0.45
    assert c.hover_throttle(0.5) == pytest.approx(0.475)
    assert c.command(0.0, 0.0, 2.0, 1.0, 0.01) == pytest.approx(0.5)
    # eq. 4.32 inverse: a_up = A (T - T0) with A = g / T0
    assert c.command(G * 0.2, G * 0.2, 2.0, 1.0, 0.01) == pytest.approx(0.6)
    for _ in range(100):
        thr = c.command(1.0, 0.0, 2.0, 1.0, 0.01)  # persistent shortfall: the integral grows
    assert thr > 0.5 * (1 + 1 / G) + 0.02
