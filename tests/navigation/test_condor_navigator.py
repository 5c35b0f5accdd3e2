"""CondorNavigator (navigation/condor.py): driven from a plain list of measurements it gives the estimate
it gave inside the closed loop; its radius integrity; the estimate never sees truth."""

import math

import numpy as np
import pytest

from visnav.measurements import NavCommand, NavInit, TargetRangeSample
from visnav.navigation.base import Navigator
from visnav.navigation.condor import CondorNavigator, RadiusFilter
from visnav.scenarios.schema import load_scenario
from visnav.app.condor_parts import build_navigator
from visnav.app.loop import Simulation


class _Recorder:
    """Wraps a navigator and records every call the loop makes, in order."""

    def __init__(self, nav):
        self.nav, self.events = nav, []

    def update(self, m):
        self.events.append(("update", m))
        self.nav.update(m)

    def initialize(self, init):
        self.events.append(("initialize", init))
        self.nav.initialize(init)

    def command(self, c):
        self.events.append(("command", c))
        self.nav.command(c)

    def estimate(self, t):
        e = self.nav.estimate(t)
        self.events.append(("estimate", t, e))
        return e

    def health(self, t):
        return self.nav.health(t)

    def __getattr__(self, k):
        return getattr(self.nav, k)


def _same(a, b):
    for k in ("position", "velocity", "attitude", "body_rates", "specific_force"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    for k in ("airspeed", "height", "ground_speed", "radius", "radius_rate", "radius_valid", "source", "valid"):
        x, y = getattr(a, k), getattr(b, k)
        assert x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y)), k


def test_plain_list_gives_the_closed_loop_estimate():
    sc = load_scenario("condor-orbit", ["run.duration_s=30", "mission.orbit.switch_time_s=10"])
    recs: list[_Recorder] = []
    sim = Simulation(sc, navigator_wrapper=lambda nav: recs.append(_Recorder(nav)) or recs[0])
    rec = recs[0]
    assert sim.nav is rec and sim.mission.nav is rec
    r = sim.run()
    assert r.error is None, r.error
    ev = rec.events
    kinds = {e[0] for e in ev}
    assert kinds == {"update", "initialize", "command", "estimate"}
    assert any(e[0] == "command" and e[1].name == "set_source" for e in ev)
    assert any(e[0] == "update" and isinstance(e[1], TargetRangeSample) for e in ev)
    # a fresh navigator, no simulation: the same messages in the same order give the same estimates
    nav = build_navigator(sc, sim.camera_model)
    assert isinstance(nav, Navigator)
    n = 0
    for e in ev:
        if e[0] == "update":
            nav.update(e[1])
            nav.pop_uplink()
        elif e[0] == "initialize":
            nav.initialize(e[1])
        elif e[0] == "command":
            nav.command(e[1])
        else:
            _same(nav.estimate(e[1]), e[2])
            # health() reads the position covariance without building an estimate: the same matrix
            np.testing.assert_array_equal(nav._position_cov(e[1]), e[2].covariance)
            n += 1
    assert n > 1500  # 50 Hz control + 10 Hz log over 30 s
    # after the switch the vision range is what the guidance flies on, and it is close to truth
    est = [e[2] for e in ev if e[0] == "estimate" and e[1] > 15.0]
    assert all(x.source == "vision" for x in est)
    tr = r.log.get("truth")
    R_true = np.hypot(tr["position"][:, 0], tr["position"][:, 1])
    logged = r.log.get("estimate")
    sel = logged["t"] > 15.0
    assert np.sqrt(np.mean((logged["radius"][sel] - R_true[sel]) ** 2)) < 3.0


def test_unknown_command_and_missing_survey():
    nav = CondorNavigator(None, None, (15.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="set_source"):
        nav.command(NavCommand(0.0, "fly_home"))
    with pytest.raises(ValueError, match="gps or vision"):
        nav.command(NavCommand(0.0, "set_source", {"source": "lidar"}))
    with pytest.raises(ValueError, match="surveyed"):
        nav.initialize(NavInit(0.0, "survey"))


@pytest.mark.parametrize("noise_pct, state", [(1.0, "ok"), (4.0, "degraded")])
def test_radius_integrity_follows_the_innovations(noise_pct, state):
    """Radius fixes with the noise the navigator assumes (1 %) pass the windowed NIS test; 4x that does not."""
    rng = np.random.default_rng(5)
    nav = CondorNavigator(None, None, (15.0, 0.0, 0.0), radius_sigma_pct=1.0)
    nav.initialize(NavInit(0.0, "survey", position=np.zeros(3)))
    nav.command(NavCommand(0.0, "set_source", {"source": "vision"}))
    for k in range(300):
        t = k / 7.5
        nav.update(TargetRangeSample(t, 110.0 * (1 + noise_pct / 100 * rng.standard_normal()), 0.0, 0.0))
    h = nav.health(300 / 7.5)
    assert h.integrity == state and h.tracking
    nis = h.nis_per_dof["radius"]
    # the steady alpha-beta innovation variance sigma^2 / (1 - alpha) is an approximation: about 1 per dof
    assert (0.5 < nis < 2.0) if state == "ok" else nis > 5.0
    assert nav.health(300 / 7.5 + 5.0).integrity == "unusable"  # no fix for 5 s > 3 s


def test_radius_filter_tracks_a_ramp():
    f = RadiusFilter()
    for k in range(100):
        f.update(k / 7.5, 100.0 + 3.0 * k / 7.5)
    R, Rdot = f.predict(99 / 7.5 + 1.0)
    assert Rdot == pytest.approx(3.0, rel=1e-3) and R == pytest.approx(100 + 3 * (99 / 7.5 + 1.0), abs=0.05)


def test_a_repeated_image_gives_no_radius_fix():
    """issue #18: the ground station makes no fix from a frame bit-identical to the previous one (a frozen
    video link: the camera's noise never repeats an image), so the radius goes stale as with no video."""
    from visnav.measurements import Frame, OperatorClick

    img = np.random.default_rng(0).integers(0, 60, (48, 64, 3), dtype=np.uint8)  # noise, no red tent
    img[..., 2] = 0
    for reject in (True, False):
        nav = CondorNavigator(None, None, (15.0, 0.0, 0.0), reject_repeated_frames=reject)
        nav.update(OperatorClick(0.0, np.array([32.0, 24.0])))
        nav.update(Frame(t=0.1, image=img, index=0))
        assert "frozen" not in nav.last_vision["reason"]
        nav.update(Frame(t=0.2, image=img.copy(), index=1))
        assert ("frozen" in nav.last_vision["reason"]) == reject
        other = img.copy()
        other[0, 0, 0] ^= 1
        nav.update(Frame(t=0.3, image=other, index=2))
        assert "frozen" not in nav.last_vision["reason"]
