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


def test_every_entry_point_agrees_with_scipy_single_and_batched():
    """One vector and a batch, against an independent implementation (scipy's ``Rotation``, ZYX intrinsic
    = ``Rz(yaw) Ry(pitch) Rx(roll)``), gimbal lock and the yaw wrap included."""
    from visnav.geometry.rotations import euler_to_dcm3, euler_to_dcm_and_rate_matrix

    rng = np.random.default_rng(7)
    e = _random_euler(rng, 300)
    e[:5, 2] = [np.pi, -np.pi, np.nextafter(-np.pi, 0.0), 0.0, np.pi / 2]
    ref = Rotation.from_euler("ZYX", e[:, ::-1]).as_matrix()
    np.testing.assert_allclose(euler_to_dcm(e), ref, atol=1e-15)
    np.testing.assert_allclose(np.array([euler_to_dcm3(*x) for x in e]), ref, atol=1e-15)
    np.testing.assert_allclose(euler_to_dcm_and_rate_matrix(e)[0], ref, atol=1e-15)
    single = np.array([dcm_to_euler(c) for c in ref])
    np.testing.assert_allclose(single, dcm_to_euler(ref), atol=1e-15)
    yaw_ok = np.abs(np.abs(e[:, 2]) - np.pi) > 1e-9  # +-pi both read as +pi
    np.testing.assert_allclose(single[yaw_ok], e[yaw_ok], atol=1e-9)
    assert np.all((single[:, 2] > -np.pi) & (single[:, 2] <= np.pi))
    locked = dcm_to_euler(Rotation.from_euler("ZYX", [0.2, np.pi / 2, 0.3]).as_matrix())
    assert locked[0] == 0.0 and locked[1] == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(euler_to_dcm([0.0, locked[1], locked[2]]),  # the same rotation, roll folded into yaw
                               Rotation.from_euler("ZYX", [0.2, np.pi / 2, 0.3]).as_matrix(), atol=1e-7)
    ed = rng.normal(0.0, 1.0, (300, 3))
    np.testing.assert_allclose(np.array([euler_rates_to_body_rates(a, b) for a, b in zip(e, ed)]),
                               euler_rates_to_body_rates(e, ed), rtol=1e-14, atol=1e-14)
    a, b = rng.normal(0.0, 10.0, (2, 300, 3))
    np.testing.assert_allclose(np.array([cross3(x, y) for x, y in zip(a, b)]), np.cross(a, b), rtol=1e-14, atol=1e-12)
    assert np.array_equal(cross3([1.0, 0.0, 0.0], (0.0, 1.0, 0.0)), [0.0, 0.0, 1.0])


def test_euler_rate_matrix_is_the_closed_form_of_eq_3_7_and_inverts_the_body_rates():
    """E(e) (seed 002 eq. 3.7) entry by entry from its printed form, and E(e) E(e)^-1 = I through the two
    rate conversions, for one vector and for a batch."""
    from visnav.geometry.rotations import euler_rate_matrix, euler_to_dcm_and_rate_matrix

    rng = np.random.default_rng(3)
    e = _random_euler(rng, 50)
    for x in e[:5]:
        phi, th = x[0], x[1]
        printed = [[1, np.sin(phi) * np.tan(th), np.cos(phi) * np.tan(th)], [0, np.cos(phi), -np.sin(phi)],
                   [0, np.sin(phi) / np.cos(th), np.cos(phi) / np.cos(th)]]
        np.testing.assert_allclose(euler_rate_matrix(x), printed, rtol=1e-14, atol=1e-15)
    E = euler_rate_matrix(e)
    np.testing.assert_allclose(E, np.array([euler_rate_matrix(x) for x in e]), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(euler_to_dcm_and_rate_matrix(e)[1], E, rtol=1e-13, atol=1e-14)
    w = rng.normal(size=(50, 3))
    np.testing.assert_allclose(euler_rates_to_body_rates(e, body_rates_to_euler_rates(e, w)), w, atol=1e-12)
