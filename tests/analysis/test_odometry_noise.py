import math

import numpy as np
import pytest

from visnav.analysis.odometry_noise import odometry_noise, write_figures


def test_attitude_noise_closed_form():
    """Noise-free pixels: sigma_tau = sqrt(2) sigma_alpha (two independent tilt errors)."""
    st = odometry_noise(50, 0.0, 0.5, trials=20000, rng=np.random.default_rng(0))
    assert st == pytest.approx([math.sqrt(2) * math.radians(0.5)] * 2, rel=0.03)


def test_pixel_noise_scales_linearly_and_falls_with_features():
    a = odometry_noise(50, 1.0, 0.0, trials=3000, rng=np.random.default_rng(1))
    b = odometry_noise(50, 2.0, 0.0, trials=3000, rng=np.random.default_rng(1))
    np.testing.assert_allclose(b, 2 * a, rtol=0.05)  # linear in sigma_pi (same draws)
    few = odometry_noise(12, 2.0, 0.0, trials=3000, rng=np.random.default_rng(2))
    many = odometry_noise(150, 2.0, 0.0, trials=3000, rng=np.random.default_rng(2))
    assert many.max() < 0.5 * few.min()
    # thesis: with sigma_pi = 2 px and sigma_alpha = 0.5 deg the attitude dominates (by ~10x)
    att = odometry_noise(50, 0.0, 0.5, trials=3000, rng=np.random.default_rng(3))
    assert att.min() > 3 * b.max()


def test_one_sided_layout_is_worse_along_x():
    rng = np.random.default_rng(4)
    uni = odometry_noise(50, 2.0, 0.0, "uniform", 3000, rng)
    one = odometry_noise(50, 2.0, 0.0, "one-sided", 3000, rng)
    assert one[1] > 1.5 * uni[1]  # east = image x: the axis the features do not span
    assert one[1] > one[0]
    with pytest.raises(ValueError, match="layout"):
        odometry_noise(50, 1.0, layout="left")


def test_figures_are_written(tmp_path):
    paths = write_figures(tmp_path, trials=40)
    assert len(paths) == 5 and all(p.stat().st_size > 5000 for p in paths)
