"""The one-pixel vision kernels against the readable (array) chain, at 1e-12 (issue #31)."""

from __future__ import annotations

import math

import numpy as np

from visnav.vision import kernels
from visnav.vision.distortion_lut import DistortionLUT
from visnav.vision.rectification import CameraGeometry, ground_range


def test_one_point_lut_is_the_array_lookup():
    rng = np.random.default_rng(3)
    for kind in ("factor", "offset"):
        g0 = 0.0 if kind == "factor" else -1.0
        lut = DistortionLUT(kind, np.linspace(g0, 1, 9), np.linspace(g0, 1, 7), rng.normal(1, 0.1, (9, 7)),
                            rng.normal(1, 0.1, (9, 7)), 640, 480)
        X, Y = rng.uniform(-400, 400, 200), rng.uniform(-300, 300, 200)  # inside and outside the grid
        ref = lut.correct(X, Y)
        got = np.array([[float(c[0]) for c in lut.correct(np.array([x]), np.array([y]))] for x, y in zip(X, Y)])
        np.testing.assert_allclose(got.T, ref, rtol=1e-12, atol=1e-9)


def test_one_pixel_ground_range_is_the_array_chain():
    rng = np.random.default_rng(4)
    geom = CameraGeometry(640, 480, math.radians(30.0), math.atan(math.tan(math.radians(30.0)) * 0.75))
    for method in ("exact", "thesis"):
        X, Y = rng.uniform(-320, 320, 300), rng.uniform(-240, 240, 300)
        h, tilt, roll = rng.uniform(1, 150, 300), rng.uniform(-1.5, -0.05, 300), rng.uniform(-0.5, 0.5, 300)
        ref = np.array(ground_range(X, Y, h, tilt, roll, geom, method))
        got = np.array([kernels.ground_range1(*a, geom, method) for a in zip(X, Y, h, tilt, roll)]).T
        assert np.array_equal(np.isnan(got), np.isnan(ref)) and np.isnan(ref).any()  # (rays above the horizon)
        ok = np.isfinite(ref)
        np.testing.assert_allclose(got[ok], ref[ok], rtol=1e-12)
