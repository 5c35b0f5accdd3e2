"""The general UKF against filterpy (same model, same data) and against a linear Kalman filter."""

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints
from filterpy.kalman import UnscentedKalmanFilter as FilterpyUKF

from visnav.estimation import deck as dm
from visnav.estimation.ukf import SigmaWeights, UnscentedKalmanFilter

LIGHTS = np.array([[-0.128, 0, 0], [0, -0.102, 0], [0, 0.102, 0], [0.058, 0, 0]])
CAM = dm.CameraGeometry(rho=np.array([0.101, 0.008, 0.11]),
                        T_cam=np.array([[0, 1, 0], [-np.sin(0.76), 0, np.cos(0.76)], [np.cos(0.76), 0, np.sin(0.76)]]))


def _imu(rng):
    return dm.ImuInput(accel=np.array([0.0, 0.0, -9.81]) + rng.normal(0, 0.3, 3), gyro=rng.normal(0, 0.2, 3),
                       gyro_dot=rng.normal(0, 0.5, 3), gravity_body=np.array([0.0, 0.0, 9.81]))


def test_weights_sum_and_points_reproduce_mean_and_covariance():
    w = SigmaWeights(5, alpha=0.3, beta=2.0, kappa=1.0)
    assert w.wm.sum() == pytest.approx(1.0, abs=1e-12)
    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 5))
    P = A @ A.T + np.eye(5)
    x = rng.normal(size=5)
    s = w.points(x, P)
    m = w.wm @ s
    d = s - m
    np.testing.assert_allclose(m, x, atol=1e-12)
    np.testing.assert_allclose((d * w.wc[:, None]).T @ d - (w.wc[0] - w.wm[0]) * np.outer(d[0], d[0]), P, atol=1e-10)


def test_deck_model_matches_filterpy_to_1e8():
    rng = np.random.default_rng(3)
    x0, P0 = dm.initial_state_static()
    x0 = x0 + np.r_[0.1, -0.05, 0.1, 0.05, -0.03, 0.2, 0.02, 0.0, -0.01, 0.01, 0.0, 0.02]
    dt = 0.01
    imu_cov = np.diag([0.05**2] * 3 + [0.005**2] * 3)
    ship_cov = np.diag([0.1**2] * 3 + [0.05**2] * 3)
    idx, ridx = np.arange(4), np.array([0, 2, 3])
    R = np.diag([np.radians(2) ** 2] * 8 + [np.radians(2) ** 2] * 6)

    ours = UnscentedKalmanFilter(x0, P0, dm.process_model, alpha=0.1, beta=2.0, kappa=0.0)
    pts = MerweScaledSigmaPoints(12, alpha=0.1, beta=2.0, kappa=0.0)
    holder = {}

    def fx(x, dt):
        return dm.process_model(x[None, :], dt, holder["u"])[0]

    def hx(x):
        return dm.measurement_model(x[None, :], LIGHTS, CAM, holder["u"].gyro, idx, ridx)[0]

    ref = FilterpyUKF(dim_x=12, dim_z=14, dt=dt, hx=hx, fx=fx, points=pts)
    ref.x, ref.P = x0.copy(), P0.copy()
    truth = x0.copy()
    for k in range(60):
        u = _imu(rng)
        holder["u"] = u
        Q = dm.process_noise(ours.x, dt, u, imu_cov, ship_cov)
        ours.predict(dt, Q, u=u)
        ref.Q = Q
        ref.predict()
        truth = dm.process_model(truth[None, :], dt, u)[0]
        if k % 3 == 2:
            z = dm.measurement_model(truth[None, :], LIGHTS, CAM, u.gyro, idx, ridx)[0] + rng.normal(0, 0.01, 14)
            ours.update(z, R, hx=dm.measurement_model, lights=LIGHTS, cam=CAM, gyro=u.gyro, idx=idx, rate_idx=ridx)
            ref.update(z, R=R)
        np.testing.assert_allclose(ours.x, ref.x, atol=1e-8, rtol=0)
        np.testing.assert_allclose(ours.P, ref.P, atol=1e-8, rtol=0)


def test_linear_model_equals_kalman_filter():
    rng = np.random.default_rng(1)
    dt = 0.1
    F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]])
    H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    Q = np.diag([1e-4, 1e-2, 1e-4, 1e-2])
    R = np.diag([0.25, 0.25])
    x, P = np.zeros(4), np.eye(4) * 4.0
    ukf = UnscentedKalmanFilter(x, P, lambda s, dt: s @ F.T, lambda s: s @ H.T, alpha=0.5)
    for _ in range(40):
        x, P = F @ x, F @ P @ F.T + Q
        ukf.predict(dt, Q)
        z = rng.normal(0, 1, 2)
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        x, P = x + K @ (z - H @ x), (np.eye(4) - K @ H) @ P
        ukf.update(z, R)
        np.testing.assert_allclose(ukf.x, x, atol=1e-10)
        np.testing.assert_allclose(ukf.P, P, atol=1e-10)


def test_not_positive_definite_is_a_clear_error():
    ukf = UnscentedKalmanFilter(np.zeros(2), -np.eye(2), lambda s, dt: s)
    with pytest.raises(np.linalg.LinAlgError, match="positive definite"):
        ukf.predict(0.1, np.eye(2))


