"""MPE noise against range: eq. 3.3 with the laser noise of Fig. 3.4 (seed 000)."""

import math

import numpy as np
import pytest

from visnav.analysis.noise import closed_form, mpe_error_series, noise_slope

F = 1073.0
RANGES = [8.0, 16.0, 32.0, 64.0]


def test_across_track_sigma_grows_as_R_over_f_sqrt12_with_laser_noise():
    """The issue's criterion: slope of σ against R within 10% of 1/(f√12), laser noise on."""
    res, series = mpe_error_series(RANGES, F, n=1000, seed=1)
    assert all(s.shape == (1000, 3) for s in series)
    slope, intercept = noise_slope(res.range_m, res.sigma_across_m)
    assert slope == pytest.approx(1.0 / (F * math.sqrt(12.0)), rel=0.10)
    assert abs(intercept) < 0.1 * slope * RANGES[0]  # through the origin: linear in R


def test_each_axis_matches_the_closed_form():
    """Along track the laser dominates (σ_L = (1 + 0.2 R) cm x 1.5 over asphalt); without it the
    pixel share is R/(f√12)/sin 60° for the plane model (the ray slides along the ground)."""
    res, _ = mpe_error_series(RANGES, F, n=1000, seed=2)
    cf = closed_form(RANGES, F)
    np.testing.assert_allclose(res.sigma_along_m, cf.sigma_along_m, rtol=0.10)
    np.testing.assert_allclose(res.sigma_across_m, cf.sigma_across_m, rtol=0.10)
    assert np.all(cf.sigma_along_m > 3 * cf.sigma_across_m)
    quiet = closed_form(RANGES, F, sigma0_m=0.0, sigma_per_m=0.0)
    np.testing.assert_allclose(quiet.sigma_along_m, np.array(RANGES) / (F * math.sqrt(12)) / math.sin(math.pi / 3),
                               rtol=1e-3)
    res0, _ = mpe_error_series(RANGES, F, n=1000, sigma0_m=0.0, sigma_per_m=0.0, seed=3)
    np.testing.assert_allclose(res0.sigma_along_m, quiet.sigma_along_m, rtol=0.10)


def test_noise_rejects_bad_input():
    with pytest.raises(ValueError, match="ranges"):
        mpe_error_series([10.0, -1.0])
    with pytest.raises(ValueError, match="two distinct"):
        noise_slope([10.0, 10.0], [0.1, 0.2])
    with pytest.raises(ValueError, match="ranges"):
        closed_form([math.nan], F)
