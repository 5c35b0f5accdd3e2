"""Every registered navigator honours the one protocol of ``navigation/base`` and its estimates the one typed
base ``measurements.Estimate`` (issue #31 item 5): checked on what each returns in a short closed-loop run of
its scenario."""

from __future__ import annotations

import math

import numpy as np
import pytest

from visnav.app.missions import make_simulation
from visnav.app.navigators import NAVIGATORS, make_navigator
from visnav.measurements import FRAMES, Estimate, Frame, GpsSample, Health, NavCommand, NavEstimate, NavInit
from visnav.navigation.base import Navigator
from visnav.scenarios.schema import load_scenario
from visnav.sensors.pantilt import PanTiltUnit

#: simulated seconds flown per navigator: long enough for a valid estimate (geo-location: the target's first
#: registrations after the operator's click)
FLOWN_S = {"geolocation": 20.0}


@pytest.mark.parametrize("name", sorted(NAVIGATORS))
def test_every_registered_navigator_offers_the_protocol(name):
    spec = NAVIGATORS[name]
    parts = {"ptu": PanTiltUnit(pan=0.0, tilt=-1.0)} if name == "pad" else {}  # the pad camera's own pan-tilt unit
    try:
        nav = make_navigator(name, load_scenario(spec.scenario), **parts)
    except TypeError as e:  # a builder that needs a part of its run (the map) names it
        pytest.fail(f"{name}: cannot be built from its scenario alone: {e}")
    assert isinstance(nav, Navigator), f"{name}: {type(nav).__name__} lacks a method of the protocol"
    with pytest.raises(ValueError, match="no command"):
        nav.command(NavCommand(0.0, "no-such-command"))
    nav.initialize(NavInit(0.0, "operator", position=np.zeros(3), velocity=np.zeros(3), attitude=np.zeros(3)))
    check_estimate(nav.estimate(0.0), 0.0, spec.frame)
    assert isinstance(nav.health(0.0), Health)


class _Probe:
    """The loop's navigator, passed through; keeps every estimate asked of it (or, with ``tee``, of a second
    navigator fed the same frames and fixes: VO, which no mission flies)."""

    def __init__(self, inner, tee=None):
        self._inner, self._tee, self.asked = inner, tee, []

    def update(self, m):
        self._inner.update(m)
        if self._tee is not None and isinstance(m, (Frame, GpsSample)):
            self._tee.update(m)

    def estimate(self, t, *args, **kwargs):
        e = self._inner.estimate(t, *args, **kwargs)
        self.asked.append((t, e if self._tee is None else self._tee.estimate(t)))
        return e

    def __getattr__(self, name):
        return getattr(self._inner, name)


def check_estimate(e, t: float, spec_frame: str) -> None:
    """The contract of ``Estimate`` on one estimate."""
    assert isinstance(e, Estimate), f"{type(e).__name__} is no Estimate"
    assert e.t == t and isinstance(e.valid, bool)
    assert e.frame in FRAMES and FRAMES[e.frame] == spec_frame  # the registry's frame is the estimate's
    pos, vel, cov = (np.asarray(x, float) for x in (e.position, e.velocity, e.covariance))
    n = len(e.position_index)
    assert pos.shape == vel.shape == (n,) and n in (2, 3)
    assert cov.ndim == 2 and cov.shape[0] == cov.shape[1] >= n
    pv = e.pv_covariance
    assert pv.shape == (2 * n, 2 * n)
    # symmetric (to rounding: a UKF's covariance), NaN (not modelled) where its transpose is
    np.testing.assert_allclose(pv, pv.T, rtol=1e-9, atol=0.0, equal_nan=True)
    np.testing.assert_array_equal(e.position_covariance, pv[:n, :n])
    if not e.valid:
        return
    # what is valid is a horizontal position with a variance: finite, or +inf (no bound: VO alone)
    assert np.all(np.isfinite(pos[:2])), pos
    Ph = pv[:2, :2]
    assert not np.any(np.isnan(Ph)) and np.all(np.diag(Ph) > 0), Ph
    # the coordinates with a finite variance: a finite, positive semi-definite block (eigenvalues >= -1e-12 of
    # its scale)
    k = np.flatnonzero(np.isfinite(np.diag(pv)))
    B = pv[np.ix_(k, k)]
    assert np.all(np.isfinite(B)), B
    if k.size:
        lam = np.linalg.eigvalsh(B)
        assert lam[0] >= -1e-12 * max(lam[-1], 1e-300), lam


@pytest.mark.parametrize("name", sorted(NAVIGATORS))
def test_every_registered_navigator_estimates_the_typed_base_in_its_run(name):
    """A few seconds of the navigator's scenario in the closed loop: every estimate the loop asks for satisfies
    ``Estimate``'s contract, and some are valid (a navigator that never says valid would pass vacuously)."""
    spec = NAVIGATORS[name]
    sc = load_scenario(spec.scenario, [f"run.duration_s={FLOWN_S.get(name, 3.0)}"])
    probes = []

    def wrap(nav):
        probes.append(_Probe(nav, make_navigator("vo", sc) if name == "vo" else None))
        return probes[-1]

    make_simulation(sc, navigator_wrapper=wrap).run()
    asked = probes[0].asked
    assert asked, f"{name}: the loop asked no estimate"
    for t, e in asked:
        check_estimate(e, t, spec.frame)
    valid = [e for _, e in asked if e.valid]
    assert valid, f"{name}: no valid estimate in {sc.run.duration_s} s"
    assert math.isfinite(float(np.trace(valid[-1].position_covariance[:2, :2])))


def test_pv_covariance_takes_each_type_s_layout():
    """The position / velocity block from each layout: NavEstimate (6, 6) as it is, the deck's 12 states at
    0-2 and 6-8, a target's (2, 2) with a NaN velocity block."""
    from visnav.measurements import TargetEstimate
    from visnav.navigation.deck import DeckEstimate

    C = np.arange(36.0).reshape(6, 6)
    e = NavEstimate(0.0, np.zeros(3), np.zeros(3), np.zeros(3), C)
    np.testing.assert_array_equal(e.pv_covariance, C)
    C12 = np.arange(144.0).reshape(12, 12)
    d = DeckEstimate(0.0, np.arange(12.0), C12, np.zeros(3), np.zeros(3), 0.0, 0.0)
    i = [0, 1, 2, 6, 7, 8]
    np.testing.assert_array_equal(d.pv_covariance, C12[np.ix_(i, i)])
    np.testing.assert_array_equal(d.velocity, [6.0, 7.0, 8.0])
    g = TargetEstimate(0.0, np.ones(2), np.eye(2) * 4.0, 3, True)
    P = g.pv_covariance
    np.testing.assert_array_equal(P[:2, :2], np.eye(2) * 4.0)
    assert np.all(np.isnan(P[2:, :])) and np.all(np.isnan(P[:, 2:])) and np.all(np.isnan(g.velocity))
    assert (e.frame, d.frame, g.frame) == ("ned", "deck_body", "target_ned")
