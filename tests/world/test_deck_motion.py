"""Deck motion (seed 003 eq. 5.11) and light layouts (eq. 5.10)."""

import numpy as np
import pytest

from visnav.geometry.rotations import euler_to_dcm
from visnav.world.deck import LEDS_EQ_5_10, DeckMotion, validate_lights


def test_sum_of_sinusoids_and_its_derivatives():
    rng = np.random.default_rng(0)
    m = DeckMotion.from_sea_state("stewart", rng, n_sinusoids=3, heading=0.4)
    t, h = 3.7, 1e-6
    d, dd = m.displacement(t)
    want = np.sum(m.a * np.sin(m.w * t + m.ph), axis=1)
    np.testing.assert_allclose(d, want)
    np.testing.assert_allclose(dd, (m.displacement(t + h)[0] - m.displacement(t - h)[0]) / (2 * h), atol=1e-7)
    s0, s1, s2 = m.state(t - h), m.state(t), m.state(t + h)
    np.testing.assert_allclose(s1.velocity, (s2.position - s0.position) / (2 * h), atol=1e-7)
    # body rates: dC/dt = C skew(w)
    Cdot = (s2.C - s0.C) / (2 * h)
    W = s1.C.T @ Cdot
    np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], s1.body_rates, atol=1e-6)
    np.testing.assert_allclose(s1.C, euler_to_dcm(s1.euler))
    assert s1.euler[2] == pytest.approx(0.4 + d[5])


def test_static_deck_does_not_move_and_limits():
    m = DeckMotion.static(position=(1.0, 2.0, 0.0))
    s = m.state(12.3)
    np.testing.assert_array_equal(s.position, [1.0, 2.0, 0.0])
    np.testing.assert_array_equal(s.body_rates, 0.0)
    with pytest.raises(ValueError, match="at most 3"):
        DeckMotion(np.ones((6, 4)), np.ones((6, 4)), np.ones((6, 4)))
    with pytest.raises(ValueError, match="unknown sea state"):
        DeckMotion.from_sea_state("hurricane", np.random.default_rng(0))


def test_light_layouts():
    np.testing.assert_allclose(LEDS_EQ_5_10[0], [-0.128, 0, 0])
    assert validate_lights(LEDS_EQ_5_10).shape == (4, 3)
    with pytest.raises(ValueError, match="at least 3"):
        validate_lights([[0, 0, 0], [0.1, 0, 0]])
    with pytest.raises(ValueError, match="closer than"):
        validate_lights([[0, 0, 0], [0, 0, 0], [0.1, 0, 0]])
    with pytest.raises(ValueError, match="finite"):
        validate_lights([[0, 0, 0], [np.nan, 0, 0], [0.1, 0, 0]])


def test_state_kept_for_one_instant_is_read_only_and_equals_a_fresh_evaluation():
    """The loop, the camera and the observer ask for the same instant: one evaluation, read-only arrays."""
    m = DeckMotion.from_sea_state("stewart", np.random.default_rng(3), n_sinusoids=2, heading=0.2)
    fresh = DeckMotion(m.a, m.w, m.ph, m.p0, m.heading)
    s = m.state(1.25)
    assert m.state(1.25) is s
    with pytest.raises(ValueError):
        s.position[0] = 0.0
    m.state(1.26)
    for a, b in ((m.state(1.25), fresh.state(1.25)), (m.state(1.26), fresh.state(1.26))):
        for k in ("position", "velocity", "euler", "body_rates", "C"):
            np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
