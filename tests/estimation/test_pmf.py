import numpy as np
import pytest

from visnav.estimation.pmf import PointMassFilter, gaussian_kernel


def test_kernel_variance_matches_sigma():
    k = gaussian_kernel(2.5)
    x = np.arange(len(k)) - len(k) // 2
    assert k.sum() == pytest.approx(1.0)
    assert (k * x * x).sum() == pytest.approx(2.5**2, rel=1e-3)


def test_linear_gaussian_case_matches_kalman_filter():
    """Random walk with odometry input and Gaussian position measurements: the PMF mean and
    covariance equal the Kalman filter's (up to the grid discretization)."""
    rng = np.random.default_rng(2)
    x0, P = np.array([100.0, -50.0]), np.eye(2) * 6.0**2
    pmf = PointMassFilter(x0, size_m=80.0, resolution_m=0.5, sigma0_m=6.0)
    x = x0.copy()
    sv = 1.5
    R = np.array([[9.0, 2.0], [2.0, 4.0]])
    for _ in range(15):
        u = rng.normal(0, 3.0, 2)
        # Kalman filter
        x, P = x + u, P + sv**2 * np.eye(2)
        pmf.predict(u, sv)
        z = x + rng.multivariate_normal([0, 0], R)
        S = P + R
        Kg = P @ np.linalg.inv(S)
        x, P = x + Kg @ (z - x), (np.eye(2) - Kg) @ P
        pmf.update_gaussian(z, R)
        m, C = pmf.estimate()
        np.testing.assert_allclose(m, x, atol=0.02)
        np.testing.assert_allclose(C, P, atol=0.03, rtol=0.01)


def test_grid_follows_estimate_and_bad_input():
    pmf = PointMassFilter([0.0, 0.0], size_m=40, resolution_m=1.0, sigma0_m=3.0)
    pmf.update_gaussian([8.0, -6.0], np.eye(2))
    m, _ = pmf.estimate()
    assert np.allclose(pmf.centre, np.round(m))  # re-centred by whole cells
    with pytest.raises(ValueError, match="finite"):
        pmf.predict([np.nan, 0.0], 1.0)
    with pytest.raises(ValueError, match="8..400"):
        PointMassFilter([0, 0], size_m=1000, resolution_m=1.0)
    # a likelihood that is zero everywhere keeps the prior
    before = pmf.p.copy()
    assert pmf.update(np.zeros_like(pmf.p)) == 0.0
    np.testing.assert_array_equal(pmf.p, before)
