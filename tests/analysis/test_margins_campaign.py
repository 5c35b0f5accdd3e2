"""Margins campaigns: sweeps flown in the simulator, rows of Tables 5.1/5.2 (seed 000 §5.2)."""

import math

import pytest

from visnav.app import margins_campaign as mc
from visnav.analysis.loop_model import model_margins, model_stable
from visnav.app.margins_campaign import SweepSettings, margins_campaign, sweep_run


COLUMNS = ["altitude_m", "delay_s", "compensated", "lateral_pm_deg", "lateral_pm_wc_rps", "lateral_gm_db",
           "longitudinal_pm_deg", "longitudinal_pm_wc_rps", "longitudinal_gm_db", "identified_imu_delay_s"]


def _fake_sweeps(calls, fail_at=None):
    """Sweeps stubbed: the camera 10 ms late (the palace-sweep baseline); each second of mismatch
    between the image and the attitude or laser it is paired with costs 300° of PM; identification
    reads the true delays behind the camera + 1 ms, and fails at ``fail_at`` m."""
    cam = 0.01

    def fake_sweep(altitude_m, axis, source, imu_delay_s, attitude_delay_s, laser_delay_s=0.0,
                   laser_compensation_s=0.0, **kw):
        calls.append((altitude_m, axis, source, imu_delay_s, round(attitude_delay_s, 6),
                      round(laser_compensation_s, 6), kw["sweep"] is mc.IDENT_SWEEP, kw["seed"]))
        fail = altitude_m == fail_at and imu_delay_s > 0
        seen = math.nan if fail else imu_delay_s - cam + 0.001
        lseen = math.nan if fail or axis == "lateral" else laser_delay_s - cam + 0.001
        late = 0.0 if source == "gps" else (abs(imu_delay_s - cam - attitude_delay_s)
                                            + abs(laser_delay_s - cam - laser_compensation_s))
        return dict(pm_deg=45.0 - 300.0 * late, w_gc=1.0, gm_db=10.0, w_pc=3.0, delay_s=seen,
                    delay_std_s=0.001, laser_delay_s=lseen, laser_delay_std_s=0.002, notes=[])

    return fake_sweep


def test_campaign_identifies_once_on_gps_then_compensates_both_delays(monkeypatch):
    calls = []
    monkeypatch.setattr(mc, "sweep_run", _fake_sweeps(calls))
    rows = margins_campaign([12.0, 30.0], [0.0, 0.1], compensate=True, laser_delay_s=0.02)
    assert [list(r)[:10] for r in rows] == [COLUMNS] * len(rows)
    key = {(r["altitude_m"], r["delay_s"], r["compensated"]): r for r in rows}
    assert len(rows) == 2 * (1 + 2 * 2)  # per altitude: GPS + (late, compensated) per delay
    assert key[12.0, None, "gps"]["lateral_pm_deg"] == 45.0
    assert key[12.0, None, "gps"]["lateral_pm_seeds_deg"] == "45.0"  # one seed: its PM, no spread
    assert math.isnan(key[12.0, None, "gps"]["lateral_pm_seed_sd_deg"])
    # uncompensated: 90 ms of IMU and 10 ms of laser mismatch
    assert key[30.0, 0.1, False]["longitudinal_pm_deg"] == pytest.approx(45.0 - 300 * 0.1)
    for a in (12.0, 30.0):
        comp = key[a, 0.1, True]
        assert comp["identified_imu_delay_s"] == pytest.approx(0.091)
        assert comp["identified_laser_delay_s"] == pytest.approx(0.011)
        assert comp["lateral_pm_deg"] == pytest.approx(45.0 - 0.6) and not comp["notes"]
        # 0 ms IMU: the camera is the late one, the attitude looked up 9 ms earlier than the stamp
        assert key[a, 0.0, True]["identified_imu_delay_s"] == pytest.approx(-0.009)
    assert (30.0, "lateral", "mpe", 0.1, 0.091, 0.011, False, 1) in calls  # flown with both compensations
    assert (30.0, "lateral", "mpe", 0.0, -0.009, 0.011, False, 1) in calls
    ident = [c for c in calls if c[-2]]
    assert {c[:3] for c in ident} == {(12.0, ax, "gps") for ax in ("lateral", "longitudinal")}
    assert len(ident) == 2 * 2 * 4  # identified once per delay, at 12 m, on GPS, with 4 seeds
    assert {c[-1] for c in ident} == {1, 2, 3, 4} and {c[-1] for c in calls if not c[-2]} == {1}
    assert len(calls) == len(set(calls))  # no sweep flown twice


