"""The estimation kernels against the readable equations they reproduce, at 1e-12 (issue #31)."""

from __future__ import annotations

import numpy as np

from visnav.estimation.ins import NavState, StrapdownINS, quat_from_rotvec


def test_flat_ins_propagation_is_the_readable_one():
    """300 IMU intervals of random specific force and body rates, with biases: the same states step by step."""
    rng = np.random.default_rng(7)
    fast, ref = StrapdownINS(earth_rotation=False, gravity=9.81), StrapdownINS(earth_rotation=False, gravity=9.81)
    ref.kernel = False
    s0 = NavState(0.0, rng.normal(0, 50, 3), rng.normal(0, 5, 3), quat_from_rotvec(rng.normal(0, 1, 3)),
                  rng.normal(0, 0.1, 3), rng.normal(0, 0.01, 3))
    a, b = s0.copy(), s0.copy()
    for _ in range(300):
        f, w, dt = rng.normal(0, 3, 3) + [0, 0, -9.81], rng.normal(0, 0.5, 3), rng.uniform(0.005, 0.02)
        a, b = fast.propagate(a, f, w, dt), ref.propagate(b, f, w, dt)
        for x, y in ((a.position, b.position), (a.velocity, b.velocity), (a.quat, b.quat)):
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)
        assert a.t == b.t
    w0 = np.zeros(3)  # a zero rotation (the exponential map's limit)
    np.testing.assert_allclose(fast.propagate(a, f, w0 + a.gyro_bias, dt).quat, ref.propagate(a, f, w0 + a.gyro_bias,
                                                                                               dt).quat, rtol=1e-12)


def test_quaternion_step_is_the_readable_product():
    from visnav.estimation.ins import quat_mult
    from visnav.estimation.kernels import quat_step

    rng = np.random.default_rng(11)
    for _ in range(200):
        q = quat_from_rotvec(rng.normal(0, 1, 3))
        w, dt = rng.normal(0, 1, 3), rng.uniform(0.001, 0.05)
        np.testing.assert_allclose(quat_step(tuple(q.tolist()), w.tolist(), dt), quat_mult(q, quat_from_rotvec(w * dt)),
                                   rtol=1e-12, atol=1e-15)
    assert quat_step((1.0, 0.0, 0.0, 0.0), [0.0, 0.0, 0.0], 0.01) == (1.0, 0.0, 0.0, 0.0)  # no rotation


def test_the_gyro_check_on_floats_is_the_readable_one():
    from visnav.navigation.integrity import GyroAttitudeCheck

    rng = np.random.default_rng(5)
    a, b = GyroAttitudeCheck(), GyroAttitudeCheck()
    b.kernel = False
    for k in range(500):
        w = rng.normal(0, 0.3, 3)
        a.gyro(0.02 * k, w, 0.02)
        b.gyro(0.02 * k, w, 0.02)
    np.testing.assert_allclose(np.asarray(a._R), np.asarray(b._R), rtol=1e-12, atol=1e-14)


# ------------------------------------------------------------------ the deck UKF's prediction (seed 003)
def _imu_input(rng):
    from visnav.estimation import deck as dm

    return dm.ImuInput(accel=rng.normal(0, 3, 3) + [0, 0, -9.81], gyro=rng.normal(0, 0.5, 3),
                       gyro_dot=rng.normal(0, 2, 3), gravity_body=rng.normal(0, 1, 3) + [0, 0, 9.81])


def test_the_deck_process_model_kernel_is_eq_3_1_to_3_5():
    """Batches of sigma points of the thesis' 12 states, with the bias (15) and with consider parameters (22), each
    bias flag: the kernel's rows are ``deck.process_model``'s at 1e-12 (the consider parameters copied)."""
    from visnav.estimation import deck as dm
    from visnav.estimation.kernels import deck_process_model

    rng = np.random.default_rng(3)
    for n in (12, 15, 22):
        for bias in (None, False, True)[: 3 if n > 12 else 2]:
            for _ in range(20):
                sig = rng.normal(0, 1, (2 * n + 1, n))
                sig[:, dm.ATT] *= 0.4  # (pitch away from +-90 deg)
                u, dt = _imu_input(rng), rng.uniform(0.002, 0.05)
                want = dm.process_model(sig, dt, u, bias=bias)
                got = deck_process_model(sig, dt, u, bias=bias)
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-13)
                np.testing.assert_array_equal(got[:, 12 + 3 * (n >= 15 and bias is not False):],
                                              sig[:, 12 + 3 * (n >= 15 and bias is not False):])


