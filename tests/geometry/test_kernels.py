"""The one-vector rotation kernels against the readable (batch) equations, at 1e-12 (issue #31)."""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry import rotations
from visnav.geometry.kernels import dcm_to_euler3


def test_dcm_to_euler3_is_the_batch_path():
    rng = np.random.default_rng(0)
    e = np.c_[rng.uniform(-np.pi, np.pi, 500), rng.uniform(-1.5, 1.5, 500), rng.uniform(-np.pi, np.pi, 500)]
    e[:5, 1] = [math.pi / 2, -math.pi / 2, math.pi / 2, 0.0, 0.0]  # gimbal lock; yaw -pi
    e[3:5, 2] = -math.pi
    C = rotations.euler_to_dcm(e)
    C[5] = np.nan
    ref = rotations.dcm_to_euler(C)  # the batch path: the readable equations
    got = np.array([dcm_to_euler3(c.tolist()) for c in C])
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15)
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    one = rotations.dcm_to_euler(C[7])
    rotations.KERNELS = False
    try:
        np.testing.assert_allclose(one, rotations.dcm_to_euler(C[7]), rtol=1e-12, atol=1e-15)
    finally:
        rotations.KERNELS = True


def test_one_vector_euler_rates_and_wrap_are_the_batch_ones():
    rng = np.random.default_rng(1)
    e, w = rng.uniform(-1.4, 1.4, (200, 3)), rng.normal(0, 1, (200, 3))
    ref = rotations.body_rates_to_euler_rates(e, w)
    got = np.array([rotations.body_rates_to_euler_rates(a, b) for a, b in zip(e, w)])
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15)
    a = np.r_[rng.uniform(-20, 20, 200), -math.pi, math.pi, 0.0, 3 * math.pi]
    wrapped = rotations.wrap_angle(a)
    assert [rotations.wrap_angle(float(x)) for x in a] == wrapped.tolist()
    assert wrapped.min() > -math.pi and wrapped.max() <= math.pi
