"""Figure-eight path and L1 guidance (seed 002 Fig. 7.7)."""

import math

import numpy as np
import pytest

from visnav.guidance.figure_eight import FigureEight


def test_path_crosses_over_the_centre_and_spans_the_half_length():
    f = FigureEight([5.0, -3.0], 80.0, math.radians(90.0))
    d = np.linalg.norm(f.points - [5.0, -3.0], axis=1)
    assert d.min() < 0.2
    assert d.max() == pytest.approx(80.0, abs=0.1)
    assert np.ptp(f.points[:, 1]) == pytest.approx(160.0, abs=0.1)  # along east
    assert np.ptp(f.points[:, 0]) == pytest.approx(80.0, abs=0.5)  # lobes a/2 each side


def test_l1_turns_towards_the_path():
    f = FigureEight([0.0, 0.0], 80.0, 0.0)
    p, course = f.start_pose()
    # flying the path direction, displaced to the right of it: the command turns left (negative)
    right = np.array([-math.sin(course), math.cos(course)])
    v = 13.0 * np.array([math.cos(course), math.sin(course)])
    r_cmd, info = f.heading_rate(p + 10.0 * right, v)
    f.index = None
    l_cmd, _ = f.heading_rate(p - 10.0 * right, v)
    assert r_cmd < 0 < l_cmd
    # L1 law: a = 2 V^2 sin(eta) / L1 -> the rate is bounded by 2 V / L1
    assert abs(r_cmd) <= 2 * 13.0 / f.l1 + 1e-9
