"""Integrity metrics from the log (analysis/integrity_metrics.py) and the fault campaign's table."""

from __future__ import annotations

import math

import numpy as np
import pytest

from visnav.app.fault_campaign import FAULT_SETS, fault_row, faults_for
from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.scenarios.schema import load_scenario
from visnav.flightlog import FlightLog
from visnav.sim.streams import RMAX_STREAMS


def _log(codes, errs, hpls, touchdown=None):
    log = FlightLog(schema=RMAX_STREAMS)
    for k, (c, e, h) in enumerate(zip(codes, errs, hpls)):
        t = 0.1 * k
        log.record("truth", t, position=np.array([e, 0.0, -5.0]), velocity=np.zeros(3), euler=np.zeros(3),
                   body_rates=np.zeros(3))
        log.record("estimate", t, position=np.array([0.0, 0.0, -5.0]), velocity=np.zeros(3), euler=np.zeros(3),
                   source="gps", valid=True)
        log.record("status", t, mode="m", source="gps", coherence=1.0, mpe_rate_hz=10.0, laser_ok=True,
                   tracking=True, integrity=c, hpl_m=h, k2=1.0)
    prev = None
    for k, c in enumerate(codes):
        if c != prev:
            log.record("integrity_event", 0.1 * k, state=c, reason="r", hpl=hpls[k])
            prev = c
    if touchdown is not None:
        log.record("touchdown", 0.1 * len(codes), position=np.array(touchdown[0]), speed=touchdown[1])
    return log


def test_metrics_count_violations_states_and_detection(tmp_path):
    codes = [2] + [0] * 49 + [1] * 10 + [2] * 10 + [0] * 30  # 100 steps of 0.1 s
    errs = [0.1] * 100
    errs[10] = errs[20] = 0.6  # two violations while ok (HPL 0.5)
    errs[55] = 5.0  # large but not ok: not a violation
    hpl = [0.5] * 100
    sc = load_scenario("palace-landing", ["faults=[{kind='camera_blackout', start_s=4.5, duration_s=2.0}]"])
    log = _log(codes, errs, hpl, touchdown=([0.4, 0.3, 0.0], 0.5))
    m = integrity_metrics(log, sc)
    assert m["hpl_bound_violations"] == 2 and m["hpl_samples_ok"] == 79
    assert m["integrity_time_ok_s"] == pytest.approx(7.8, abs=1e-9)  # 79 ok steps, the last has no duration
    assert m["integrity_time_degraded_s"] == pytest.approx(1.0) and m["integrity_time_unusable_s"] == pytest.approx(1.1)
    assert m["faults_injected"] == 1 and m["faults_detected"] == 1
    assert m["detection_delay_s"] == pytest.approx(0.5)  # degraded at 5.0 s, fault at 4.5 s
    assert m["false_alarms"] == 0 and m["worst_error_while_ok_m"] == pytest.approx(0.6)
    assert m["outcome"] == "safe"  # 0.5 m from the point at 0.5 m/s
    # the same from log.h5
    p = tmp_path / "log.h5"
    log.to_hdf5(p)
    again = integrity_metrics(FlightLog.from_hdf5(p), sc)
    assert again.keys() == m.keys()
    for k, v in m.items():
        assert again[k] == v or (isinstance(v, float) and math.isnan(v) and math.isnan(again[k]))


def test_outcome_unsafe_landing_and_false_alarm_outside_the_window():
    sc = load_scenario("palace-landing")
    codes = [0] * 20 + [1] * 5 + [0] * 5
    m = integrity_metrics(_log(codes, [0.1] * 30, [1.0] * 30, touchdown=([1.2, 0.0, 0.0], 0.4)), sc)
    assert m["outcome"] == "unsafe" and "1.20 m" in m["outcome_reason"]
    assert m["false_alarms"] == 1 and m["false_alarm_actions"] == 0
    m = integrity_metrics(_log([0] * 10, [0.1] * 10, [1.0] * 10, touchdown=([0.1, 0.0, 0.0], 1.5)), sc)
    assert m["outcome"] == "unsafe"  # too fast


def test_fault_row_aggregates_runs():
    rows = [{"status": "ok", "outcome": "safe", "faults_injected": "1", "faults_detected": "1",
             "detection_delay_s": "0.5", "false_alarms": "0", "false_alarm_actions": "0",
             "worst_error_while_ok_m": "0.2", "hpl_bound_violations": "0", "hpl_samples_ok": "600"},
            {"status": "ok", "outcome": "unsafe", "faults_injected": "1", "faults_detected": "0",
             "detection_delay_s": "", "false_alarms": "2", "false_alarm_actions": "1",
             "worst_error_while_ok_m": "3.0", "hpl_bound_violations": "3", "hpl_samples_ok": "200"},
            {"status": "ok", "outcome": "safe", "faults_injected": "1", "faults_detected": "1",
             "detection_delay_s": "1.5", "false_alarms": "0", "false_alarm_actions": "0",
             "worst_error_while_ok_m": "0.1"}]
    r = fault_row("x", rows)
    assert r["runs"] == 3 and r["detected_share"] == pytest.approx(2 / 3)
    assert r["detection_delay_s"] == pytest.approx(1.0) and r["false_alarms"] == 1 and r["navigator_alarms"] == 2
    assert (r["safe"], r["unsafe"]) == (2, 1) and r["worst_error_while_ok_m"] == 3.0
    assert r["over_hpl_while_ok_pct"] == pytest.approx(100 * 3 / 800)  # the third run has no HPL samples


