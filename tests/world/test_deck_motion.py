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


def test_state_equals_its_array_form_bit_for_bit():
    """DeckMotion.state reads the attitude's three floats once (euler_to_dcm3 of them, euler_to_dcm's one-vector
    path): every array of the state equals the form that went through euler_to_dcm(euler), to the bit."""
    from visnav.geometry.rotations import euler_rates_to_body_rates

    def reference(m, t):  # DeckMotion.state's arrays before speed round 5
        d, dd = m.displacement(t)
        euler = np.array([d[3], d[4], m.heading + d[5]])
        return (m.p0 + m._Rz @ d[:3], m._Rz @ dd[:3], euler,
                np.asarray(euler_rates_to_body_rates(euler, dd[3:])), euler_to_dcm(euler))

    rng = np.random.default_rng(21)
    for k in range(300):
        n = int(rng.integers(1, 4))
        sea, scale = str(rng.choice(["stewart", "ship_ss4", "calm"])), float(rng.uniform(0.2, 3.0))
        m = DeckMotion.from_sea_state(sea, rng, n, scale, rng.normal(0, 2, 3), float(rng.uniform(-4, 4)))
        if k % 10 == 0:
            m = DeckMotion.static(rng.normal(0, 2, 3), float(rng.choice([0.0, -0.0, 1.0])))
        for t in rng.uniform(0, 60, 5).tolist() + [0.0]:
            s = m.state(t)
            for got, want in zip((s.position, s.velocity, s.euler, s.body_rates, s.C), reference(m, t)):
                assert np.array_equal(got.view(np.int64), want.view(np.int64))


def test_a_tilted_deck_is_its_motion_about_the_list_and_trim():
    """``tilt``: the deck's roll and pitch are the motion's plus the tilt (static: exactly the tilt, the normal
    turned by it), the body rates still dC/dt = C skew(w) of the tilted attitude."""
    tilt = (np.radians(1.5), np.radians(-0.7))
    s = DeckMotion.static(tilt=tilt).state(4.0)
    np.testing.assert_allclose(s.euler, [tilt[0], tilt[1], 0.0], atol=1e-15)
    assert np.degrees(np.arccos(s.C[2, 2])) == pytest.approx(np.degrees(np.arccos(np.cos(tilt[0]) * np.cos(tilt[1]))))
    assert not s.body_rates.any() and not s.velocity.any()
    a = DeckMotion.from_sea_state("stewart", np.random.default_rng(3), heading=0.2)
    b = DeckMotion.from_sea_state("stewart", np.random.default_rng(3), heading=0.2, tilt=tilt)
    t, h = 2.3, 1e-6
    np.testing.assert_allclose(b.state(t).euler - a.state(t).euler, [tilt[0], tilt[1], 0.0], atol=1e-14)
    np.testing.assert_allclose(b.state(t).position, a.state(t).position)
    W = b.state(t).C.T @ (b.state(t + h).C - b.state(t - h).C) / (2 * h)
    np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], b.state(t).body_rates, atol=1e-6)
