"""The one ring-buffer history (estimation/history.py): numpy.interp on every column, angles across +-pi."""

import math

import numpy as np
import pytest

from visnav.estimation.history import History


def test_matches_numpy_interp_bit_for_bit_inside_and_holds_the_ends():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.02, 400))
    x = rng.normal(size=(400, 4))
    h = History(4, n=128, tolerance=0.05)
    for ti, xi in zip(t, x):
        h.push(ti, xi)
    kept_t, kept_x = t[-128:], x[-128:]
    q = np.concatenate([rng.uniform(kept_t[0], kept_t[-1], 200), kept_t[::7], [kept_t[-1] + 0.03, kept_t[0] - 0.04]])
    for qi in q:
        want = np.array([np.interp(qi, kept_t, kept_x[:, j]) for j in range(4)])
        assert np.array_equal(h.at(qi), want), qi
    assert h.at(kept_t[-1] + 0.051) is None and h.at(kept_t[0] - 0.051) is None
    assert len(h) == 128 and h.newest_t == t[-1] and np.array_equal(h.newest(), x[-1])


def test_a_short_history_and_an_empty_one():
    h = History(2, n=8)
    assert h.at(0.0) is None and h.newest() is None and h.newest_t == -math.inf
    h.push(1.0, [1.0, 2.0])
    assert np.array_equal(h.at(1.0), [1.0, 2.0]) and h.at(1.1) is None
    h.push(2.0, [3.0, 6.0])
    np.testing.assert_allclose(h.at(1.25), [1.5, 3.0], rtol=0, atol=1e-15)


def test_yaw_interpolates_across_plus_minus_pi():
    """Yaw from 179 deg to -179 deg: half-way is 180 deg (wrapped to -180), not 0."""
    h = History(3, n=16, angles=(2,))
    h.push(0.0, [0.1, 0.0, math.radians(179.0)])
    h.push(1.0, [0.3, 0.0, math.radians(-179.0)])
    out = h.at(0.5)
    assert out[0] == pytest.approx(0.2, abs=1e-15)
    assert abs(abs(out[2]) - math.pi) < 1e-12
    q = h.at(0.75)  # 179.5 + ... = 180.5 deg -> -179.5 deg
    assert q[2] == pytest.approx(math.radians(-179.5), abs=1e-12)
    # many turns: the stored yaw keeps growing (unwrapped), the answer stays in [-pi, pi)
    for k in range(2, 200):
        h.push(float(k), [0.0, 0.0, (k * 1.0 + math.pi) % (2 * math.pi) - math.pi])
    assert h.newest()[2] > 100.0
    assert -math.pi <= h.at(190.5)[2] < math.pi
    assert h.at(190.5)[2] == pytest.approx((190.5 + math.pi) % (2 * math.pi) - math.pi, abs=1e-9)


def test_bad_sizes_are_refused():
    with pytest.raises(ValueError, match="n >= 1"):
        History(3, n=0)
