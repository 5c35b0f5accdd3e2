"""Integrity in the navigators' health (issue #18), driven from plain lists of measurements, and the
missions' reactions to it."""

from __future__ import annotations

import math

import numpy as np

from visnav.navigation.base import CommandDispatch
import pytest

from visnav.estimation.integrity import horizontal_protection_level
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.measurements import AttitudeSample, GpsSample, Health, ImuSample, NavEstimate
from visnav.navigation.palace import PalaceNavigator
from visnav.scenarios.schema import NavigationConfig
from visnav.flightlog import FlightLog


def _palace(gps_offset=lambda t: 0.0, t_end=6.0, gps_until=math.inf, seed=0):
    rng = np.random.default_rng(seed)
    log = FlightLog()
    nav = PalaceNavigator(NavigationConfig(), PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0),
                          recorder=log.record)
    states = []
    for k in range(int(t_end * 100) + 1):
        t = 0.01 * k
        nav.update(AttitudeSample(t=t, euler=np.zeros(3)))
        nav.update(ImuSample(t=t, accel=np.array([0.0, 0.0, -9.81]), gyro=np.zeros(3)))
        if k % 10 == 0 and t < gps_until:
            nav.update(GpsSample(t=t, position=np.array([gps_offset(t), 0.0, -10.0]) +
                                 np.r_[rng.normal(0, 0.02, 2), 0.0], velocity=np.zeros(3), sigma=0.02))
        if k % 10 == 5:
            h = nav.health(t)
            states.append((t, h.integrity, h.integrity_reason, h.hpl_m, nav.filter.covariance()[:2, :2]))
    return nav, states, log


def test_palace_is_ok_with_honest_gps_and_its_hpl_is_the_covariance_bound():
    nav, states, _ = _palace()
    assert all(s == "ok" for _, s, *_ in states[5:])
    t, s, _, hpl, P = states[-1]
    assert hpl == pytest.approx(horizontal_protection_level(P, 0.999, nav.health(t).consistency_k2), rel=1e-12)
    assert 0.0 < hpl < 0.1


def test_palace_gps_jump_is_degraded_then_gps_loss_unusable():
    _, states, log = _palace(gps_offset=lambda t: 1.0 if t >= 3.0 else 0.0)
    before = [s for t, s, *_ in states if t < 3.0 and t > 0.5]
    after = [(s, r) for t, s, r, *_ in states if 3.2 < t < 4.0]
    assert set(before) == {"ok"}
    assert after and after[0][0] == "degraded" and "gps NIS" in after[0][1]
    _, states, _ = _palace(gps_until=3.0, t_end=5.0)
    late = {t: (s, r) for t, s, r, *_ in states}
    assert late[3.45][0] != "unusable" and late[4.25][0] == "unusable"  # stale_s = 1 s after the last fix
    assert "no accepted update" in late[4.25][1]
    ev = log.get("integrity_event")
    assert ev and 1 in set(ev["state"])


def _health(state):
    return Health(source="vision", integrity=state, integrity_reason=f"test {state}")


def test_pad_mission_goes_around_high_and_lands_on_dead_reckoning_low():
    from visnav.mission.pad import PadLandingMission
    from visnav.scenarios.config_pad import PadMissionConfig

    def nav(h):
        return NavEstimate(t=0.0, position=np.array([0.5, 0.0, -h]), velocity=np.zeros(3), attitude=np.zeros(3))

    m = PadLandingMission(PadMissionConfig(start_ne_m=[0.5, 0.0], start_height_m=10.0, settle_s=0.0))
    t = 0.0
    for _ in range(5):
        m.step(t, nav(8.0), _health("ok"))
        t += 0.1
    assert m.mode == "approach"
    for _ in range(7):  # 0.6 s unusable at 8 m
        ref, mode = m.step(t, nav(8.0), _health("unusable"))
        t += 0.1
    assert mode == "go-around" and m.go_arounds == 1
    z0 = ref.position[2]
    for _ in range(10):
        ref, mode = m.step(t, nav(8.0), _health("ok"))
        t += 0.1
    assert ref.position[2] < z0 - 0.5  # climbing back
    low = PadLandingMission(PadMissionConfig(start_ne_m=[0.5, 0.0], start_height_m=2.0, settle_s=0.0,
                                             gate_height_m=0.0))
    t = 0.0
    for _ in range(3):
        low.step(t, nav(1.5), _health("ok"))
        t += 0.1
    for _ in range(10):
        _, mode = low.step(t, nav(1.5), _health("unusable"))
        t += 0.1
    assert mode in ("approach", "blind") and low.go_arounds == 0 and low._dr_logged


class _Nav(CommandDispatch):
    """A navigator stand-in that takes the mission's commands and does nothing with them."""

    source = "gps"
    tracking_pending = False

    def _cmd_request_tracking(self, t, **k):
        pass

    def _cmd_set_source(self, t, source):
        self.source = source

    def _cmd_stop_tracking(self, t):
        pass


def test_palace_mission_aborts_on_gps_when_unusable_for_a_second():
    from visnav.mission.palace import PalaceMission
    from visnav.scenarios.schema import PalaceMissionConfig

    m = PalaceMission(PalaceMissionConfig(settle_s=0.5), _Nav())
    nav = NavEstimate(t=0.0, position=m.start_position(), velocity=np.zeros(3), attitude=np.zeros(3))
    t = 0.0
    for _ in range(10):
        m.step(t, nav, _health("ok"))
        t += 0.1
    for _ in range(9):
        m.step(t, nav, _health("unusable"))
        t += 0.1
    assert m.mode != "abort"
    for _ in range(3):
        m.step(t, nav, _health("unusable"))
        t += 0.1
    assert m.mode == "abort" and m.aborted
    assert m.abort_hold[2] == pytest.approx(nav.position[2] - 5.0)