def test_an_update_beyond_max_nis_is_not_applied():
    """The whole-update gate: NIS = y^T S^-1 y of a linear model (closed form) decides; beyond it x, P stay."""
    H = np.array([[1.0, 0.0]])
    ukf = UnscentedKalmanFilter(np.zeros(2), np.diag([4.0, 1.0]), lambda s, dt: s, lambda s: s @ H.T, alpha=0.5)
    R = np.array([[1.0]])
    nis = 3.0**2 / (4.0 + 1.0)  # y = 3, S = 4 + 1
    assert not ukf.update([3.0], R, max_nis=nis - 1e-6)
    np.testing.assert_array_equal(ukf.x, [0.0, 0.0])
    np.testing.assert_array_equal(ukf.P, np.diag([4.0, 1.0]))
    assert ukf.nis == pytest.approx(nis)
    assert ukf.update([3.0], R, max_nis=nis + 1e-6)
    np.testing.assert_allclose(ukf.x, [3.0 * 4.0 / 5.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(ukf.P, np.diag([4.0 - 16.0 / 5.0, 1.0]), atol=1e-12)


def test_sigma_points_are_the_stacked_reference_bits_and_layout():
    """SigmaWeights.points fills [0; U; -U] in place: the same values and the same column-major layout as
    the ``np.vstack`` of U = L^T it replaced (the layout decides the rounding of the products downstream:
    a row-major copy changed the deck runs in the last bits)."""
    w = SigmaWeights(12, alpha=0.1, beta=2.0)
    rng = np.random.default_rng(4)
    for k in range(200):
        A = rng.normal(size=(12, 12))
        P = np.diag(rng.uniform(1e-6, 1.0, 12)) if k % 2 else A @ A.T + 1e-3 * np.eye(12)
        x = rng.normal(size=12) * 3
        U = np.linalg.cholesky((w.lam + 12) * P).T
        d = np.vstack([np.zeros((1, 12)), U, -U])
        for add in (dm.state_add, lambda a, b: a + b):
            ref = add(np.broadcast_to(x, d.shape), d)
            got = w.points(x, P, add)
            assert got.strides == ref.strides
            assert np.array_equal(got.view(np.int64), ref.view(np.int64))


def test_consider_update_equals_the_schmidt_kalman_filter():
    """Two states and one consider parameter c (a constant sensor bias) seen through z = x0 + c: the UKF's update
    with ``consider`` equals the Schmidt-Kalman filter's closed form in the Joseph form with the gain's consider row
    zero, (I - K H) P (I - K H)^T + K R K^T; c and its variance never change, and the Schmidt filter's state
    variance stays above the optimal (augmented) filter's, which estimates c."""
    rng = np.random.default_rng(2)
    dt = 0.1
    F = np.array([[1, dt, 0], [0, 1, 0], [0, 0, 1.0]])
    H = np.array([[1.0, 0, 1.0]])
    Q = np.diag([1e-4, 1e-2, 0.0])
    R = np.array([[0.04]])
    x, P = np.zeros(3), np.diag([1.0, 1.0, 0.09])
    ukf = UnscentedKalmanFilter(x, P, lambda s, dt: s @ F.T, lambda s: s @ H.T, alpha=0.5)
    opt = UnscentedKalmanFilter(x, P, lambda s, dt: s @ F.T, lambda s: s @ H.T, alpha=0.5)
    for _ in range(30):
        x, P = F @ x, F @ P @ F.T + Q
        ukf.predict(dt, Q)
        opt.predict(dt, Q)
        z = rng.normal(0, 0.3, 1)
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        K[2] = 0.0
        IKH = np.eye(3) - K @ H
        x, P = x + K @ (z - H @ x), IKH @ P @ IKH.T + K @ R @ K.T
        ukf.update(z, R, consider=slice(2, 3))
        opt.update(z, R)
        np.testing.assert_allclose(ukf.x, x, atol=1e-10)
        np.testing.assert_allclose(ukf.P, P, atol=1e-10)
    assert ukf.x[2] == pytest.approx(0.0, abs=1e-12) and ukf.P[2, 2] == pytest.approx(0.09, abs=1e-12)
    assert ukf.P[0, 0] > opt.P[0, 0]


@pytest.mark.parametrize("consider", [None, slice(5, 6)])
def test_a_direct_measurement_of_states_equals_the_unscented_update_of_the_linear_h(consider):
    """``update_states``: z = (x1, x3) + noise through the closed form equals ``update`` with h(x) = (x1, x3) (the
    unscented transform of a linear h is exact) at 1e-10, with and without a consider state (its gain row zero,
    its variance kept), and leaves the last update's S, y, NIS as they were."""
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 6))
    x, P = rng.normal(size=6), A @ A.T + np.eye(6)
    z, R = rng.normal(size=2), np.diag([0.3, 0.5])
    ref = UnscentedKalmanFilter(x, P, lambda s, dt: s, lambda s: s[:, [1, 3]], alpha=0.5)
    lin = UnscentedKalmanFilter(x, P, lambda s, dt: s, lambda s: s[:, [1, 3]], alpha=0.5)
    ref.update(z, R, consider=consider)
    lin.S, lin.y, lin.nis = np.eye(3), np.ones(3), 5.0
    lin.update_states(z, R, np.array([1, 3]), consider=consider)
    np.testing.assert_allclose(lin.x, ref.x, atol=1e-10)
    np.testing.assert_allclose(lin.P, ref.P, atol=1e-10)
    assert lin.nis == 5.0 and (lin.y == 1.0).all()
    if consider is not None:
        assert lin.x[5] == x[5] and lin.P[5, 5] == pytest.approx(P[5, 5], rel=1e-12)
