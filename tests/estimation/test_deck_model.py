"""The relative deck model (seed 003 eq. 2.25-2.29, 3.1-3.8, 5.12-5.17) against world-frame kinematics."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.estimation import deck as dm
from visnav.geometry.rotations import dcm_to_euler, euler_to_dcm

LIGHTS = np.array([[-0.128, 0, 0], [0, -0.102, 0], [0, 0.102, 0], [0.058, 0, 0]])
CAM = dm.CameraGeometry(rho=np.array([0.101, 0.008, 0.11]),
                        T_cam=np.array([[0, 1, 0], [-np.sin(0.76), 0, np.cos(0.76)], [np.cos(0.76), 0, np.sin(0.76)]]))
G = np.array([0.0, 0.0, 9.81])
W_H = np.array([0.3, -0.2, 0.4])  # vehicle body rates (constant)
W_D = np.array([0.1, 0.15, -0.05])  # deck body rates (constant)
A_H = np.array([0.5, -0.3, -0.8])  # vehicle acceleration (NED, constant)
V_D = np.array([0.2, 0.1, -0.05])  # deck velocity (constant: zero deck acceleration)


def world(t):
    Ch = euler_to_dcm([0.1, -0.05, 0.3]) @ Rotation.from_rotvec(W_H * t).as_matrix()  # C_h^n
    Cd = euler_to_dcm([0.05, 0.08, 0.9]) @ Rotation.from_rotvec(W_D * t).as_matrix()  # C_d^n
    ph = np.array([-1.0, 0.2, -1.2]) + np.array([0.3, 0.0, 0.1]) * t + 0.5 * A_H * t * t
    vh = np.array([0.3, 0.0, 0.1]) + A_H * t
    pd = np.array([0.1, 0.0, 0.0]) + V_D * t
    return Ch, Cd, ph, vh, pd


def truth_state(t):
    Ch, Cd, ph, vh, pd = world(t)
    r = Ch.T @ (pd - ph)
    e = dcm_to_euler(Cd.T @ Ch)  # C_h^d
    v = Ch.T @ (V_D - vh) - np.cross(W_H, r)
    return np.r_[r, e, v, W_D]


def measured_bearings(t):
    Ch, Cd, ph, _, pd = world(t)
    p_h = (pd[None, :] + LIGHTS @ Cd.T - ph) @ Ch - CAM.rho
    s = p_h @ CAM.T_cam.T
    return np.stack([np.arctan(s[:, 0] / s[:, 2]), np.arctan(s[:, 1] / s[:, 2])], axis=-1)


def test_bearings_and_rates_match_world_geometry():
    t, h = 0.7, 1e-5
    bear, rate = dm.bearings_and_rates(truth_state(t)[None, :], LIGHTS, CAM, W_H)
    np.testing.assert_allclose(bear[0], measured_bearings(t), atol=1e-12)
    fd = (measured_bearings(t + h) - measured_bearings(t - h)) / (2 * h)
    np.testing.assert_allclose(rate[0], fd, atol=1e-7)


def test_process_model_integrates_world_kinematics():
    dt, t = 1e-3, 0.0
    x = truth_state(0.0)
    for _ in range(500):
        Ch = world(t)[0]
        u = dm.ImuInput(accel=Ch.T @ (A_H - G), gyro=W_H, gyro_dot=np.zeros(3), gravity_body=Ch.T @ G)
        x = dm.process_model(x[None, :], dt, u)[0]
        t += dt
    err = dm.residual_x(x[None, :], truth_state(t)[None, :])[0]
    assert np.max(np.abs(err[:3])) < 2e-3 and np.max(np.abs(err[3:6])) < 2e-3 and np.max(np.abs(err[6:9])) < 5e-3
    # a wrong model (gravity with the wrong sign) is off by far more
    x2 = truth_state(0.0)
    t = 0.0
    for _ in range(500):
        Ch = world(t)[0]
        u = dm.ImuInput(accel=Ch.T @ (A_H - G), gyro=W_H, gyro_dot=np.zeros(3), gravity_body=-Ch.T @ G)
        x2 = dm.process_model(x2[None, :], dt, u)[0]
        t += dt
    assert np.max(np.abs(x2[:3] - truth_state(t)[:3])) > 0.1


def test_process_noise_from_eq_3_8_is_symmetric_and_grows_with_imu_noise():
    x, _ = dm.initial_state_static()
    u = dm.ImuInput(np.array([0, 0, -9.81]), np.array([0.1, 0, 0]), np.zeros(3), G)
    q1 = dm.process_noise(x, 0.01, u, np.diag([0.05**2] * 3 + [0.005**2] * 3), np.zeros((6, 6)))
    q2 = dm.process_noise(x, 0.01, u, np.diag([0.1**2] * 3 + [0.005**2] * 3), np.zeros((6, 6)))
    np.testing.assert_allclose(q1, q1.T)
    assert q2[6, 6] - q1[6, 6] == pytest.approx(0.01**2 * (0.1**2 - 0.05**2))
    assert np.all(np.linalg.eigvalsh(q1) >= -1e-18)


def test_ship_acceleration_bound_eq_3_7():
    assert dm.ship_acceleration_bound(0.1, 1.0, 0.01, 0.1) == pytest.approx(0.13 * 1.3**2)


def test_initialisation_eq_5_12_to_5_17():
    x0, P0 = dm.initial_state_static()
    np.testing.assert_array_equal(x0, [1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(np.sqrt(np.diag(P0)), np.repeat([0.5, np.radians(20), 0.05, np.radians(2)], 3))
    P = dm.initial_covariance_sea_state([0.1] * 3, [1.0] * 3, [0.2] * 3, [0.5] * 3)
    assert P[0, 0] == pytest.approx(0.005) and P[9, 9] == pytest.approx(0.04 * 0.25 / 2)


def test_batch_helpers_match_the_reference_forms():
    """The hand-vectorised DCM, cross product and angle wrap equal geometry.rotations / numpy."""
    from visnav.estimation.deck import _cross, euler_dcm_batch, wrap_state
    from visnav.geometry.rotations import euler_to_dcm

    rng = np.random.default_rng(3)
    e = rng.uniform(-3, 3, (25, 3)) * [1.0, 0.45, 1.0]
    np.testing.assert_allclose(euler_dcm_batch(e), np.stack([euler_to_dcm(a) for a in e]), atol=1e-14)
    a, b = rng.normal(size=(25, 4, 3)), rng.normal(size=(1, 4, 3))
    np.testing.assert_allclose(_cross(a, b), np.cross(a, b), atol=1e-14)
    np.testing.assert_allclose(_cross(b[0, 0], a), np.cross(b[0, 0], a), atol=1e-14)
    x = rng.uniform(-10, 10, (5, 12))
    w = wrap_state(x)
    np.testing.assert_array_equal(np.delete(w, [3, 5], axis=1), np.delete(x, [3, 5], axis=1))
    assert np.all(np.abs(w[:, [3, 5]]) <= np.pi)
    np.testing.assert_allclose(np.cos(w[:, [3, 5]]), np.cos(x[:, [3, 5]]), atol=1e-12)


def _process_noise_reference(x, dt, u, imu_cov, ship_cov):
    """process_noise as it was before speed round 4 (batches of one, np.outer, np.eye / np.zeros each call)."""
    from visnav.geometry.rotations import skew

    r, e, v = x[dm.POS], x[dm.ATT], x[dm.VEL]
    w = u.gyro
    C = dm.euler_dcm_batch(e[None, :])[0]
    E = dm.euler_rate_matrix(e[None, :])[0]
    I3 = np.eye(3)
    dt2 = 0.5 * dt * dt
    Fz = np.zeros((12, 6))
    Fz[dm.POS, 0:3] = -dt2 * I3
    Fz[dm.VEL, 0:3] = -dt * I3
    dvdw = 2.0 * skew(v) + 2.0 * np.outer(r, w) - np.dot(w, r) * I3 - np.outer(w, r)
    Fz[dm.VEL, 3:6] = dt * dvdw
    Fz[dm.POS, 3:6] = dt2 * dvdw
    Fz[dm.ATT, 3:6] = dt * E
    Fs = np.zeros((12, 6))
    Fs[dm.POS, 0:3] = dt2 * C.T
    Fs[dm.VEL, 0:3] = dt * C.T
    Fs[dm.ATT, 3:6] = -dt2 * E @ C.T
    Fs[dm.RATE, 3:6] = dt * I3
    return Fz @ imu_cov @ Fz.T + Fs @ ship_cov @ Fs.T


def test_numpy_cos_and_sin_are_maths_bit_for_bit():
    """process_noise takes cos / sin from ``math`` where the array form took numpy's: the same libm values (numpy's
    tan is another implementation here and stays numpy's)."""
    import math

    rng = np.random.default_rng(9)
    for scale in (1e-6, 0.01, 0.3, 1.0, 1.6, 3.2, 100.0):
        a = rng.normal(size=20000) * scale
        assert np.array_equal(np.cos(a), [math.cos(v) for v in a.tolist()])
        assert np.array_equal(np.sin(a), [math.sin(v) for v in a.tolist()])
        assert np.array_equal(np.cos(a[:, None]), np.cos(a)[:, None])


