"""Each R-MAX navigator (PALACE, WITAS, pad landing) driven from a plain list of messages gives the estimates
it gave inside the closed loop.

A short closed-loop run captures, in order, every message the loop and the mission sent to the navigator
(``update(m)``, ``command(NavCommand)``, ``initialize(NavInit)``) and every ``estimate(t)`` / ``health(t)``
query with its answer (``Simulation(navigator_wrapper=...)``). A fresh navigator of the same scenario, fed the
list with no simulation object around it, must answer every estimate query the same to 1e-9.
"""

from __future__ import annotations

import numpy as np
import pytest

from visnav.navigation.base import Navigator
from visnav.scenarios.schema import load_scenario
from visnav.flightlog import FlightLog
from visnav.app.missions import BuildContext, build


class Capture:
    """Passes everything to the navigator and keeps the list of what it was sent and asked."""

    def __init__(self, inner):
        self.inner, self.events = inner, []

    def update(self, m):
        self.events.append(("update", m))
        self.inner.update(m)

    def command(self, request):
        self.events.append(("command", request))
        self.inner.command(request)

    def initialize(self, init):
        self.events.append(("initialize", init))
        self.inner.initialize(init)

    def estimate(self, t):
        e = self.inner.estimate(t)
        self.events.append(("estimate", t, e))
        return e

    def health(self, t=None):
        self.events.append(("health", t))
        return self.inner.health(t)


def _fly(name, sets):
    from visnav.app.loop import Simulation

    sc = load_scenario(name, sets)
    caps = []
    sim = Simulation(sc, navigator_wrapper=lambda nav: caps.append(Capture(nav)) or caps[-1])
    res = sim.run()
    assert res.error is None
    return sc, caps[0].events


def _replay(sc, events):
    nav = build(BuildContext(sc, FlightLog().record)).navigator  # a fresh one, as the scenario builds it
    assert isinstance(nav, Navigator)
    worst, n, counts = 0.0, 0, {}
    for ev in events:
        counts[ev[0]] = counts.get(ev[0], 0) + 1
        if ev[0] == "update":
            nav.update(ev[1])
        elif ev[0] == "command":
            nav.command(ev[1])
        elif ev[0] == "initialize":
            nav.initialize(ev[1])
        elif ev[0] == "health":
            nav.health(ev[1])
        else:
            t, want = ev[1], ev[2]
            got = nav.estimate(t)
            assert got.valid == want.valid and got.source == want.source
            if want.valid:
                for a, b in ((got.position, want.position), (got.velocity, want.velocity),
                             (got.attitude, want.attitude)):
                    worst = max(worst, float(np.max(np.abs(np.asarray(a) - np.asarray(b)))))
                n += 1
    return worst, n, counts


def test_palace_from_a_list():
    """Through the MPE switch at 12 m (tracking request, re-base, source switch)."""
    sc, events = _fly("palace-landing", ["run.duration_s=10.5", "mission.start_height_m=14"])
    worst, n, counts = _replay(sc, events)
    assert counts["command"] >= 3 and counts["update"] > 1000
    assert n >= 90 and worst <= 1e-9
    assert {e[2].source for e in events if e[0] == "estimate"} >= {"gps", "mpe"}


def test_witas_from_a_list():
    """GPS lost at 3 s: odometry, registration and the PMF from there."""
    sc, events = _fly("witas-homing", ["run.duration_s=8", "mission.gps_loss_s=3", "mission.settle_s=2"])
    worst, n, _ = _replay(sc, events)
    assert n >= 70 and worst <= 1e-9
    assert {e[2].source for e in events if e[0] == "estimate"} >= {"gps", "vision"}


def test_pad_from_a_list():
    sc, events = _fly("pad-landing", ["run.duration_s=6"])
    worst, n, _ = _replay(sc, events)
    assert n >= 40 and worst <= 1e-9
    assert "vision" in {e[2].source for e in events if e[0] == "estimate"}


def test_the_comparison_can_fail():
    """A list with one IMU sample dropped gives other estimates: the check sees a difference."""
    sc, events = _fly("pfcm-segment", ["run.duration_s=3"])
    k = next(i for i, e in enumerate(events) if e[0] == "update" and type(e[1]).__name__ == "ImuSample" and i > 500)
    with pytest.raises(AssertionError):
        worst, _, _ = _replay(sc, events[:k] + events[k + 1:])
        assert worst <= 1e-9
