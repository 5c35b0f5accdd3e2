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