def test_process_noise_is_the_reference_bit_for_bit():
    """process_noise builds C, E and dv/dw of the one mean state in Python floats (math's cos / sin, numpy's tan)
    and copies its dt-only blocks from templates: the same Q to the last bit, signs of zero included (speed
    rounds 4 and 5)."""
    rng = np.random.default_rng(8)
    imu = np.diag(rng.uniform(1e-6, 1e-2, 6))
    imu[0, 1] = imu[1, 0] = 1e-5
    ship = np.diag(rng.uniform(1e-4, 1.0, 6))
    for k in range(3000):
        x = rng.normal(size=12) * rng.choice([0.1, 1.0, 3.0])
        if k % 7 == 0:
            x[4] = np.pi / 2 * rng.choice([-1, 1]) + rng.normal(0, 1e-9)  # near the pitch singularity
        if k % 5 == 1:  # exact zeros (the signs of zero products and sums)
            x[rng.choice(12, 4, replace=False)] = rng.choice([0.0, -0.0])
        if k % 11 == 3:
            x[4] = rng.uniform(-1.6, 1.6)  # pitch over its whole range
        u = dm.ImuInput(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
        if k % 9 == 2:
            u = dm.ImuInput(u.accel, np.array([0.0, -0.0, rng.normal()]), u.gyro_dot, u.gravity_body)
        dt = float(rng.choice([0.01, 0.005, 0.0033333333333333335, rng.uniform(1e-4, 0.02)]))
        got, ref = dm.process_noise(x, dt, u, imu, ship), _process_noise_reference(x, dt, u, imu, ship)
        assert np.array_equal(got.view(np.int64), ref.view(np.int64))


def _euler_rate_matrix_reference(e):
    """E(e) as euler_rate_matrix computed it before speed round 5 (its own cos / sin / tan of the columns)."""
    cf, sf = np.cos(e[:, 0]), np.sin(e[:, 0])
    ct, tt = np.cos(e[:, 1]), np.tan(e[:, 1])
    E = np.zeros((e.shape[0], 3, 3))
    E[:, 0, 0] = 1.0
    E[:, 0, 1] = sf * tt
    E[:, 0, 2] = cf * tt
    E[:, 1, 1] = cf
    E[:, 1, 2] = -sf
    E[:, 2, 1] = sf / ct
    E[:, 2, 2] = cf / ct
    return E


def test_dcm_and_rate_matrix_from_shared_trig_equal_the_separate_forms_bit_for_bit():
    """process_model takes C and E of its sigma points from one euler_dcm_batch(e, rate=True) (the cos / sin of
    the batch shared): the same arrays, C-contiguous, as euler_dcm_batch(e) and the separate E (the einsums
    downstream read their layout), on sigma-point-like batches (column-major views of 25 x 12, rows of 1)."""
    rng = np.random.default_rng(17)
    for k in range(3000):
        n = int(rng.choice([25, 1, int(rng.integers(2, 40))]))
        sig = rng.normal(size=(n, 12)) * rng.choice([0.01, 0.5, 2.0, 10.0])
        if k % 2:
            sig = np.asfortranarray(sig)
        if k % 7 == 0:
            sig[:, 4] = np.pi / 2 * rng.choice([-1, 1], n) + rng.normal(0, 1e-9, n)  # near the pitch singularity
        if k % 5 == 1:
            sig[:, 3:6][rng.random((n, 3)) < 0.3] = rng.choice([0.0, -0.0])
        e = sig[:, dm.ATT]
        C, E = dm.euler_dcm_batch(e, rate=True)
        C0, E0 = dm.euler_dcm_batch(e), _euler_rate_matrix_reference(e)
        assert np.array_equal(C.view(np.int64), C0.view(np.int64)) and C.flags.c_contiguous
        assert np.array_equal(E.view(np.int64), E0.view(np.int64)) and E.flags.c_contiguous
        assert np.array_equal(dm.euler_rate_matrix(e).view(np.int64), E0.view(np.int64))
