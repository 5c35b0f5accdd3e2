"""Integrity monitor: chi-square bounds vs scipy, false-alarm rate, detection, protection level coverage."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom, chi2, rayleigh

from visnav.estimation.integrity import IntegrityConfig, IntegrityMonitor, chi2_2_quantile, horizontal_protection_level


def test_window_bounds_are_scipy_chi2_quantiles():
    m = IntegrityMonitor(IntegrityConfig(window=10, alpha=0.01))
    for k in range(10):
        m.record(k * 0.1, "pos", 1.0, 2, True)
    x = m.test("pos")
    assert x.dof == 20
    assert x.lower == pytest.approx(chi2.ppf(0.005, 20), rel=1e-12)
    assert x.upper == pytest.approx(chi2.ppf(0.995, 20), rel=1e-12)


def test_false_alarm_rate_of_a_consistent_filter_is_alpha_over_two():
    rng = np.random.default_rng(1)
    alpha, window, n_windows = 0.01, 10, 4000
    nis = rng.chisquare(2, size=(n_windows, window))  # an honest 2-D position update
    alarms = 0
    for w in nis:
        m = IntegrityMonitor(IntegrityConfig(window=window, alpha=alpha))
        for k, v in enumerate(w):
            m.record(0.1 * k, "pos", v, 2, True)
        alarms += m.assess(1.0)["integrity"] != "ok"
    lo, hi = binom.ppf([0.0005, 0.9995], n_windows, alpha / 2)
    assert lo <= alarms <= hi, (alarms, lo, hi)


def test_an_over_confident_filter_is_degraded_and_the_transition_is_logged():
    rng = np.random.default_rng(2)
    m = IntegrityMonitor(IntegrityConfig(window=20, alpha=0.001))
    t = 0.0
    for _ in range(20):  # consistent
        t += 0.1
        m.record(t, "registration", rng.chisquare(2), 2, True)
    assert m.assess(t)["integrity"] == "ok"
    for _ in range(20):  # true errors 3x what the filter believes: NIS x 9
        t += 0.1
        m.record(t, "registration", 9 * rng.chisquare(2), 2, True)
    a = m.assess(t)
    assert a["integrity"] == "degraded" and "registration NIS" in a["integrity_reason"]
    assert a["consistency_k2"] == pytest.approx(np.mean([x for x, _, ok in m._streams["registration"]]) / 2)
    assert m.transitions[-1][1] == "degraded"


def test_rejected_share_and_staleness():
    m = IntegrityMonitor(IntegrityConfig(window=10, max_rejected_share=0.3, stale_s=2.0))
    for k in range(10):
        m.record(0.1 * k, "pos", 1.0, 2, accepted=k % 2 == 0)  # half rejected
    a = m.assess(1.0)
    assert a["rejected_share"]["pos"] == pytest.approx(0.5)
    assert a["integrity"] == "degraded" and "rejected 50 %" in a["integrity_reason"]
    a = m.assess(0.8 + 2.5)
    assert a["integrity"] == "unusable" and "no accepted update" in a["integrity_reason"]


def test_an_accepted_update_that_is_no_fix_does_not_hold_off_staleness():
    m = IntegrityMonitor(IntegrityConfig(window=10, stale_s=0.5))
    m.record(0.0, "bearing", 4.0, 8, True)  # a fix (a deck frame with four lights)
    for k in range(1, 10):
        m.record(0.1 * k, "bearing", 1.0, 2, True, fix=False)  # one light: fused, not a fix
    a = m.assess(0.9)
    assert a["integrity"] == "unusable" and "no accepted update for 0.9 s" in a["integrity_reason"]
    assert a["rejected_share"]["bearing"] == 0.0  # accepted all the same: the windows count them
    m.record(1.0, "bearing", 4.0, 8, True)
    assert m.assess(1.0)["integrity"] != "unusable"


def test_largest_eigenvalue_closed_form_and_isotropic_hpl_is_the_rayleigh_quantile():
    rng = np.random.default_rng(3)
    for _ in range(50):
        A = rng.normal(size=(2, 2))
        P = A @ A.T
        a, b, d = P[0, 0], P[0, 1], P[1, 1]
        lam = (a + d) / 2 + math.sqrt(((a - d) / 2) ** 2 + b * b)  # the 2x2 largest eigenvalue in closed form
        assert horizontal_protection_level(P, 0.99) == pytest.approx(math.sqrt(lam * chi2.ppf(0.99, 2)), rel=1e-9)
    s = 1.7
    assert horizontal_protection_level(np.eye(2) * s * s, 0.999) == pytest.approx(rayleigh.ppf(0.999, scale=s),
                                                                                  rel=1e-9)


@pytest.mark.parametrize("P", [np.diag([4.0, 4.0]), np.array([[9.0, 2.5], [2.5, 1.0]]), np.diag([1.0, 1e-6])])
def test_hpl_contains_the_error_with_the_stated_probability(P):
    rng = np.random.default_rng(4)
    n, p = 200_000, 0.999
    e = rng.multivariate_normal([0, 0], P, size=n)
    hpl = horizontal_protection_level(P, p)
    violations = int(np.sum(np.linalg.norm(e, axis=1) > hpl))
    assert violations <= binom.ppf(0.9999, n, 1 - p)  # never more often than 1 - p (isotropic: exactly)
    if P[0, 0] == P[1, 1] and P[0, 1] == 0:
        assert violations >= binom.ppf(0.0001, n, 1 - p)


def test_inflation_widens_the_hpl_of_an_over_confident_filter():
    m = IntegrityMonitor(IntegrityConfig(window=10, probability=0.99))
    for k in range(10):
        m.record(0.1 * k, "pos", 8.0, 2, True)  # mean NIS 4 per dof
    a = m.assess(1.0, np.eye(2))
    assert a["consistency_k2"] == pytest.approx(4.0)
    assert a["hpl_m"] == pytest.approx(2.0 * horizontal_protection_level(np.eye(2), 0.99))
    with pytest.raises(ValueError, match="window"):
        IntegrityConfig(window=0)


def test_inflation_pools_only_the_named_streams():
    m = IntegrityMonitor(IntegrityConfig(window=5, inflation_streams=("pos",)))
    for k in range(5):
        m.record(0.1 * k, "pos", 4.0, 2, True)  # mean NIS / dof = 2
        m.record(0.1 * k, "baro", 30.0, 1, True)  # a badly tuned vertical stream
    assert m.inflation() == pytest.approx(2.0)
    every = IntegrityMonitor(IntegrityConfig(window=5))
    for k in range(5):
        every.record(0.1 * k, "pos", 4.0, 2, True)
        every.record(0.1 * k, "baro", 30.0, 1, True)
    assert every.inflation() == pytest.approx((5 * 4.0 + 5 * 30.0) / 15)


def test_assess_between_updates_reuses_the_windows_and_sees_every_change():
    """``assess`` runs every step and the windows change only at updates (issue #19 memo): interleaved at
    random, it must give what the windows' own tests give at that moment, clears included."""
    rng = np.random.default_rng(5)
    m = IntegrityMonitor(IntegrityConfig(window=6, max_rejected_share=0.3))
    P = np.diag([1.0, 2.0])
    for k in range(600):
        r = rng.uniform()
        if r < 0.4:
            m.record(0.01 * k, str(rng.choice(["gps", "vision"])), float(rng.chisquare(2) * rng.choice([1, 8])), 2,
                     bool(rng.uniform() < 0.8))
        elif r < 0.42:
            m.clear()
        a = m.assess(0.01 * k, P)
        tests = {s: m.test(s) for s in m._streams}
        assert a["consistency_k2"] == m.inflation()
        assert a["nis_per_dof"] == pytest.approx({s: x.mean_nis_per_dof for s, x in tests.items()}, nan_ok=True)
        assert a["rejected_share"] == {s: x.rejected_share for s, x in tests.items()}
        want = "degraded" if any(x.over_confident or x.rejected_share > 0.3 for x in tests.values()) else "ok"
        assert a["integrity"] == want


def _windows_reference(m: IntegrityMonitor) -> tuple:
    """``IntegrityMonitor._windows`` before the per-stream memo (issue #19): every test and k^2 from the windows."""
    c = m.config
    tests = [m.test(s) for s in m._streams]
    state, reason = "ok", ""
    bad = [x for x in tests if x.over_confident]
    rej = [x for x in tests if x.rejected_share > c.max_rejected_share]
    if bad:
        state = "degraded"
        reason = "; ".join(f"{x.stream} NIS {x.mean_nis_per_dof:.2f}/dof over {x.updates} updates "
                           f"(chi2 bound {x.upper / x.dof:.2f})" for x in bad)
    elif rej:
        state = "degraded"
        reason = "; ".join(f"{x.stream} rejected {100 * x.rejected_share:.0f} %" for x in rej)
    return (m.inflation(), state, reason, {x.stream: x.mean_nis_per_dof for x in tests},
            {x.stream: x.rejected_share for x in tests}, bool(bad))


@pytest.mark.parametrize("only", [("gps", "vision"), None])
def test_per_stream_memo_equals_the_windows_recomputed_bit_for_bit(only):
    """The per-stream tests and k^2 kept until their own stream changes (a baro update recomputes the baro
    test alone, and not k^2 when baro does not inflate) equal the full recomputation, to the bit."""
    rng = np.random.default_rng(11)
    m = IntegrityMonitor(IntegrityConfig(window=7, max_rejected_share=0.3, inflation_streams=only))
    P = np.diag([1.0, 2.0])
    for k in range(3000):
        r = rng.uniform()
        if r < 0.5:
            s = str(rng.choice(["gps", "vision", "baro", "heading"]))
            m.record(0.01 * k, s, float(rng.chisquare(2) * rng.choice([1, 8]) * rng.uniform(0.1, 3.0)),
                     int(rng.choice([1, 2])), bool(rng.uniform() < 0.8))
        elif r < 0.51:
            m.clear()
        m.assess(0.01 * k, P)
        assert repr(m._windows()) == repr(_windows_reference(m))  # repr: floats to the bit, NaN equal to NaN


def test_hpl_of_an_unbounded_or_unknown_covariance():
    """A variance of +inf (no bound: visual odometry alone) gives an infinite HPL, a NaN (not modelled) a NaN one
    (and ``assess`` then no alert from it)."""
    assert horizontal_protection_level(np.diag([np.inf, np.inf])) == math.inf
    assert math.isnan(horizontal_protection_level(np.array([[np.nan, 0.0], [0.0, 1.0]])))


def test_hpl_is_the_largest_eigenvalue_of_the_symmetric_part():
    rng = np.random.default_rng(5)
    for _ in range(200):
        A = rng.normal(0, 3, (2, 2))
        P = A @ A.T + np.diag(rng.uniform(0, 1, 2)) + np.array([[0.0, 1e-3], [0.0, 0.0]])  # a little asymmetric
        lam = float(np.linalg.eigvalsh(0.5 * (P + P.T))[-1])
        assert horizontal_protection_level(P, 0.99, 2.0) == pytest.approx(math.sqrt(2.0 * chi2_2_quantile(0.99) * lam),
                                                                         rel=1e-12)
    assert math.isnan(horizontal_protection_level(np.array([[np.nan, 0.0], [0.0, np.inf]])))
    assert horizontal_protection_level(np.array([[np.inf, 0.0], [0.0, 1.0]])) == math.inf


def test_window_state_says_what_the_windows_say_and_that_a_nis_test_failed():
    """``window_state``: (state, reason, NIS test failed) from the windows alone, as ``assess`` sees them."""
    m = IntegrityMonitor(IntegrityConfig(window=5, alpha=0.001))
    for k in range(5):
        m.record(0.1 * k, "rate", 30.0, 2, True)  # NIS/dof 15: over-confident
    state, reason, nis_failed = m.window_state()
    assert state == "degraded" and nis_failed is True and reason.startswith("rate NIS 15.00/dof")
    assert m.assess(0.5)["integrity"] == "degraded"
    for k in range(5):
        m.record(0.6 + 0.1 * k, "rate", 2.0, 2, True)  # the windows clean again
    assert m.window_state() == ("ok", "", False) and m.assess(1.1)["integrity"] == "ok"


def test_window_state_tells_rejections_from_a_failed_nis_test():
    m = IntegrityMonitor(IntegrityConfig(window=5, max_rejected_share=0.3))
    for k in range(5):
        m.record(0.1 * k, "bearing", float("nan"), 0, k < 2)  # 60 % rejected, the accepted ones (none) consistent
    state, reason, nis_failed = m.window_state()
    assert state == "degraded" and "rejected" in reason and nis_failed is False