def test_campaign_falls_back_to_no_compensation(monkeypatch):
    calls = []
    monkeypatch.setattr(mc, "sweep_run", _fake_sweeps(calls, fail_at=30.0))
    rows = margins_campaign([30.0], [0.1], compensate=True, identify_altitude_m=30.0)
    fallback = [r for r in rows if r["compensated"] is True][0]
    late = [r for r in rows if r["compensated"] is False][0]
    assert math.isnan(fallback["identified_imu_delay_s"]) and fallback["identified_imu_delay_confidence"] == 0.0
    assert "IMU delay not compensated" in fallback["notes"] and "laser delay not compensated" in fallback["notes"]
    # no compensation: the same sweeps as the late row (flown once), not the true delays (unknown in a real flight)
    assert fallback["lateral_pm_deg"] == late["lateral_pm_deg"]
    assert not [c for c in calls if c[2] == "mpe" and (c[4] != 0.0 or c[5] != 0.0)]
    assert len(calls) == len(set(calls))
    with pytest.raises(ValueError, match="altitudes"):
        margins_campaign([], [0.1])
    with pytest.raises(ValueError, match="delays"):
        margins_campaign([12.0], [-0.1])
    with pytest.raises(ValueError, match="laser_delay_s"):
        margins_campaign([12.0], [0.1], laser_delay_s=-0.1)


# ------------------------------------------------------------------ closed loop in the simulator
def test_short_gps_sweep_at_12m_gives_margins_near_the_model():
    sweep = SweepSettings(amplitude=40.0, f0_hz=0.12, f1_hz=2.5, duration_s=30.0, start_s=1.0)
    r = sweep_run(12.0, "longitudinal", source="gps", imu_delay_s=0.044, seed=3, sweep=sweep,
                  overrides=("mission.settle_s=1", "mission.coherence_time_s=1"))
    assert not r["notes"]
    model = model_margins(12.0, None, "longitudinal")  # 42° at 0.98 rad/s, 9.5 dB at 2.2 rad/s
    assert 0 < r["pm_deg"] == pytest.approx(model.pm_deg, abs=8.0)  # seeds (gusts) vary by ~±4°
    assert 0 < r["gm_db"] == pytest.approx(model.gm_db, abs=3.0)
    assert r["w_gc"] == pytest.approx(model.w_gc, rel=0.2)


def test_identification_sweep_gives_each_sensors_delay_within_5ms():
    """The campaign's identification chirp on GPS with the IMU 44 ms and the laser 30 ms late and
    the image 10 ms late (palace-sweep's baseline): each delay behind the camera within ±5 ms
    (the issue's target; the thesis found the IMU 44 ms late and the laser on time, Figs. 5.2-5.4)."""
    r = sweep_run(12.0, "longitudinal", source="gps", imu_delay_s=0.044, seed=3, sweep=mc.IDENT_SWEEP,
                  laser_delay_s=0.03, overrides=("mission.settle_s=1", "mission.coherence_time_s=1"))
    assert not r["notes"]
    assert r["delay_s"] == pytest.approx(0.044 - 0.01, abs=0.005)
    assert r["laser_delay_s"] == pytest.approx(0.03 - 0.01, abs=0.005)
    assert r["imu_vs_laser_s"] == pytest.approx(0.044 - 0.03, abs=0.005)


@pytest.mark.slow
def test_mpe_sweeps_late_and_compensated_at_12m():
    """100 ms of IMU delay destabilises the 12 m MPE hover (the model's lateral loop is unstable
    there); compensating the identified 90 ms (IMU 100 ms late, image 10 ms late: palace-sweep's
    baseline) restores the GPS margins. Seeds 1 and 2 merged, as the campaign does: one MPE sweep's
    PM scatters by several degrees (single seeds gave +3.4°, +8.4°, +3.4° from GPS for seeds 1-3)."""
    sweep = SweepSettings()
    gps = mc.merge_sweeps([sweep_run(12.0, "lateral", source="gps", seed=s) for s in (1, 2)], sweep)
    late = sweep_run(12.0, "lateral", imu_delay_s=0.1, seed=2)
    comp = mc.merge_sweeps([sweep_run(12.0, "lateral", imu_delay_s=0.1, attitude_delay_s=0.09,
                                      laser_compensation_s=-0.01, seed=s) for s in (1, 2)], sweep)
    assert not model_stable(12.0, 0.1, "lateral")
    assert math.isnan(late["pm_deg"]) and any("sweep incomplete" in n for n in late["notes"])
    assert comp["pm_deg"] == pytest.approx(gps["pm_deg"], abs=5.0)
    assert comp["delay_s"] == pytest.approx(0.09, abs=0.005)
