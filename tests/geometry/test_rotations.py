from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.geometry.rotations import (
    body_rates_to_euler_rates,
    cross3,
    dcm_to_euler,
    euler_rates_to_body_rates,
    euler_to_dcm,
    skew,
    wrap_angle,
)


def _random_euler(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.column_stack(
        [
            rng.uniform(-np.pi, np.pi, n),
            rng.uniform(-np.pi / 2 + 0.05, np.pi / 2 - 0.05, n),
            rng.uniform(-np.pi, np.pi, n),
        ]
    )


def _cbn_eq_3_2(phi: float, theta: float, psi: float) -> np.ndarray:
    """Seed 002 eq. 3.2 written out by hand."""
    cf, sf = np.cos(phi), np.sin(phi)
    ct, st = np.cos(theta), np.sin(theta)
    cp, sp = np.cos(psi), np.sin(psi)
    return np.array(
        [
            [ct * cp, -cf * sp + sf * st * cp, sf * sp + cf * st * cp],
            [ct * sp, cf * cp + sf * st * sp, -sf * cp + cf * st * sp],
            [-st, sf * ct, cf * ct],
        ]
    )


def test_euler_to_dcm_matches_seed_002_eq_3_2():
    rng = np.random.default_rng(1)
    e = _random_euler(rng, 50)
    C = euler_to_dcm(e)
    assert C.shape == (50, 3, 3)
    for ei, Ci in zip(e, C):
        np.testing.assert_allclose(Ci, _cbn_eq_3_2(*ei), atol=1e-14)


def test_euler_to_dcm_single_and_batched_shapes():
    rng = np.random.default_rng(2)
    e = _random_euler(rng, 12).reshape(3, 4, 3)
    C = euler_to_dcm(e)
    assert C.shape == (3, 4, 3, 3)
    np.testing.assert_allclose(euler_to_dcm(e[1, 2]), C[1, 2], atol=1e-15)
    assert euler_to_dcm(e[0, 0]).shape == (3, 3)


def test_dcm_is_orthonormal_rotation():
    rng = np.random.default_rng(3)
    C = euler_to_dcm(_random_euler(rng, 100))
    np.testing.assert_allclose(C @ np.swapaxes(C, -1, -2), np.broadcast_to(np.eye(3), C.shape), atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-13)


def test_body_axes_map_as_expected():
    # Yaw 90 deg: the nose (body x) points east; pitch up 90 deg: the nose points up (-z).
    np.testing.assert_allclose(euler_to_dcm([0, 0, np.pi / 2]) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(euler_to_dcm([0, np.pi / 2, 0]) @ [1, 0, 0], [0, 0, -1], atol=1e-15)
    # Roll right 90 deg: the right wing (body y) points down.
    np.testing.assert_allclose(euler_to_dcm([np.pi / 2, 0, 0]) @ [0, 1, 0], [0, 0, 1], atol=1e-15)


def test_euler_round_trip_and_scipy():
    rng = np.random.default_rng(4)
    e = _random_euler(rng, 200)
    back = dcm_to_euler(euler_to_dcm(e))
    np.testing.assert_allclose(back, e, atol=1e-12)
    ref = Rotation.from_matrix(euler_to_dcm(e)).as_euler("ZYX")[:, ::-1]
    np.testing.assert_allclose(back, ref, atol=1e-10)


def test_dcm_to_euler_wraps_yaw_and_handles_gimbal_lock():
    e = dcm_to_euler(euler_to_dcm([0.1, 0.2, np.pi]))
    assert e[2] == pytest.approx(np.pi)
    C = euler_to_dcm([0.3, np.pi / 2, 1.0])
    e = dcm_to_euler(C)
    assert e[1] == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(euler_to_dcm(e), C, atol=1e-7)


def test_rates_round_trip():
    rng = np.random.default_rng(5)
    e = _random_euler(rng, 100)
    pqr = rng.normal(0, 1, (100, 3))
    ed = body_rates_to_euler_rates(e, pqr)
    np.testing.assert_allclose(euler_rates_to_body_rates(e, ed), pqr, atol=1e-11)
    np.testing.assert_allclose(body_rates_to_euler_rates(e, euler_rates_to_body_rates(e, pqr)), pqr, atol=1e-11)


def test_rates_against_finite_difference_of_dcm():
    """Kinematics dC/dt = C skew(pqr) with pqr from eq. 3.7 (inverted)."""
    rng = np.random.default_rng(6)
    e0 = _random_euler(rng, 20)
    ed = rng.normal(0, 0.5, (20, 3))
    h = 1e-6
    dC = (euler_to_dcm(e0 + h * ed) - euler_to_dcm(e0 - h * ed)) / (2 * h)
    pqr = euler_rates_to_body_rates(e0, ed)
    np.testing.assert_allclose(dC, euler_to_dcm(e0) @ skew(pqr), atol=1e-8)
    # And the forward direction of eq. 3.7 reproduces the Euler rates used.
    np.testing.assert_allclose(body_rates_to_euler_rates(e0, pqr), ed, atol=1e-11)


def test_eq_3_7_small_angle_form():
    # Seed 002 eq. 4.11 (linearised eq. 3.7): q ~ theta_dot + r phi, p ~ phi_dot - r theta.
    e = np.array([1e-3, -2e-3, 0.4])
    pqr = np.array([0.02, -0.01, 0.3])
    ed = body_rates_to_euler_rates(e, pqr)
    assert pqr[1] == pytest.approx(ed[1] + pqr[2] * e[0], abs=1e-6)
    assert pqr[0] == pytest.approx(ed[0] - pqr[2] * e[1], abs=1e-6)


def test_gimbal_lock_rates_raise():
    with pytest.raises(ValueError, match="pitch"):
        body_rates_to_euler_rates([0.0, np.pi / 2, 0.0], [0.1, 0.2, 0.3])


def test_skew_is_cross_product():
    rng = np.random.default_rng(7)
    v, u = rng.normal(size=(2, 10, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", skew(v), u), np.cross(v, u), atol=1e-14)
    S = skew([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(S, -S.T)
    for k in range(10):  # the single-vector fast path (filters) agrees with the general one
        np.testing.assert_allclose(skew(v[k]) @ u[k], np.cross(v[k], u[k]), atol=1e-14)
        np.testing.assert_array_equal(skew(v[k]), skew(v[k:k + 1])[0])


def test_wrap_angle():
    assert wrap_angle(np.pi) == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)
    assert wrap_angle(3 * np.pi) == pytest.approx(np.pi)
    assert wrap_angle(2 * np.pi + 0.1) == pytest.approx(0.1)
    rng = np.random.default_rng(8)
    a = rng.uniform(-50, 50, 1000)
    w = wrap_angle(a)
    assert np.all((w > -np.pi) & (w <= np.pi))
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)


@pytest.mark.parametrize(
    "call",
    [
        lambda: euler_to_dcm([0.1, 0.2]),
        lambda: euler_to_dcm([0.1, np.nan, 0.0]),
        lambda: dcm_to_euler(np.eye(2)),
        lambda: skew([1.0, 2.0]),
        lambda: body_rates_to_euler_rates([0, 0, 0], [1, 2]),
    ],
)
def test_bad_input_raises(call):
    with pytest.raises(ValueError):
        call()


def test_single_vector_fast_paths_equal_the_batch_arithmetic_to_the_ulp():
    """The one-vector paths (scalar math, the 100 Hz loops) give the batch (numpy) path's numbers: the
    same arithmetic, bit for bit where numpy's ufuncs use libm; on a CPU where numpy takes its own SIMD
    arctan2 / arcsin (AVX-512) the two may differ in the last bit, so the check is a few ulp, not equality."""
    rng = np.random.default_rng(7)
    e = _random_euler(rng, 300)
    e[:5, 2] = [np.pi, -np.pi, np.nextafter(-np.pi, 0.0), 0.0, np.pi / 2]
    C = euler_to_dcm(e)
    C[5] = euler_to_dcm([0.3, np.pi / 2, 0.2])  # gimbal lock: roll set to 0
    single = np.array([dcm_to_euler(c) for c in C])
    batch = dcm_to_euler(C)
    np.testing.assert_array_max_ulp(single, batch, maxulp=4)
    assert single[5, 0] == 0.0 and np.all((single[:, 2] > -np.pi) & (single[:, 2] <= np.pi))
    ed = rng.normal(0.0, 1.0, (300, 3))
    np.testing.assert_allclose(np.array([euler_rates_to_body_rates(a, b) for a, b in zip(e, ed)]),
                               euler_rates_to_body_rates(e, ed), rtol=1e-15, atol=1e-15)
    a, b = rng.normal(0.0, 10.0, (2, 300, 3))
    assert np.array_equal(np.array([cross3(x, y) for x, y in zip(a, b)]), np.cross(a, b))
    assert np.array_equal(cross3([1.0, 0.0, 0.0], (0.0, 1.0, 0.0)), [0.0, 0.0, 1.0])


def test_the_level_attitude_from_three_floats_is_euler_to_dcm_of_the_list_bit_for_bit():
    """The deck's 50 / 100 Hz code takes ``euler_to_dcm3(roll, pitch, 0.0)`` where it took
    ``euler_to_dcm([roll, pitch, 0.0])``: the same matrix to the bit (signs of zero included) and the same
    refusal of a NaN attitude."""
    from visnav.geometry.rotations import euler_to_dcm, euler_to_dcm3

    rng = np.random.default_rng(12)
    for k in range(3000):
        r, p = (float(v) for v in rng.normal(0, [0.3, 1.2][k % 2], 2))
        if k % 10 == 0:
            r, p = float(rng.choice([0.0, -0.0])), float(rng.choice([0.0, -0.0, p]))
        a, b = euler_to_dcm([np.float64(r), p, 0.0]), euler_to_dcm3(r, p, 0.0)
        assert np.array_equal(a.view(np.int64), b.view(np.int64))
    for bad in ((np.nan, 0.1), (0.1, np.inf)):
        with pytest.raises(ValueError, match="finite"):
            euler_to_dcm([bad[0], bad[1], 0.0])
        with pytest.raises(ValueError, match="finite"):
            euler_to_dcm3(bad[0], bad[1], 0.0)
