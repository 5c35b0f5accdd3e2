"""guidance/kernels against the readable models (issue #31 item 2): the same equation at 1e-12 relative."""

import numpy as np
import pytest

from visnav.guidance import kernels
from visnav.guidance.hermite import HermiteSegment


@pytest.fixture
def readable(monkeypatch):
    monkeypatch.setattr(kernels, "ENABLED", False)


def _segments():
    rng = np.random.default_rng(3)
    out = [HermiteSegment(np.zeros(3), np.array([100.0, 0.0, 0.0]), np.array([100.0, 0.0, 0.0]),
                          np.array([100.0, 0.0, 0.0]))]  # a straight line: arc length = chord
    for _ in range(20):
        p1 = rng.normal(0, 80, 3)
        out.append(HermiteSegment(np.zeros(3), p1, rng.normal(0, 60, 3) + p1, rng.normal(0, 60, 3) + p1))
    return out


def test_arc_length_of_one_point_is_the_readable_quadrature():
    for sg in _segments():
        for s, s0 in ((1.0, 0.0), (0.37, 0.0), (0.9, 0.2), (0.0, 0.0)):
            want = float(sg.arc_length(np.float64(s) * np.ones(1), np.float64(s0) * np.ones(1))[0])  # the array path
            got = sg.arc_length(s, s0)
            assert got == pytest.approx(want, rel=1e-12, abs=1e-12)
    assert _segments()[0].arc_length(0.5) == pytest.approx(50.0, rel=1e-12)  # closed form on a line


def test_the_readable_switch_takes_the_array_path(readable):
    sg = _segments()[3]
    assert isinstance(sg.arc_length(0.5), float)
    assert sg.arc_length(0.5) == pytest.approx(float(sg.arc_length(np.array([0.5]))[0]), rel=1e-15)
