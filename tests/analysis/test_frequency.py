"""Frequency sweeps, margins and delay identification (seed 000 §5.2, Tables 5.1/5.2, Figs. 5.2-5.4)."""

import math

import control as ct
import numpy as np
import pytest
from scipy import signal

from visnav.analysis import frequency
from visnav.analysis.frequency import (
    SweepSettings,
    broken_loop_response,
    camera_attitude,
    frequency_response,
    identify_delay,
    identify_delay_series,
    margins_campaign,
    margins_from_frd,
    model_loop,
    model_margins,
    model_stable,
    sweep_run,
)
from visnav.control.rmax import loop_margins, position_loop
from visnav.estimation.mpe import MonocularPositionEstimator
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.mission.hover import log_chirp
from visnav.sim.log import FlightLog


# ------------------------------------------------------------------ spectra of known systems
@pytest.mark.parametrize("method", ["welch", "fft"])
def test_h1_estimate_matches_a_known_filter(method):
    rng = np.random.default_rng(0)
    fs = 50.0
    b, a = signal.cheby1(4, 1.0, 4.0, fs=fs)
    u = rng.standard_normal(20000)
    y = signal.lfilter(b, a, u) + 0.01 * rng.standard_normal(u.size)  # output noise: H1 unbiased
    # fft: 10% smoothing (a 4th-order cut-off is sharp; thousands of bins per band anyway)
    fr = frequency_response(u, y, fs, 0.2, 12.0, method=method, rel_bandwidth=0.1)
    _, H = signal.freqz(b, a, worN=fr.w_rad_s / fs)
    good = fr.coherence > 0.98  # random error of H1 ~ sqrt(1 - γ²)/sqrt(2 n_d) < 0.3 dB here
    assert good.mean() > 0.6
    assert np.max(np.abs(20 * np.log10(np.abs(fr.H[good] / H[good])))) < 0.5
    assert np.max(np.abs(np.degrees(np.angle(fr.H[good] / H[good])))) < 3.0
    assert fr.coherence[-1] < 0.5 < fr.coherence[0]  # the stop band drowns in the noise


def _closed_loop_log(L: ct.TransferFunction, fs=50.0, duration=80.0, seed=1) -> FlightLog:
    """The loop u_c = −L·x1 (x1 = u_c + e + unmeasured disturbance d) swept by a log chirp e,
    simulated by ``control.forced_response``; logged like the simulator's "actuator" stream."""
    t = np.arange(0.0, duration, 1.0 / fs)
    e = 1.0 * log_chirp(t, 0.06, 2.0, duration)
    rng = np.random.default_rng(seed)
    d = signal.lfilter(*signal.butter(2, 1.0, fs=fs), 0.3 * rng.standard_normal(t.size))
    S = ct.feedback(ct.tf(1, 1), L)  # e -> x1
    x1 = ct.forced_response(ct.ss(S), t, e).outputs - ct.forced_response(ct.ss(L * S), t, d).outputs
    log = FlightLog()
    for k in range(t.size):
        log.record("actuator", t[k], controller=np.array([x1[k] - e[k], 0, 0, 0]),
                   injection=np.array([e[k], 0, 0, 0]), applied=np.array([x1[k], 0, 0, 0]))
    return log


def test_broken_loop_margins_match_the_analytic_loop():
    L = position_loop("lateral")  # PID x eq. 3.4 plant x Padé delay: 45.0° at 1.33 rad/s, 12.9 dB
    ref = loop_margins(L)
    fr = broken_loop_response(_closed_loop_log(L), "lateral", 0.06, 1.6)  # inside the 0.06-2 Hz chirp
    for method in ("control", "interp"):
        m = margins_from_frd(fr.w_rad_s, fr.H, fr.coherence, method=method)
        assert m.pm_deg == pytest.approx(ref.pm_deg, abs=2.0)
        assert m.gm_db == pytest.approx(ref.gm_db, abs=1.0)
        assert m.w_gc == pytest.approx(ref.w_gc, rel=0.05)
        assert m.w_pc == pytest.approx(ref.w_pc, rel=0.08)  # the phase is flat there: ±2° moves it 5%


def test_frd_margins_by_both_methods_match_stability_margins():
    w = np.geomspace(0.1, 20.0, 120)
    for axis in ("lateral", "longitudinal"):
        L = position_loop(axis, delay_s=0.03)
        ref = loop_margins(L)
        H = L(1j * w)
        for method in ("control", "interp"):
            m = margins_from_frd(w, H, method=method)
            assert m.pm_deg == pytest.approx(ref.pm_deg, abs=0.2)
            assert m.gm_db == pytest.approx(ref.gm_db, abs=0.1)
            assert m.w_pc == pytest.approx(ref.w_pc, rel=0.01)
        # an incoherent point that fakes a crossing is dropped
        bad, coh = H.copy(), np.ones(w.size)
        bad[60], coh[60] = -2.0, 0.1
        assert margins_from_frd(w, bad, coh).gm_db == pytest.approx(ref.gm_db, abs=0.1)


