"""The geo-location navigator driven from a plain list of the messages it received in the closed loop
(operator click, frames, telemetry) gives the closed loop's estimates: nothing else reaches it.

Bit for bit: the registration's arithmetic does not depend on where its buffers lie (the edge
magnitude was ``cv2.magnitude``, whose IPP result depended on its output's address: ~1e-8 m between
two feeds of the same messages; ``vision/geolocation_registration.sobel_edges``); a dropped frame
changes the estimate (second test)."""

from __future__ import annotations

import numpy as np

from visnav.scenarios.schema import load_scenario
from visnav.app.loop import Simulation
from visnav.app.missions import make_simulation


class _Capture:
    """Forwards everything to the navigator and keeps the messages given to ``update``."""

    def __init__(self, nav):
        self._nav = nav
        self.messages: list = []

    def update(self, m) -> None:
        self.messages.append(m)
        self._nav.update(m)

    def __getattr__(self, name):
        return getattr(self._nav, name)


def _state(nav, t):
    out = []
    for method in ("registration", "map_based"):
        e = nav.estimate(t, method)
        out.append((e.valid, np.asarray(e.position, float), np.asarray(e.covariance, float), e.samples))
    return out


def test_geolocation_navigator_from_a_list_equals_the_closed_loop():
    sc = load_scenario("mav-geolocation", ["run.duration_s=30"])
    caps: list[_Capture] = []
    sim = Simulation(sc, navigator_wrapper=lambda nav: caps.append(_Capture(nav)) or caps[0])
    cap = caps[0]
    res = sim.run()
    assert res.error is None, res.error
    kinds = {type(m).__name__ for m in cap.messages}
    assert {"Frame", "OperatorClick"} <= kinds and len(cap.messages) > 50, kinds
    fresh = make_simulation(sc).nav  # the same navigator, built and never fed
    for m in cap.messages:
        fresh.update(m)
    t = float(cap.messages[-1].t)
    live, again = _state(cap._nav, t), _state(fresh, t)
    assert live[0][0], "the registration estimate never started: the comparison would be empty"
    for (v0, p0, c0, n0), (v1, p1, c1, n1) in zip(live, again):
        assert v0 == v1 and n0 == n1
        np.testing.assert_array_equal(p1, p0)
        np.testing.assert_array_equal(c1, c0)
    assert len(fresh.samples) == len(cap._nav.samples) > 0
    for a, b in zip(cap._nav.samples, fresh.samples):
        for k in ("reg", "est_reg", "peak", "second", "quality", "uv", "heading_used"):
            np.testing.assert_array_equal(b[k], a[k], err_msg=k)


def test_dropped_messages_change_the_estimate():
    """The comparison can fail: the same list without every other frame does not reproduce the estimate
    (a single dropped frame does not: the tracker carries over it)."""
    sc = load_scenario("mav-geolocation", ["run.duration_s=30"])
    caps: list[_Capture] = []
    sim = Simulation(sc, navigator_wrapper=lambda nav: caps.append(_Capture(nav)) or caps[0])
    cap = caps[0]
    sim.run()
    t_end = float(cap.messages[-1].t)
    fresh = make_simulation(sc).nav
    frames = 0
    for m in cap.messages:
        if type(m).__name__ == "Frame":
            frames += 1
            if frames % 2 == 0:
                continue
        fresh.update(m)
    a, b = _state(cap._nav, t_end)[0], _state(fresh, t_end)[0]
    assert a[3] != b[3] or not np.allclose(a[1], b[1], rtol=0, atol=1e-6)
