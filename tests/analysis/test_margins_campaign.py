"""Margins campaigns: sweeps flown in the simulator, rows of Tables 5.1/5.2 (seed 000 §5.2)."""

import math

import numpy as np
import pytest

from visnav.analysis import margins_campaign as mc
from visnav.analysis.loop_model import model_margins, model_stable
from visnav.analysis.margins_campaign import SweepSettings, margins_campaign, sweep_run


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
                      round(laser_compensation_s, 6), kw["sweep"] is mc.IDENT_SWEEP))
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
    # uncompensated: 90 ms of IMU and 10 ms of laser mismatch
    assert key[30.0, 0.1, False]["longitudinal_pm_deg"] == pytest.approx(45.0 - 300 * 0.1)
    for a in (12.0, 30.0):
        comp = key[a, 0.1, True]
        assert comp["identified_imu_delay_s"] == pytest.approx(0.091)
        assert comp["identified_laser_delay_s"] == pytest.approx(0.011)
        assert comp["lateral_pm_deg"] == pytest.approx(45.0 - 0.6) and not comp["notes"]
        # 0 ms IMU: the camera is the late one, the attitude looked up 9 ms earlier than the stamp
        assert key[a, 0.0, True]["identified_imu_delay_s"] == pytest.approx(-0.009)
    assert (30.0, "lateral", "mpe", 0.1, 0.091, 0.011, False) in calls  # flown with both compensations
    assert (30.0, "lateral", "mpe", 0.0, -0.009, 0.011, False) in calls
    ident = [c for c in calls if c[-1]]
    assert {c[:3] for c in ident} == {(12.0, ax, "gps") for ax in ("lateral", "longitudinal")}
    assert len(ident) == 4  # identified once per delay, at 12 m, on GPS
    assert len(calls) == len(set(calls))  # no sweep flown twice


def test_campaign_falls_back_to_the_true_delays(monkeypatch):
    calls = []
    monkeypatch.setattr(mc, "sweep_run", _fake_sweeps(calls, fail_at=30.0))
    rows = margins_campaign([30.0], [0.1], compensate=True, identify_altitude_m=30.0)
    fallback = [r for r in rows if r["compensated"] is True][0]
    assert math.isnan(fallback["identified_imu_delay_s"]) and "true delays" in fallback["notes"]
    assert (30.0, "lateral", "mpe", 0.1, 0.1, 0.0, False) in calls  # the true delays (the camera's unknown)
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
    there); compensating it restores the synchronised loop's margins."""
    sync = sweep_run(12.0, "lateral", seed=2)
    late = sweep_run(12.0, "lateral", imu_delay_s=0.1, seed=2)
    comp = sweep_run(12.0, "lateral", imu_delay_s=0.1, attitude_delay_s=0.1, seed=2)
    assert not model_stable(12.0, 0.1, "lateral")
    assert math.isnan(late["pm_deg"]) and any("sweep incomplete" in n for n in late["notes"])
    assert comp["pm_deg"] == pytest.approx(sync["pm_deg"], abs=5.0)
    assert late["delay_s"] == pytest.approx(0.1, abs=0.005) or math.isnan(late["delay_s"])
    assert comp["delay_s"] == pytest.approx(0.1, abs=0.005)


def test_merging_seeds_weighs_each_record_by_its_coherence():
    """merge_sweeps: H averaged with weights γ²/(1−γ²), coherence S/(1+S); a phase crossover that
    no single record resolves above the coherence threshold is read from the merged one."""
    from visnav.control.rmax import loop_margins, position_loop

    L = position_loop("lateral")
    w = np.geomspace(0.5, 14.0, 60)
    H = L(1j * w)
    ref = loop_margins(L)
    sweep = SweepSettings(min_coherence=0.6, gm_min_coherence=0.59)
    g = np.where(w > 0.7 * ref.w_pc, 0.45, 0.9)  # each record incoherent from below the phase crossover
    rng = np.random.default_rng(0)
    runs = []
    for k in range(3):
        Hk = H * (1 + 0.01 * rng.standard_normal(w.size))
        runs.append(dict(frf=dict(w=w, H=Hk, coherence=g), delay_s=0.04 + 0.002 * k, delay_std_s=0.002,
                         laser_delay_s=math.nan, laser_delay_std_s=math.nan, imu_vs_laser_s=math.nan,
                         notes=["n"] if k == 0 else []))
    merged = mc.merge_sweeps(runs, sweep)
    S = 3 * 0.45 / 0.55
    assert merged["frf"]["coherence"][-1] == pytest.approx(S / (1 + S))
    np.testing.assert_allclose(merged["frf"]["H"], np.mean([r["frf"]["H"] for r in runs], axis=0))
    assert merged["gm_db"] == pytest.approx(ref.gm_db, abs=0.3)
    assert merged["pm_deg"] == pytest.approx(ref.pm_deg, abs=1.0)
    assert merged["delay_s"] == pytest.approx(0.042) and merged["delay_std_s"] == pytest.approx(0.002 / math.sqrt(3))
    assert merged["notes"] == ["seed 1: n"]
    single = mc._margins(w, runs[0]["frf"]["H"], g, sweep, [])
    assert not math.isfinite(single["gm_db"])  # one record alone: no phase crossover above 0.59
