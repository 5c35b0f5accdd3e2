"""Closed-loop vision + INS pad landing (mission/pad.py, navigation/pad.py): a short landing from 5 m
by default, the full 20 m approach and the 3 s black-out as slow tests (the 20-seed campaign is in
docs/results-pad.md)."""

from __future__ import annotations

import numpy as np
import pytest

from visnav.mission.pad import PadLandingMission
from visnav.scenarios.config_pad import PadMissionConfig
from visnav.scenarios.schema import ScenarioError, load_scenario
from visnav.app.missions import make_simulation

SHORT = ["mission.start_height_m=5.0", "mission.start_ne_m=[1.0, -0.8]", "mission.settle_s=1.0",
         "mission.slow_height_m=3.0", "world.field_size_m=30.0", "run.duration_s=30.0"]


def _fly(overrides, seed=2):
    sim = make_simulation(load_scenario("pad-landing", overrides, seed=seed))
    res = sim.run()
    assert res.error is None, res.error
    return sim, res.metrics


def _check_landing(m, radius=0.5):
    assert m["landed"] is True
    assert m["touchdown_error_m"] < radius
    assert m["touchdown_speed_mps"] <= 0.5
    assert 0.4 <= m["vision_lost_height_m"] <= 1.0  # the pattern leaves the view by geometry
    assert m["blind_time_s"] > 0.5  # the last part on the filter alone
    assert m["position_error_at_touchdown_m"] < 0.1


def test_short_landing_from_5m():
    sim, m = _fly(SHORT)
    _check_landing(m)
    # from 5 m the vision is already precise (the 3x of the issue is over the 20 m approach: slow test)
    assert m["velocity_error_rms_mps"] * 2 < m["vision_velocity_error_rms_mps"]
    assert m["attitude_error_rms_deg"] <= 0.5
    # the vision attitude carries the platform misalignment (1.5, -1.2 deg) as a bias
    assert m["vision_roll_bias_deg"] == pytest.approx(1.5, abs=0.4)
    assert m["vision_pitch_bias_deg"] == pytest.approx(-1.2, abs=0.4)
    vis = sim.log.get("pad_vision")
    assert np.all(np.diff(vis["t"]) > 0) and np.median(np.diff(vis["t"])) == pytest.approx(0.05, abs=1e-6)
    assert set(vis["config"]) >= {2, 3}  # the largest complete configuration, then the smallest


@pytest.mark.slow
def test_landing_from_20m():
    _, m = _fly([], seed=3)
    _check_landing(m)
    assert m["velocity_error_rms_mps"] * 3 < m["vision_velocity_error_rms_mps"]
    assert m["attitude_error_rms_deg"] <= 0.5 < m["vision_attitude_error_rms_deg"]


@pytest.mark.slow
def test_blackout_3s_at_5m():
    sim, m = _fly(["mission.blackout_height_m=5.0", "mission.blackout_s=3.0"], seed=4)
    assert m["landed"] is True and m["touchdown_error_m"] < 1.0
    ft = sim.log.get("frame_truth")
    b = ft["t"][ft["blind"].astype(bool)]
    assert b[-1] - b[0] == pytest.approx(3.0, abs=0.06)


def test_mission_reference_sinks_over_the_pad():
    cfg = PadMissionConfig(start_ne_m=[2.0, 0.0], start_height_m=10.0, settle_s=0.0)
    m = PadLandingMission(cfg)
    from visnav.measurements import Health, NavEstimate

    nav = NavEstimate(t=0.0, position=np.array([2.0, 0.0, -10.0]), velocity=np.zeros(3), attitude=np.zeros(3))
    h = Health(source="vision")
    ref, mode = m.step(0.0, nav, h)
    assert mode == "settle"
    for k in range(1, 60):
        ref, mode = m.step(0.1 * k, nav, h)
    assert mode == "approach"
    assert ref.position[0] == pytest.approx(2.0 - 0.8 * 5.8, abs=0.11) or ref.position[0] == pytest.approx(0.0)
    assert ref.position[2] == pytest.approx(-10.0 + 0.7 * 5.8, abs=0.11)
    h.source = "inertial"
    assert m.step(6.0, nav, h)[1] == "blind"


def test_bad_pad_config_is_one_line():
    with pytest.raises(ScenarioError, match="overlaps"):
        load_scenario("pad-landing", ["world.pad.legs_m=[4.4, 3.0, 1.1, 0.55]"])


def test_gate_holds_until_centred():
    from visnav.measurements import Health, NavEstimate

    cfg = PadMissionConfig(start_ne_m=[0.0, 0.0], start_height_m=2.0, settle_s=0.0, gate_height_m=1.3)
    m = PadLandingMission(cfg)
    h = Health(source="vision")
    off = NavEstimate(t=0.0, position=np.array([0.3, 0.0, -1.3]), velocity=np.zeros(3), attitude=np.zeros(3))
    on = NavEstimate(t=0.0, position=np.array([0.02, 0.0, -1.3]), velocity=np.zeros(3), attitude=np.zeros(3))
    t = 0.0
    for _ in range(60):  # 6 s off-centre: the reference stops at the gate height
        ref, mode = m.step(t, off, h)
        t += 0.1
    assert mode == "gate" and ref.position[2] == pytest.approx(-1.3) and ref.velocity[2] == 0.0
    for _ in range(12):  # centred for 1.2 s: the final descent starts
        ref, mode = m.step(t, on, h)
        t += 0.1
    assert mode == "final-descent"
    ref, _ = m.step(t, on, h)
    assert ref.velocity[2] == pytest.approx(cfg.final_rate_mps)


def _imu_fault(kind, bias):
    return [f'faults=[{{kind = "{kind}", start_s = 3.0, duration_s = 10.0, bias = {bias}}}]']


def test_accelerometer_bias_lands_safely():
    """Issue #18: 0.3 m/s^2 on the accelerometers' x and y from 3 s (for 10 s) on the short landing. Before
    the IMU checks (commit 0040c18) the filter took it into its attitude, the fixes then agreed with the
    wrong estimate and it landed 13.99 m from the pad. Now the attitude check flags it within 1 s, the filter
    is re-initialised on its fixes and lands within the 1 m / 1 m/s of a safe landing."""
    sim, m = _fly(SHORT + _imu_fault("imu_accel_bias", "[0.3, 0.3, 0.0]"))
    assert m["outcome"] == "safe" and m["landed"] is True
    assert m["touchdown_error_m"] < 0.5 and m["touchdown_speed_mps"] < 0.5
    assert m["faults_detected"] == 1 and m["detection_delay_s"] <= 1.0
    flagged = sim.log.get("pad_fault")
    assert flagged and 3.0 < flagged["t"][0] < 4.0
    assert m["hpl_bound_violations"] <= 3


@pytest.mark.slow
def test_gyro_bias_lands_safely():
    """0.5 deg/s on every gyro axis from 3 s: before, 9.09 m from the pad; now flagged by the gyro check."""
    sim, m = _fly(SHORT + _imu_fault("imu_gyro_bias", "[0.5, 0.5, 0.5]"))
    assert m["outcome"] == "safe" and m["touchdown_error_m"] < 0.5
    assert m["detection_delay_s"] <= 1.0 and m["hpl_bound_violations"] == 0
    assert "gyros turned" in str(sim.log.get("pad_fault")["reason"][0])
