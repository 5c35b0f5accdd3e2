"""The deck's protection level with the LED survey's constant error (issue 30): a bias that no number of frames
averages out is in the HPL as a covariance of its own, growing with the range."""

import math

import numpy as np

from visnav.app.missions import make_simulation
from visnav.scenarios.schema import load_scenario


def test_the_survey_share_per_metre_is_the_tilt_of_the_fitted_deck_plane():
    """sigma_survey sqrt(2 / S), S = sum |b_i - b_mean|^2 of eq. 5.10's lights: 0.071 per metre for 1 cm."""
    from visnav.navigation.deck import DeckNavConfig, DeckNavigator

    sc = load_scenario("deck-moving")
    nav = DeckNavigator(DeckNavConfig.from_mission(sc, 1.0 / 30.0))
    L = np.asarray(sc.world.deck.lights_m, float)
    S = float(((L - L.mean(0)) ** 2).sum())
    assert math.isclose(nav._survey_sigma_per_m(), 0.01 * math.sqrt(2.0 / S), rel_tol=1e-12)
    assert 0.06 < nav._survey_sigma_per_m() < 0.08
    ideal = load_scenario("deck-moving", ["world.deck.light_survey_error_m=0"])
    assert DeckNavigator(DeckNavConfig.from_mission(ideal, 1.0 / 30.0))._survey_sigma_per_m() == 0.0


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
    assert np.all(st["hpl_m"][ok] >= per_m * rng[ok] * np.sqrt(st["k2"][ok]) - 1e-9)
    assert res.metrics["outcome"] == "safe", res.metrics["outcome_reason"]
    td = sim.log.get("touchdown")
    assert len(td["t"]) == 1 and bool(td["on_deck"][0])


def test_health_splits_its_hpl_into_the_filter_share_and_the_calibration_share():
    """Each part is the HPL of its own covariance: hpl_noise_m of the filter's P (the mission's rules take it),
    hpl_bias_per_m x range of the calibration's constant share (the survey's tilt, (s r)^2 I, and the layout's
    apparent size along the line of sight, ``_calibration_position_cov``); hpl_m of their sum lies between the
    larger and their hypot (lambda_max is subadditive, and the sight line's share is not isotropic)."""
    from visnav.estimation.integrity import horizontal_protection_level
    from visnav.measurements import NavInit
    from visnav.navigation.deck import DeckNavConfig, DeckNavigator

    sc = load_scenario("deck-static")
    nav = DeckNavigator(DeckNavConfig.from_mission(sc, 1.0 / 30.0))
    nav.initialize(NavInit(t=0.0, source="static"))
    h = nav.health(0.0)
    r = float(np.linalg.norm(nav.x[0:3]))
    assert r > 1.0 and h.hpl_bias_per_m > 0.2
    k2 = h.consistency_k2
    C = nav._calibration_position_cov()[0:2, 0:2]
    assert math.isclose(h.hpl_noise_m, horizontal_protection_level(nav.P[0:2, 0:2], 0.999, k2), rel_tol=1e-9)
    assert math.isclose(h.hpl_bias_per_m * r, horizontal_protection_level(C, 0.999, k2), rel_tol=1e-9)
    assert math.isclose(h.hpl_m, horizontal_protection_level(nav.P[0:2, 0:2] + C, 0.999, k2), rel_tol=1e-9)
    assert max(h.hpl_noise_m, h.hpl_bias_per_m * r) <= h.hpl_m <= math.hypot(h.hpl_noise_m, h.hpl_bias_per_m * r)
    # the sight line's share is there: more than the survey's tilt alone
    assert h.hpl_bias_per_m > np.sqrt(k2 * -2 * np.log(1e-3)) * nav._survey_sigma_per_m()