def test_fault_sets_validate_and_unknown_names_are_one_line():
    for scen in ("palace-landing", "witas-homing", "pad-landing", "deck-static", "deck-moving", "condor-orbit"):
        for d in faults_for(scen, [], ["all"]):  # every definition is a valid fault of that mission
            from visnav.app.fault_campaign import _toml_inline

            load_scenario(scen, [f"faults=[{_toml_inline(d)}]"])
    assert len(faults_for("witas-homing", [], ["all"])) == len(FAULT_SETS["witas-homing"])
    with pytest.raises(ValueError, match="unknown fault volcano"):
        faults_for("palace-landing", [], ["volcano"])
    with pytest.raises(ValueError, match="no fault set"):
        faults_for("pfcm-segment", [], ["all"])
    assert faults_for("deck-static", [], ["all"]) == FAULT_SETS["deck"]  # the two deck scenarios share it


def _deck_log(touchdown):
    from visnav.sim.streams import DECK_STREAMS

    log = FlightLog(schema=DECK_STREAMS)
    for k in range(10):
        log.record("status", 0.1 * k, mode="approach", source="camera", integrity=0, hpl_m=0.05, k2=1.0)
    if touchdown is not None:
        d, v, on = touchdown
        log.record("touchdown", 1.0, rel_speed=v, pos_err=d, on_deck=on, att_mismatch=1.0)
    return log


@pytest.mark.parametrize("touchdown,outcome", [
    ((0.05, 0.4, True), "safe"), ((0.05, 1.2, True), "unsafe"), ((0.25, 0.4, False), "unsafe"),
    ((1.1, 0.4, True), "unsafe"), (None, "safe")])
def test_deck_outcome_from_the_touchdown(touchdown, outcome):
    m = integrity_metrics(_deck_log(touchdown), load_scenario("deck-moving"))
    assert m["outcome"] == outcome, m["outcome_reason"]


def test_condor_outcome_orbit_radius_while_ok():
    from visnav.sim.streams import CONDOR_STREAMS

    sc = load_scenario("condor-orbit")  # 110 m orbit, vision from 60 s, 40 s transition
    def log_with(radius_at, code_at):
        log = FlightLog(schema=CONDOR_STREAMS)
        for k in range(0, 2000):
            t = 0.1 * k
            r = radius_at(t)
            log.record("truth", t, position=np.array([r, 0.0, -100.0]), velocity=np.zeros(3), euler=np.zeros(3),
                       body_rates=np.zeros(3), airspeed=18.0, beta=0.0)
            log.record("status", t, mode="gps_loiter" if t < 60 else "vision_orbit", source="vision",
                       integrity=code_at(t), hpl_m=20.0, k2=1.0)
        return log
    far = lambda t: 150.0 if 120 <= t < 125 else 112.0  # noqa: E731  (40 m off for 5 s)
    m = integrity_metrics(log_with(far, lambda t: 0), sc)
    assert m["outcome"] == "unsafe" and "40.0 m off" in m["outcome_reason"]
    m = integrity_metrics(log_with(far, lambda t: 2 if 119 <= t < 126 else 0), sc)  # not claiming ok there
    assert m["outcome"] == "safe" and "2.0 m" in m["outcome_reason"]
    early = lambda t: 150.0 if 70 <= t < 75 else 112.0  # noqa: E731  (inside the transition: not scored)
    assert integrity_metrics(log_with(early, lambda t: 0), sc)["outcome"] == "safe"


def test_a_deck_run_logs_and_scores_its_integrity():
    from visnav.app.loop import Simulation

    r = Simulation(load_scenario("deck-moving", ["run.seed=2"])).run()
    st = r.log.get("status")
    assert st is not None and np.all(np.isfinite(st["hpl_m"][st["integrity"] == 0]))
    m = r.metrics
    assert m["hpl_samples_ok"] > 500 and m["hpl_bound_violations"] <= m["hpl_samples_ok"] // 1000
    assert m["outcome"] == "safe" and m["faults_injected"] == 0
    # the relative-position error compared with the HPL: that of the logged deck-frame estimate
    tr, es = r.log.get("truth"), r.log.get("estimate")
    e = np.hypot(*(es["position"][:, :2] - tr["position"][:, :2]).T)
    ok = (st["integrity"] == 0) & np.isfinite(e)
    assert m["worst_error_while_ok_m"] == pytest.approx(float(e[ok].max()))