def test_the_deck_process_noise_kernel_is_eq_3_8():
    """``deck.process_noise`` at random means, IMU and ship covariances: the kernel's 12 x 12 block at 1e-12,
    zeros beyond it, symmetric."""
    from visnav.estimation import deck as dm
    from visnav.estimation.kernels import deck_process_noise

    rng = np.random.default_rng(4)
    for n in (12, 15, 22):
        for _ in range(30):
            x = rng.normal(0, 1, n)
            x[dm.ATT] *= 0.4
            u, dt = _imu_input(rng), rng.uniform(0.002, 0.05)
            A, B = rng.normal(size=(6, 6)), rng.normal(size=(6, 6))
            imu_cov, ship_cov = A @ A.T * 1e-3, B @ B.T * 1e-2
            want = dm.process_noise(x, dt, u, imu_cov, ship_cov)
            got = deck_process_noise(x, dt, u, imu_cov, ship_cov, n)
            assert got.shape == (n, n)
            np.testing.assert_allclose(got[:12, :12], want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
            assert not got[12:].any() and not got[:, 12:].any()
            np.testing.assert_allclose(got, got.T, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_the_deck_navigator_on_the_kernels_is_the_readable_one():
    """Two deck navigators (bias states on), one predicting through the kernels and one through the readable
    functions, 3 s of a turning, accelerating IMU and noisy bearings: the same state and covariance at 1e-9."""
    from visnav.estimation import deck as dm
    from visnav.measurements import ImuSample
    from visnav.navigation.deck import DeckNavigator
    from visnav.world.deck import LEDS_EQ_5_10
    from tests.navigation.test_deck_navigator import CAM, _tied_nav

    fast, truth = _tied_nav(accel_bias_sigma=0.1, accel_bias_walk=0.002)
    DeckNavigator.kernel = False
    try:
        ref, _ = _tied_nav(accel_bias_sigma=0.1, accel_bias_walk=0.002)
    finally:
        DeckNavigator.kernel = True
    assert not ref._compiled and ref.ukf.fx.func is dm.process_model
    rng = np.random.default_rng(9)
    b, r = dm.bearings_and_rates(truth[None], LEDS_EQ_5_10, CAM, np.zeros(3))
    for k in range(301):
        t = 0.01 * k
        gyro = 0.2 * np.array([np.sin(2 * t), np.cos(3 * t), 0.5 * np.sin(t)])
        accel = np.array([0.3 * np.cos(t), -0.2, -9.81 + 0.1 * np.sin(4 * t)])
        for nav in (fast, ref):
            nav.update(ImuSample(t, accel, gyro))
        if k % 3 == 0:
            bn, rn = b[0] + 1e-3 * rng.standard_normal(b[0].shape), r[0] + 0.05 * rng.standard_normal(r[0].shape)
            for nav in (fast, ref):
                nav.fuse_bearings(bn, rn)
    assert fast.ukf.n == ref.ukf.n == dm.N_AUGMENTED and fast.stats.imu_samples == 301
    np.testing.assert_allclose(fast.ukf.x, ref.ukf.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fast.ukf.P, ref.ukf.P, rtol=1e-9, atol=1e-15)
    assert np.abs(fast.ukf.x[dm.VEL]).max() > 0.01  # (it moved)


def test_the_deck_kernels_are_compiled_exactly_where_numba_is_installed_and_not_switched_off():
    """``make install`` installs the ``fast`` extra: the deck navigator then predicts through numba's compiled
    kernels; without numba, or with VISNAV_JIT=0, through the readable ``estimation/deck`` functions (the kernels'
    element loops on Python floats would be slower than numpy)."""
    import importlib.util
    import os

    from visnav.estimation import kernels
    from tests.jit_off import run_without_jit
    from tests.navigation.test_deck_navigator import _tied_nav

    compiled = importlib.util.find_spec("numba") is not None and os.environ.get("VISNAV_JIT", "1") != "0"
    assert (kernels.njit is not None) == compiled == hasattr(kernels._deck_process_model, "py_func")
    assert _tied_nav()[0]._compiled == compiled
    run_without_jit("from tests.navigation.test_deck_navigator import _tied_nav\n"
                    "from visnav.estimation import deck as dm\n"
                    "nav = _tied_nav()[0]\n"
                    "assert not nav._compiled and nav.ukf.fx.func is dm.process_model\n"
                    "print('ok')\n")
