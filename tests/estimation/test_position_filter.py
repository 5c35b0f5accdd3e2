"""The per-axis position filter equals a textbook 6-state Kalman filter (filterpy) on the same data."""

import numpy as np
from filterpy.kalman import KalmanFilter

from visnav.estimation.position_filter import PositionFilter, accel_ned


def _filterpy_reference(q, p0, v0, sp, sv):
    kf = KalmanFilter(dim_x=6, dim_z=3)
    kf.x = np.r_[p0, v0].astype(float)
    kf.P = np.diag([sp**2] * 3 + [sv**2] * 3)
    return kf


def test_matches_filterpy_kalman_filter():
    rng = np.random.default_rng(3)
    q = 0.4
    pf = PositionFilter(accel_noise=q)
    pf.reset(0.0, [1.0, 2.0, -10.0], [0.1, 0.0, 0.0], sigma_p=0.5, sigma_v=0.2)
    kf = _filterpy_reference(q, [1.0, 2.0, -10.0], [0.1, 0.0, 0.0], 0.5, 0.2)
    dt = 0.01
    t = 0.0
    for k in range(1, 501):
        t = k * dt
        a = rng.normal(0, 0.5, 3)
        pf.predict(t, a)
        F = np.eye(6)
        F[:3, 3:] = np.eye(3) * dt
        B = np.vstack([np.eye(3) * 0.5 * dt * dt, np.eye(3) * dt])
        Q1 = q * q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        Q = np.kron(Q1, np.eye(3))
        kf.predict(u=a, B=B, F=F, Q=Q)
        if k % 10 == 0:
            z = rng.normal(0, 0.1, 3) + kf.x[:3]
            pf.update_position(z, 0.1)
            kf.update(z, R=np.eye(3) * 0.01, H=np.hstack([np.eye(3), np.zeros((3, 3))]))
        if k % 50 == 0:
            zv = rng.normal(0, 0.05, 3)
            pf.update_velocity(zv, 0.05)
            kf.update(zv, R=np.eye(3) * 0.0025, H=np.hstack([np.zeros((3, 3)), np.eye(3)]))
    np.testing.assert_allclose(np.r_[pf.p, pf.v], kf.x, atol=1e-9)
    np.testing.assert_allclose(pf.covariance(), kf.P, atol=1e-12)


def test_single_axis_update_and_gate():
    pf = PositionFilter(accel_noise=0.1)
    pf.reset(0.0, [0.0, 0.0, -5.0], [0.0, 0.0, 0.0], sigma_p=1.0, sigma_v=0.1)
    assert pf.update_position(np.array([0.0, 0.0, -4.0]), 1.0, axes=(2,))
    assert abs(pf.p[2] - (-4.5)) < 1e-12 and pf.p[0] == 0.0  # equal weights: half way
    assert not pf.update_position(np.array([100.0, 0.0, -4.5]), 0.1, gate=5.0)
    assert pf.p[0] == 0.0


def test_accel_ned_hover_is_zero():
    np.testing.assert_allclose(accel_ned(np.eye(3), np.array([0.0, 0.0, -9.81])), 0.0, atol=1e-12)


def test_predictions_compose_to_the_one_over_their_sum():
    """The white-acceleration model is discretised exactly: predicting over 200 random steps gives the state and
    covariance of one step over their sum, x(T) = (p0 + v0 T + a T^2 / 2, v0 + a T) and
    P(T) = F(T) P0 F(T)^T + q [[T^3/3, T^2/2], [T^2/2, T]] (closed form, constant acceleration a)."""
    rng = np.random.default_rng(4)
    p0, v0, a, q = rng.normal(size=3), rng.normal(size=3), rng.normal(0.0, 2.0, 3), 0.3**2
    f = PositionFilter(accel_noise=0.3, position=p0, velocity=v0, sigma_p=0.7, sigma_v=0.2)
    f.predict(0.0, a)
    T = 0.0
    for _ in range(200):
        T += float(rng.uniform(0.005, 0.02))
        f.predict(T, a)
    np.testing.assert_allclose(f.p, p0 + v0 * T + 0.5 * a * T * T, rtol=1e-12)
    np.testing.assert_allclose(f.v, v0 + a * T, rtol=1e-12)
    F = np.array([[1.0, T], [0.0, 1.0]])
    P = F @ np.diag([0.49, 0.04]) @ F.T + q * np.array([[T**3 / 3, T**2 / 2], [T**2 / 2, T]])
    for i in range(3):
        np.testing.assert_allclose(f.axis_covariance(i), P, rtol=1e-12)
    np.testing.assert_allclose(f.covariance()[np.ix_([i, i + 3], [i, i + 3])], P, rtol=1e-12)


def test_steady_state_gain_is_the_riccati_solution():
    """10 Hz position fixes, 100 Hz predictions: the filter's gain converges to the one of the discrete
    algebraic Riccati equation of the 0.1 s model (scipy.linalg.solve_discrete_are)."""
    from scipy.linalg import solve_discrete_are

    from visnav.analysis.loop_model import _filter_gains

    q, s, T = 0.3**2, 0.02, 0.1
    F = np.array([[1.0, T], [0.0, 1.0]])
    Q = q * np.array([[T**3 / 3, T**2 / 2], [T**2 / 2, T]])  # 10 steps of 0.01 s compose to one of 0.1 s
    H = np.array([[1.0, 0.0]])
    P = solve_discrete_are(F.T, H.T, Q, np.array([[s * s]]))  # the predicted covariance in steady state
    K = P @ H.T / (H @ P @ H.T + s * s)
    np.testing.assert_allclose(_filter_gains(0.3, s, 100.0, 10.0), K.ravel(), rtol=1e-9)


def test_last_nis_is_the_normalised_innovation_of_the_update():
    from visnav.estimation.position_filter import PositionFilter

    f = PositionFilter()
    f.reset(0.0, [1.0, 2.0, -3.0], [0.0, 0.0, 0.0], sigma_p=0.5)
    ok = f.update_position([1.3, 1.6, -3.0], 0.4, axes=(0, 1))
    assert ok and f.last_accepted
    S = 0.5**2 + 0.4**2
    np.testing.assert_allclose(f.last_nis, [0.3**2 / S, 0.4**2 / S], rtol=1e-12)
    rejected = f.update_position([9.0, 2.0, -3.0], 0.01, axes=(0,), gate=3.0)
    assert not rejected and not f.last_accepted and f.last_nis[0] > 9.0
