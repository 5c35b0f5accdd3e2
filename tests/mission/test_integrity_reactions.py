"""Deck and CONDOR missions acting on the navigator's integrity (issue #18): each rule fires when it should,
is logged with its reason, and does not fire for a shorter outage or inside the commit window."""

from __future__ import annotations

import numpy as np

from visnav.measurements import Health, NavCommand
from visnav.navigation.deck import DeckEstimate, DeckHealth
from visnav.scenarios.schema import load_scenario
from visnav.sim.log import FlightLog


class _StubNav:
    def __init__(self):
        self.commands = []

    def command(self, c):
        self.commands.append(c)

    def initialize(self, i):
        pass

    def estimate(self, t):
        return _fw()


def _est():
    x = np.r_[1.0, 0.0, 1.5, np.zeros(9)]  # the deck seen from the vehicle (as tests/sim/test_deck_architecture.py)
    return DeckEstimate(t=0.0, state=x, covariance=np.eye(12), gyro=np.zeros(3),
                        accel=np.array([0.0, 0.0, -9.81]), roll=0.0, pitch=0.0)


def _deck_in_approach():
    from visnav.mission.deck import DeckMission

    sc = load_scenario("deck-moving")
    cfg = sc.mission
    log = FlightLog()
    m = DeckMission(cfg, _StubNav(), hold_point=[-1.0, 0.0, -1.5], gear_offset=0.17, period_s=0.02,
                    recorder=log.record, filter_cfg=sc.navigation)
    g = cfg.guidance
    t = cfg.start.manual_s
    m.step(t, _est(), DeckHealth(converged=True, integrity="ok"))
    assert m.mode == "hover"
    # the start conditions (late: max_wait_s) hold but the navigator is unusable: the hover holds
    t += max(g.hover_min_s, g.max_wait_s) + 0.1
    m.step(t, _est(), DeckHealth(converged=True, integrity="unusable", integrity_reason="no frame"))
    assert m.mode == "hover"
    t += 0.02
    m.step(t, _est(), DeckHealth(converged=True, integrity="ok"))
    assert m.mode == "approach"
    return m, cfg, log, t


def _run(m, t, dt, n, state):
    for _ in range(n):
        t += dt
        m.step(t, _est(), DeckHealth(converged=True, integrity=state, integrity_reason=f"test {state}"))
    return t


def test_deck_goes_around_on_an_unusable_navigator_during_the_approach():
    m, cfg, log, t = _deck_in_approach()
    g = cfg.guidance
    assert m.approach.T > g.integrity_commit_s + 2 * g.integrity_unusable_s
    t = _run(m, t, 0.1, 4, "unusable")  # the first unusable step starts the clock: 0.3 s < 0.5 s
    assert m.mode == "approach"
    t = _run(m, t, 0.1, 3, "unusable")  # 0.6 s
    assert m.mode == "hover"
    r = log.get("integrity_reaction")
    assert list(r["action"]) == ["hold", "go-around"] and "no frame" in r["reason"][0]
    assert "go-around 1" in log.get("mode")["reason"][-1]


def test_deck_lands_on_in_the_commit_window():
    m, cfg, log, t = _deck_in_approach()
    g = cfg.guidance
    t0 = m.t_mode
    t = _run(m, t, 0.1, int((m.approach.T - g.integrity_commit_s - (t - t0)) / 0.1) + 1, "ok")
    assert m.mode == "approach" and m.approach.T - (t - t0) < g.integrity_commit_s
    _run(m, t, 0.1, 7, "unusable")
    assert m.mode == "approach"  # inside the last integrity_commit_s: no go-around
    assert list(log.get("integrity_reaction")["action"]) == ["hold"]


def _fw():
    from visnav.measurements import FixedWingEstimate

    return FixedWingEstimate(t=0.0, position=np.array([110.0, 0.0, -100.0]), velocity=np.array([0.0, 20.0, 0.0]),
                             attitude=np.zeros(3), radius=110.0, radius_rate=0.0, radius_valid=True,
                             ground_speed=20.0, airspeed=20.0)


def test_condor_falls_back_to_the_gps_loiter_and_returns_after_ok():
    from visnav.mission.condor import CondorMission

    sc = load_scenario("condor-orbit")
    cfg = sc.mission
    o = cfg.control.orbit
    log = FlightLog()
    nav = _StubNav()
    m = CondorMission(cfg, nav, airspeed_mps=sc.vehicle.airspeed_mps, recorder=log.record)
    t = o.switch_time_s
    h = lambda s: Health(source="vision", tracking=True, integrity=s, integrity_reason=f"test {s}")
    m.step(t, _fw(), h("ok"))
    assert m.mode == "vision_orbit" and nav.commands[-1] == NavCommand(t, "set_source", {"source": "vision"})
    for k in range(int(o.integrity_unusable_s / 0.1)):  # unusable just under integrity_unusable_s: stays
        m.step(t + 0.1 * (k + 1), _fw(), h("unusable"))
    assert m.mode == "vision_orbit"
    t += o.integrity_unusable_s + 0.2
    m.step(t, _fw(), h("unusable"))
    assert m.mode == "gps_loiter" and nav.commands[-1].args == {"source": "gps"}
    assert log.get("integrity_reaction")["action"][-1] == "fallback to GPS"
    # ok again, but not yet for integrity_ok_s: stays on GPS; then vision again
    m.step(t + 0.1, _fw(), h("ok"))
    m.step(t + 0.1 + 0.5 * o.integrity_ok_s, _fw(), h("ok"))
    assert m.mode == "gps_loiter"
    m.step(t + 0.2 + o.integrity_ok_s, _fw(), h("ok"))
    assert m.mode == "vision_orbit" and m.switched_at == o.switch_time_s
    assert log.get("integrity_reaction")["action"][-1] == "back to vision"
