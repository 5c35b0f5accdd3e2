"""The deck's protection level with the LED survey's constant error (issue 30): a bias that no number of frames
averages out is in the HPL as a covariance of its own, growing with the range, and the mission's rules take it at
the contact range."""

import math

import numpy as np

from visnav.app.missions import make_simulation
from visnav.navigation.deck import DeckHealth
from visnav.scenarios.schema import load_scenario


def test_hpl_at_splits_the_protection_level_into_noise_and_range_proportional_bias():
    h = DeckHealth(hpl_m=0.5, hpl_noise_m=0.3, hpl_bias_per_m=0.4)
    assert math.isclose(h.hpl_at(1.0), 0.5)  # hypot(0.3, 0.4): lambda_max(P + s^2 I) = lambda_max(P) + s^2
    assert math.isclose(h.hpl_at(0.0), 0.3)
    assert DeckHealth(hpl_m=0.7).hpl_at(0.1) == 0.7  # not split: the HPL as it is


def test_realistic_deck_fault_free_error_stays_inside_the_protection_level():
    """deck-moving seed 8, realistic sensors (1 cm LED survey): the survey's draw tilts the fitted deck plane so
    that the horizontal error is 0.15-0.17 m at 1.2 m range, 14 % of it. With the covariance's HPL alone (0.12 m)
    849 of 1277 `ok` steps were over it; now none is, and the vehicle still lands on the plate."""
    sc = load_scenario("deck-moving", [], 8)
    sim = make_simulation(sc)
    res = sim.run()
    assert res.error is None, res.error
    st, tr, es = sim.log.get("status"), sim.log.get("truth"), sim.log.get("estimate")
    ok = np.asarray(st["integrity"]) == 0
    err = np.linalg.norm((es["position"] - tr["position"])[:, :2], axis=1)
    assert ok.sum() > 500
    assert np.sum(ok & (err > st["hpl_m"])) == 0
    assert np.max(err[ok]) > 0.1  # the survey's error is there (this test is not on an ideal deck)
    rng = np.linalg.norm(es["position"], axis=1)
    # the survey's share: 3.72 x 0.01 x sqrt(2 / S) per metre (S of eq. 5.10's lights) is in every ok step's HPL
    L = np.asarray(sc.world.deck.lights_m, float)
    per_m = np.sqrt(-2 * np.log(1e-3)) * 0.01 * np.sqrt(2.0 / ((L - L.mean(0)) ** 2).sum())
    assert np.all(st["hpl_m"][ok] >= per_m * rng[ok] - 1e-9)
    assert res.metrics["outcome"] == "safe", res.metrics["outcome_reason"]
    td = sim.log.get("touchdown")
    assert len(td["t"]) == 1 and bool(td["on_deck"][0])
