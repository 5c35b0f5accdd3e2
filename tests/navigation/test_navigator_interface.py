"""PALACE, WITAS and the pad navigator offer the one Navigator interface (navigation/base.py)."""

from __future__ import annotations

import numpy as np
import pytest

from visnav.app.navigators import make_navigator
from visnav.measurements import AttitudeSample, GpsSample, ImuSample, NavCommand, NavInit
from visnav.navigation.base import Navigator
from visnav.scenarios.schema import load_scenario


def _palace():
    return make_navigator("palace", load_scenario("palace-landing"))


def test_palace_estimate_is_propagated_to_t_without_changing_the_filter():
    nav = _palace()
    nav.update(AttitudeSample(0.0, np.zeros(3)))
    nav.update(GpsSample(0.0, np.array([1.0, 2.0, -30.0]), np.array([2.0, 0.0, 0.0])))
    f = np.array([0.5, 0.0, -9.81])  # body specific force, level: 0.5 m/s^2 north
    for k in range(1, 11):
        nav.update(ImuSample(0.01 * k, f, np.zeros(3)))
    ft, p, v, a = nav.filter.t, nav.filter.p.copy(), nav.filter.v.copy(), nav.filter.accel.copy()
    assert ft == pytest.approx(0.1) and a[0] == pytest.approx(0.5, abs=1e-9)
    dt = 0.037
    e = nav.estimate(ft + dt)
    np.testing.assert_allclose(e.position, p + v * dt + 0.5 * a * dt * dt, rtol=0, atol=1e-12)
    np.testing.assert_allclose(e.velocity, v + a * dt, rtol=0, atol=1e-12)
    assert e.position[0] - p[0] > v[0] * dt  # the acceleration is in it
    assert nav.filter.t == ft and np.array_equal(nav.filter.p, p)  # the filter did not move
    assert np.array_equal(nav.estimate(ft).position, p)


def test_palace_commands_and_unknown_ones():
    nav = _palace()
    assert isinstance(nav, Navigator)
    nav.command(NavCommand(1.0, "set-source", {"source": "mpe"}))
    assert nav.health(1.0).source == "mpe"
    nav.command(NavCommand(1.0, "request-tracking", {"target_ned": [0.0, 0.0, 0.0], "init_from": "gps"}))
    assert nav.health(1.0).tracking_pending
    with pytest.raises(ValueError, match="no command 'fly'; known: request_tracking, request_tracking_rebase, set_source, stop_tracking"):
        nav.command(NavCommand(1.0, "fly", {}))
    with pytest.raises(ValueError, match="unknown navigation source"):
        nav.command(NavCommand(1.0, "set-source", {"source": "magic"}))


@pytest.mark.parametrize("name", ["palace", "witas"])
def test_initialize_starts_the_filter_at_the_given_pose(name):
    sc = load_scenario({"palace": "palace-landing", "witas": "witas-homing"}[name])
    nav = make_navigator(name, sc)
    assert not nav.estimate(0.0).valid
    nav.initialize(NavInit(0.0, "survey", position=np.array([3.0, -4.0, -20.0]), velocity=np.array([1.0, 0, 0]),
                           attitude=np.array([0.0, 0.0, 0.5])))
    e = nav.estimate(0.0)
    assert e.valid and np.array_equal(e.position, [3.0, -4.0, -20.0]) and e.attitude[2] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="position"):
        nav.initialize(NavInit(0.0, "survey"))


def test_pad_navigator_needs_its_pan_tilt_unit():
    with pytest.raises(ValueError, match="pan-tilt unit"):
        make_navigator("pad", load_scenario("pad-landing"))


def test_a_builders_nav_init_is_logged_and_sent(monkeypatch):
    """A NavInit in the parts reaches the navigator before the first step and is logged (stream nav_init)."""
    from visnav.app import missions
    from visnav.app.loop import Simulation

    orig = missions.REGISTRY["palace"]

    def with_init(ctx):
        parts = orig(ctx)
        parts.nav_init = NavInit(0.0, "survey", position=parts.vehicle.state.position + [0.5, 0, 0],
                                 velocity=np.zeros(3))
        return parts

    monkeypatch.setitem(missions.REGISTRY, "palace", with_init)
    sim = Simulation(load_scenario("palace-landing", ["run.duration_s=0.35"]))
    res = sim.run()
    log = res.log.get("nav_init")
    assert list(log["source"]) == ["survey"] and np.isnan(log["attitude"][0]).all()
    est = res.log.get("estimate")
    assert bool(est["valid"][0])  # before the first GPS fix: started by the NavInit
    np.testing.assert_allclose(est["position"][0], log["position"][0], atol=1e-9)
