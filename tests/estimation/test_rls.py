"""Recursive least squares (seed 002 §7.3.4) against the batch solution, and its gating."""

import numpy as np
import pytest

from visnav.estimation.rls import RecursiveLeastSquares, batch_least_squares


def test_equals_batch_least_squares_at_every_step():
    rng = np.random.default_rng(0)
    n = 3
    x_true = rng.normal(0, 5, n)
    rls = RecursiveLeastSquares(n, gate_prob=None)
    Hs, zs, Rs = [], [], []
    for k in range(60):
        m = int(rng.integers(1, 3))
        H = rng.normal(0, 1, (m, n))
        A = rng.normal(0, 0.5, (m, m))
        R = A @ A.T + 0.1 * np.eye(m)
        z = H @ x_true + rng.multivariate_normal(np.zeros(m), R)
        rls.update(z, H, R)
        Hs.append(H), zs.append(z), Rs.append(R)
        if np.linalg.matrix_rank(sum(h.T @ h for h in Hs)) == n:
            xb, Pb = batch_least_squares(Hs, zs, Rs)
            np.testing.assert_allclose(rls.x, xb, rtol=0, atol=1e-9)
            np.testing.assert_allclose(rls.P, Pb, rtol=0, atol=1e-9)
    # and the batch solution is numpy's weighted lstsq
    W = [np.linalg.cholesky(np.linalg.inv(R)).T for R in Rs]
    A = np.vstack([w @ h for w, h in zip(W, Hs)])
    b = np.concatenate([w @ z for w, z in zip(W, zs)])
    np.testing.assert_allclose(rls.x, np.linalg.lstsq(A, b, rcond=None)[0], atol=1e-9)


def test_position_samples_mean_and_covariance():
    rng = np.random.default_rng(1)
    z = rng.normal([10.0, -4.0], 2.0, (40, 2))
    rls = RecursiveLeastSquares(2, gate_prob=None)
    for s in z:
        rls.update(s, R=4.0 * np.eye(2))
    np.testing.assert_allclose(rls.x, z.mean(axis=0), atol=1e-9)
    np.testing.assert_allclose(rls.covariance(), 4.0 / 40 * np.eye(2), atol=1e-9)


def test_gating_rejects_false_matches():
    rng = np.random.default_rng(2)
    truth = np.array([3.0, 1.0])
    clean, gated = RecursiveLeastSquares(2, gate_prob=None), RecursiveLeastSquares(2, gate_prob=0.999)
    for k in range(60):
        z = truth + rng.normal(0, 1.0, 2)
        if k % 7 == 3:
            z = truth + np.array([30.0, -25.0])  # a false match on a repetitive structure
        clean.update(z, R=np.eye(2))
        gated.update(z, R=np.eye(2))
    assert np.linalg.norm(clean.x - truth) > 3.0
    assert np.linalg.norm(gated.x - truth) < 0.5
    assert gated.rejected >= 7


def test_restart_when_started_on_false_matches():
    rng = np.random.default_rng(3)
    truth = np.zeros(2)
    rls = RecursiveLeastSquares(2, gate_prob=0.999, min_samples=3, reinit_after=4)
    for _ in range(3):
        rls.update(np.array([40.0, 40.0]) + rng.normal(0, 0.5, 2), R=np.eye(2))
    for _ in range(30):
        rls.update(truth + rng.normal(0, 1.0, 2), R=np.eye(2))
    assert rls.reinits >= 1
    assert np.linalg.norm(rls.x - truth) < 1.0


def test_bad_shapes_raise():
    with pytest.raises(ValueError):
        RecursiveLeastSquares(2).update([1.0, 2.0], H=np.eye(3))
