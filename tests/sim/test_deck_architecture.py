"""The deck system on the one architecture: the navigator replayed from a plain list of measurements gives the
closed loop's estimates; every metric comes from the log (log.h5 round trip); the mission decides from health."""

import numpy as np
import pytest

from visnav.analysis.deck_metrics import deck_metrics
from visnav.analysis.run_metrics import compute_metrics, metrics_function
from visnav.measurements import DeckReference, NavCommand
from visnav.navigation.deck import DeckHealth, DeckNavConfig, DeckNavigator
from visnav.flightlog import FlightLog
from visnav.app.missions import make_simulation

from tests.deck_ideal import load_ideal_deck


class _Recorder:
    """Wraps a navigator: keeps every message it receives and every estimate it gives, in order."""

    def __init__(self, inner):
        self.inner, self.calls = inner, []

    def update(self, m):
        self.calls.append(("update", m))
        self.inner.update(m)

    def initialize(self, init):
        self.calls.append(("initialize", init))
        self.inner.initialize(init)

    def command(self, request):
        self.calls.append(("command", request))
        self.inner.command(request)

    def estimate(self, t):
        e = self.inner.estimate(t)
        self.calls.append(("estimate", e))
        return e

    def health(self, t):
        h = self.inner.health(t)
        self.calls.append(("health", (t, h)))
        return h

    def __getattr__(self, name):
        return getattr(self.inner, name)


@pytest.mark.parametrize("name, sets", [("deck-static", ["run.duration_s=7"]),
                                        ("deck-moving", ["run.duration_s=9"])])
def test_navigator_from_a_list_of_measurements_gives_the_closed_loop_estimate(name, sets):
    """Static: the eq. 5.12 start and the hand-over command; moving: the Vicon NavInit, hover and approach."""
    from visnav.app.loop import Simulation

    sc = load_ideal_deck(name, sets, seed=2)
    rec: list[_Recorder] = []
    sim = Simulation(sc, navigator_wrapper=lambda nav: rec.append(_Recorder(nav)) or rec[0])
    res = sim.run()
    assert res.error is None, res.error
    calls = rec[0].calls
    assert {k for k, _ in calls} == {"initialize", "update", "command", "estimate", "health"}
    assert any(k == "command" and c.name == "track" for k, c in calls)
    # a fresh navigator fed the same messages (no simulation object anywhere)
    nav = DeckNavigator(DeckNavConfig.from_mission(sc, sim.extras.frame_steps * sc.run.dt_s))
    n_est = 0
    for kind, item in calls:
        if kind in ("update", "initialize", "command"):
            getattr(nav, kind)(item)
        elif kind == "estimate":
            e = nav.estimate(item.t)
            np.testing.assert_allclose(e.state, item.state, rtol=0, atol=1e-9)
            np.testing.assert_allclose(e.covariance, item.covariance, rtol=0, atol=1e-9)
            assert (e.roll, e.pitch) == (item.roll, item.pitch)
            n_est += 1
        else:
            t, h0 = item
            h = nav.health(t)
            assert (h.converged, h.lights_used, h.frames_1s, h.integrity) == (
                h0.converged, h0.lights_used, h0.frames_1s, h0.integrity)
            np.testing.assert_allclose(h.bearing_rms_1s, h0.bearing_rms_1s, rtol=0, atol=1e-12)
    assert n_est > 500
    # the logged estimate is the loop's
    es = res.log.get("estimate")
    np.testing.assert_allclose(es["position"][-1], nav.estimate(es["t"][-1]).state[:3], atol=1e-9)


def test_metrics_come_from_the_log_and_survive_log_h5(tmp_path):
    sc = load_ideal_deck("deck-static", seed=1)
    sim = make_simulation(sc)
    res = sim.run()
    assert res.error is None and res.metrics["landed"]
    path = tmp_path / "log.h5"
    res.log.to_hdf5(path)
    back = FlightLog.from_hdf5(path)
    again = compute_metrics(back, sc, wall_time_s=res.metrics["wall_time_s"], error=None)  # the registry's
    for k, v in res.metrics.items():
        if k == "ate_rmse_m":
            continue
        if isinstance(v, float) and np.isnan(v):
            assert np.isnan(again[k]), k
        else:
            assert again[k] == v and type(again[k]) is type(v), k
    assert metrics_function("deck") is deck_metrics
    # the navigator's counters reach the metrics through the log: blobs it gated out, IMU samples it dropped
    assert res.metrics["blobs_rejected"] == sim.nav.stats.blobs_rejected
    assert res.metrics["imu_dropped"] == sim.nav.stats.imu_dropped == 0


class _StubNav:
    def __init__(self):
        self.commands, self.inits = [], []

    def command(self, c):
        self.commands.append(c)

    def initialize(self, i):
        self.inits.append(i)


def _est(x):
    from visnav.navigation.deck import DeckEstimate

    return DeckEstimate(t=0.0, state=np.asarray(x, float), covariance=np.eye(12), gyro=np.zeros(3),
                        accel=np.array([0.0, 0.0, -9.81]), roll=0.0, pitch=0.0)


def test_mission_hands_over_or_restarts_from_health_alone():
    from visnav.mission.deck import DeckMission

    sc = load_ideal_deck("deck-static")
    cfg, f = sc.mission, sc.navigation
    x = np.r_[1.0, 0.0, 1.0, np.zeros(9)]
    log = FlightLog()
    nav = _StubNav()
    m = DeckMission(cfg, nav, hold_point=[-1.0, 0.0, -1.0], gear_offset=0.17, period_s=0.02, recorder=log.record,
                    filter_cfg=f, deck=sc.world.deck, gains=sc.control.deck)
    ref, mode = m.step(0.0, _est(x), DeckHealth())
    assert (ref.kind, mode) == ("level", "manual")  # the IMU pilot before the hand-over
    t = cfg.start.manual_s
    ref, mode = m.step(t, _est(x), DeckHealth(converged=False))  # check fails: restart from yaw 45
    assert mode == "manual" and nav.commands[-1] == NavCommand(t, "restart", {"yaw_deg": 45.0})
    ref, mode = m.step(2 * t, _est(x), DeckHealth(converged=True))
    assert mode == "approach" and nav.commands[-1].name == "track"
    ref, mode = m.step(2 * t + 1.0, _est(x), DeckHealth(converged=True))
    assert isinstance(ref, DeckReference) and ref.kind == "follow" and np.all(np.isfinite(ref.position))
    assert list(log.get("mode")["mode"]) == ["manual", "manual", "approach"]
    # every hypothesis spent: the run stops with one line
    m2 = DeckMission(cfg, _StubNav(), hold_point=[-1.0, 0.0, -1.0], gear_offset=0.17, period_s=0.02,
                     filter_cfg=f.model_copy(update={"yaw_hypotheses_deg": []}), deck=sc.world.deck,
                     gains=sc.control.deck)
    with pytest.raises(RuntimeError, match="did not converge"):
        m2.step(t, _est(x), DeckHealth(converged=False))
