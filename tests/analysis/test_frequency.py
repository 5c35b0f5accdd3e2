"""Spectra, broken-loop response and margins from measured FRDs (seed 000 §5.2, Tables 5.1/5.2)."""

import control as ct
import numpy as np
import pytest
from scipy import signal

from visnav.analysis.frequency import broken_loop_response, frequency_response, margins_from_frd
from visnav.control.rmax import loop_margins, position_loop
from visnav.mission.hover import log_chirp
from visnav.flightlog import FlightLog


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


