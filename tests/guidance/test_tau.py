"""Tau laws (seed 003 eq. 2.34-2.46) against scipy's ODE solver and their touchdown properties."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from visnav.guidance import tau


def _fd(f, t, h=1e-6):
    return (f(t + h) - f(t - h)) / (2 * h)


@pytest.mark.parametrize("k", [-0.5, 0.2, 0.4, 0.5, 0.8])
def test_tau_dot_against_ode(k):
    x0, v0 = 1.0, -1.0  # 1 m from the goal, 1 m/s towards it (Fig. 2.3)
    tf = min(tau.tau_dot_contact_time(x0, v0, k), 4.0) * 0.95
    # tau_dot = k  <=>  x_ddot = (1 - k) x_dot^2 / x
    sol = solve_ivp(lambda t, y: [y[1], (1 - k) * y[1] ** 2 / y[0]], (0, tf), [x0, v0], rtol=1e-12, atol=1e-13,
                    dense_output=True)
    ts = np.linspace(0, tf, 200)
    x, xd, xdd = tau.tau_dot(ts, x0, v0, k)
    ys = sol.sol(ts)
    assert np.max(np.abs(x - ys[0])) <= 1e-6 and np.max(np.abs(xd - ys[1])) <= 1e-6
    np.testing.assert_allclose(xdd, _fd(lambda t: tau.tau_dot(t, x0, v0, k)[1], ts), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(x / xd, x0 / v0 + k * ts, atol=1e-9)  # tau grows at rate k


@pytest.mark.parametrize("law,order", [(tau.tau_guidance, 2), (tau.higher_order_tau, 3)])
@pytest.mark.parametrize("k", [0.2, 0.3, 0.45, 0.5, 0.7])
def test_guidance_laws_against_ode(law, order, k):
    x0, T = 1.0, 5.0
    # eq. 2.38: x / x_dot = k/2 (t - T^2/t);  eq. 2.42: x / x_dot = k/3 (t - T^3/t^2)
    rhs = lambda t, y: [order * y[0] * t ** (order - 1) / (k * (t**order - T**order))]  # noqa: E731
    tf = 0.98 * T
    sol = solve_ivp(rhs, (0, tf), [x0], rtol=1e-12, atol=1e-14, dense_output=True)
    ts = np.linspace(0, tf, 300)
    x, xd, xdd = law(ts, x0, T, k)
    assert np.max(np.abs(x - sol.sol(ts)[0])) <= 1e-6
    assert np.max(np.abs(xd - np.array([rhs(t, [xi])[0] for t, xi in zip(ts, x)]))) <= 1e-6
    tin = ts[1:-1]
    np.testing.assert_allclose(xdd[1:-1], _fd(lambda t: law(t, x0, T, k)[1], tin), rtol=1e-5, atol=1e-5)
    assert xd[0] == 0.0
    if order == 3:
        assert xdd[0] == 0.0  # the higher-order law also starts with zero acceleration


@pytest.mark.parametrize("law", [tau.tau_guidance, tau.higher_order_tau])
def test_touchdown_properties_by_k(law):
    x0, T = 1.0, 5.0
    for k in (0.1, 0.3, 0.45):  # 0 < k < 1/2: zero velocity and acceleration at t = T
        x, xd, xdd = law(T, x0, T, k)
        assert x == 0 and xd == 0 and xdd == 0
        _, xd1, xdd1 = law(T * (1 - 1e-4), x0, T, k)
        _, xd2, xdd2 = law(T * (1 - 1e-8), x0, T, k)
        assert abs(xd2) < 1e-6 and abs(xdd2) < 0.2 * abs(xdd1)  # both tend to zero
    # k = 1/2: zero velocity, finite acceleration (eq. 2.46: 18 x0/T^2 = 0.72 m/s^2 for 1 m in 5 s)
    _, xd, xdd = law(T, x0, T, 0.5)
    assert xd == 0
    want = 0.72 if law is tau.higher_order_tau else 8 * x0 / T**2
    assert xdd == pytest.approx(want, rel=1e-12)
    # k > 1/2: velocity or acceleration grows without bound at touchdown
    _, xd1, xdd1 = law(T * (1 - 1e-3), x0, T, 0.7)
    _, xd2, xdd2 = law(T * (1 - 1e-5), x0, T, 0.7)
    assert abs(xdd2) > 10 * abs(xdd1)
    # k < 0: the gap opens instead of closing
    x, _, _ = law(T * 0.9, x0, T, -0.5)
    assert x > x0


def test_tau_dot_touchdown_by_k():
    x0, v0 = 1.0, -1.0
    for k in (0.2, 0.4):
        tf = tau.tau_dot_contact_time(x0, v0, k)
        assert tf == pytest.approx(1.0 / k)
        x, xd, xdd = tau.tau_dot(tf, x0, v0, k)
        assert x == 0 and xd == 0 and xdd == 0
    assert tau.tau_dot_contact_time(x0, v0, -0.3) == np.inf
    x, _, _ = tau.tau_dot(100.0, x0, v0, -0.3)
    assert 0 < x < 0.1  # approaches asymptotically
    _, xd, _ = tau.tau_dot(tau.tau_dot_contact_time(x0, v0, 1.0), x0, v0, 1.0)
    assert xd == pytest.approx(v0)  # k = 1: contact at constant speed (an impact)


def test_duration_for_touchdown_acceleration():
    T = tau.duration_for_touchdown_acceleration(1.41, 2.5)
    assert tau.higher_order_tau(T, 1.41, T, 0.5)[2] == pytest.approx(2.5)
    with pytest.raises(ValueError):
        tau.higher_order_tau(1.0, 1.0, 0.0, 0.5)


def test_higher_order_tau_of_one_float_equals_the_array_form_and_the_closed_form():
    """A float t (Python floats) and an array of t (numpy) give the same three numbers, of type float64, at and
    beyond both ends and at NaN; x equals eq. 2.43 written directly and x_dot its numerical derivative."""
    rng = np.random.default_rng(5)
    for _ in range(2000):
        T = float(rng.uniform(0.5, 20.0))
        k = float(rng.choice([0.5, 0.45, 0.3, 0.25, rng.uniform(0.1, 0.9)]))
        x0 = float(rng.normal(0, 5))
        t = float(rng.choice([rng.uniform(-1.0, T + 1.0), rng.uniform(0, T), T, 0.0, np.nan]))
        one = tau.higher_order_tau(t, x0, T, k)
        arr = tau.higher_order_tau(np.array([t]), x0, T, k)
        assert all(type(v) is np.float64 for v in one)
        np.testing.assert_allclose(one, [a[0] for a in arr], rtol=1e-12, atol=1e-12)
        tc = min(max(t, 0.0), T)
        if np.isfinite(t):
            assert one[0] == pytest.approx(x0 * (1.0 - (tc / T) ** 3) ** (1.0 / k), rel=1e-9, abs=1e-12)  # eq. 2.43
        if 0.05 * T < t < 0.95 * T:
            assert one[1] == pytest.approx(_fd(lambda s: tau.higher_order_tau(s, x0, T, k)[0], t), rel=1e-5, abs=1e-8)


@pytest.mark.parametrize("t, k", [(0.9999, -0.01), (0.99999999, -0.005)])
def test_higher_order_tau_of_a_float_that_overflows_answers_as_the_array_form(t, k):
    """Python's ** raises OverflowError where numpy's gives inf: a float t then gives what a 0-d array gives
    (here inf for an unbounded k < 0 approach)."""
    with pytest.raises(OverflowError):
        (1.0 - t**3) ** ((1.0 - 2.0 * k) / k)
    with np.errstate(all="ignore"):
        one = tau.higher_order_tau(t, 1.0, 1.0, k)
        arr = tau.higher_order_tau(np.array(t), 1.0, 1.0, k)
    assert all(np.array_equal(a, b) for a, b in zip(one, arr)) and np.isinf(one[0])