def test_margins_reject_bad_input():
    w = np.geomspace(0.1, 10, 10)
    with pytest.raises(ValueError, match="same length"):
        margins_from_frd(w, np.ones(9))
    with pytest.raises(ValueError, match="method"):
        margins_from_frd(w, 1 / (1j * w), method="cipher")
    with pytest.raises(ValueError, match="at least 4"):
        margins_from_frd(w, 1 / (1j * w), coherence=np.zeros(10))
    with pytest.raises(ValueError, match="f_hi"):
        frequency_response(np.ones(100), np.ones(100), 10.0, 0.1, 6.0)
    with pytest.raises(ValueError, match="actuator"):
        broken_loop_response(FlightLog(), "lateral")
    with pytest.raises(ValueError, match="axis"):
        broken_loop_response(FlightLog(), "vertical")


# ------------------------------------------------------------------ delay identification
def _delayed_pair(delay_s, rng, fs=100.0, n=6000, up=10, noise=0.05):
    """A band-limited signal and a copy ``delay_s`` late (exact on a grid 10x finer)."""
    x = signal.lfilter(*signal.butter(4, 3.0, fs=fs * up), rng.standard_normal(n * up + 2000))
    k = int(round(delay_s * fs * up))
    ref = x[1000::up][:n] + noise * rng.standard_normal(n)
    late = x[1000 - k::up][:n] + noise * rng.standard_normal(n)
    return ref, late


@pytest.mark.parametrize("delay", [0.044, 0.0, -0.044])
def test_delay_from_phase_slope(delay):
    rng = np.random.default_rng(3)
    ref, late = _delayed_pair(delay, rng)
    d = identify_delay(ref, late, 100.0, 0.3, 3.0)
    assert d.ok and d.n_bins >= 10
    assert d.delay_s == pytest.approx(delay, abs=0.002)
    assert d.std_s < 0.002


def test_delay_between_a_10hz_camera_and_a_100hz_imu():
    rng = np.random.default_rng(4)
    ref, late = _delayed_pair(0.044, rng, noise=0.02)
    t = np.arange(ref.size) / 100.0
    d = identify_delay_series(t[::10], ref[::10], t, late, 0.5, 2.5)
    assert d.delay_s == pytest.approx(0.044, abs=0.002)
    # no common signal: no delay
    assert not identify_delay(rng.standard_normal(2000), rng.standard_normal(2000), 100.0, 0.5, 3.0).ok


def test_camera_attitude_against_the_projection():
    # pure rotation (the lever arm turns a rotation partly into a translation: a gain, not a delay)
    cam, mount = PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0)
    h = 12.0
    pos = np.array([-h / math.tan(math.radians(60.0)), 0.0, -h])
    point = np.zeros((1, 3))

    def pixel(euler):
        return cam.project(mount.world_to_camera(point, pos, euler_to_dcm(euler)))[0]

    uv0 = pixel(np.zeros(3))
    for axis, e in (("pitch", np.array([0.0, 0.01, 0.0])), ("roll", np.array([0.01, 0.0, 0.0]))):
        uv = pixel(e)
        ang = camera_attitude([uv0[0], uv[0]], [uv0[1], uv[1]], 1073.0, (320.0, 240.0), math.radians(60.0), axis)
        assert ang[1] - ang[0] == pytest.approx(0.01, rel=0.02)


def test_late_attitude_shifts_mpe_by_height_times_angle():
    """The term of ``model_loop``: MPE with attitude late by δ errs by +h·δθ in x, −h·δφ in y."""
    cam, mount = PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0, lever_arm=(0.8, 0.0, -0.6))
    mpe = MonocularPositionEstimator(cam, mount, model="plane")
    h, d = 18.0, math.radians(0.5)
    pos = np.array([-h / math.tan(math.radians(60.0)), 0.0, -h])

    def look(euler):
        cam_pos, C_cn = mount.camera_pose(pos, euler_to_dcm(euler))
        uv = cam.project(mount.world_to_camera(np.zeros((1, 3)), pos, euler_to_dcm(euler)))[0]
        return uv, -cam_pos[2] / C_cn[2, 2]  # laser range along the optical axis

    uv, r = look(np.zeros(3))
    mpe.initialize(uv, r, euler_to_dcm(np.zeros(3)), pos)
    for e, k, sign in ((np.array([0.0, d, 0.0]), 0, 1.0), (np.array([d, 0.0, 0.0]), 1, -1.0)):
        uv, r = look(e)
        err = mpe.estimate(0.0, uv, r, euler_to_dcm(np.zeros(3))).position - pos
        assert err[k] == pytest.approx(sign * h * d, rel=0.05)


# ------------------------------------------------------------------ the analytic model
def test_model_reduces_to_the_design_loop_and_pade_agrees():
    w = np.array([0.2, 0.5])
    for axis in ("lateral", "longitudinal"):
        design = position_loop(axis)(1j * w)
        assert np.allclose(model_loop(axis, w, 30.0, 0.0), model_loop(axis, w, 6.0, None))
        assert np.max(np.abs(model_loop(axis, w, 12.0, None) / design - 1)) < 0.05
    # 100 ms unstable at 18 m (seed 000 Table 5.1: 14.7° there); compensating it restores stability
    assert model_stable(6.0, 0.1, "longitudinal") and not model_stable(18.0, 0.1, "longitudinal")
    assert model_stable(18.0, 0.1, "lateral", compensation_s=0.1)


def test_model_trend_of_table_5_1():
    """Margins with 100 ms of attitude delay fall with altitude; 0 ms leaves them as on GPS."""
    gps = model_margins(12.0, None, "longitudinal")
    sync = [model_margins(h, 0.0, "longitudinal") for h in (6.0, 30.0)]
    assert all(m.gm_db == pytest.approx(gps.gm_db, abs=1e-6) for m in sync)
    late = [model_margins(h, 0.1, "longitudinal").gm_db for h in (6.0, 12.0, 18.0)]
    assert late[0] < gps.gm_db and np.all(np.diff(late) < 0) and late[2] < 0
    comp = model_margins(18.0, 0.1, "lateral", compensation_s=0.1)
    assert comp.pm_deg == pytest.approx(model_margins(18.0, None, "lateral").pm_deg, abs=5.0)


# ------------------------------------------------------------------ campaign bookkeeping
COLUMNS = ["altitude_m", "delay_s", "compensated", "lateral_pm_deg", "lateral_pm_wc_rps", "lateral_gm_db",
           "longitudinal_pm_deg", "longitudinal_pm_wc_rps", "longitudinal_gm_db", "identified_imu_delay_s"]


def test_campaign_identifies_on_gps_then_compensates(monkeypatch):
    """Rows of issue #3 item 5 with the sweeps stubbed: the late attitude costs 300°/s of PM; the
    identification (true delay + 1 ms) fails at 30 m, where the true delay is used and flagged."""
    calls = []

    def fake_sweep(altitude_m, axis, source, imu_delay_s, attitude_delay_s, **kw):
        calls.append((altitude_m, axis, source, imu_delay_s, attitude_delay_s))
        seen = math.nan if altitude_m == 30.0 and imu_delay_s > 0 else imu_delay_s + 0.001
        late = 0.0 if source == "gps" else abs(imu_delay_s - attitude_delay_s)
        return dict(pm_deg=45.0 - 300.0 * late, w_gc=1.0, gm_db=10.0, w_pc=3.0, delay_s=seen,
                    delay_std_s=0.001, notes=[])

    monkeypatch.setattr(frequency, "sweep_run", fake_sweep)
    rows = margins_campaign([12.0, 30.0], [0.0, 0.1], compensate=True)
    assert [list(r)[:10] for r in rows] == [COLUMNS] * len(rows)
    key = {(r["altitude_m"], r["delay_s"], r["compensated"]): r for r in rows}
    assert len(rows) == 2 * (1 + 2 * 2)  # per altitude: GPS + (late, compensated) per delay
    assert key[12.0, None, "gps"]["lateral_pm_deg"] == 45.0
    assert key[12.0, 0.1, False]["longitudinal_pm_deg"] == pytest.approx(15.0)
    comp = key[12.0, 0.1, True]
    assert comp["identified_imu_delay_s"] == pytest.approx(0.101)
    assert comp["lateral_pm_deg"] == pytest.approx(45.0 - 0.3) and not comp["notes"]
    assert (12.0, "lateral", "mpe", 0.1, 0.101) in calls  # flown with the identified compensation
    assert (12.0, "lateral", "gps", 0.1, 0.0) in calls  # identified on GPS, MPE open loop
    fallback = key[30.0, 0.1, True]
    assert math.isnan(fallback["identified_imu_delay_s"]) and "true delay" in fallback["notes"]
    assert fallback["lateral_pm_deg"] == pytest.approx(45.0)
    assert len(calls) == len(set(calls))  # no sweep flown twice
    with pytest.raises(ValueError, match="altitudes"):
        margins_campaign([], [0.1])
    with pytest.raises(ValueError, match="delays"):
        margins_campaign([12.0], [-0.1])


# ------------------------------------------------------------------ closed loop in the simulator
def test_short_gps_sweep_at_12m_gives_positive_margins_and_the_imu_delay():
    sweep = SweepSettings(amplitude=40.0, f0_hz=0.12, f1_hz=2.5, duration_s=30.0, start_s=1.0)
    r = sweep_run(12.0, "longitudinal", source="gps", imu_delay_s=0.044, seed=3, sweep=sweep,
                  overrides=("mission.settle_s=1", "mission.coherence_time_s=1"))
    assert not r["notes"]
    model = model_margins(12.0, None, "longitudinal")  # 42° at 0.98 rad/s, 9.5 dB at 2.2 rad/s
    assert 0 < r["pm_deg"] == pytest.approx(model.pm_deg, abs=8.0)  # seeds (gusts) vary by ~±4°
    assert 0 < r["gm_db"] == pytest.approx(model.gm_db, abs=3.0)
    assert r["w_gc"] == pytest.approx(model.w_gc, rel=0.2)
    assert r["delay_s"] == pytest.approx(0.044, abs=0.005)


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
