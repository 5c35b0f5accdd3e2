"""Closed-loop deck landings under camera faults (issue #18, round 5): a black-out that hides the deck in the
approach's last second must not end in an unsafe touchdown."""

import numpy as np

from visnav.app.missions import make_simulation

from tests.deck_ideal import load_ideal_deck


def test_blackout_in_the_commit_window_lands_on_the_plate():
    """Black-out seed 7 (2 s from 9.0 s): the approach (7.36 s, T = 2.91 s) ended at 10.28 s 2 cm above the
    deck without contact and without a fix. Before round 5 it went around into the blind hold (0.2 m/s climb,
    the horizontal loop pulling it back to the start point) and touched the deck at 1.20 m/s, 0.29 m from the
    point, off the plate. Now it finishes the landing blind: level, sinking on the IMU."""
    # (no horizontal reference lead, as when the test was written: with it, issue 30 round 14, this trajectory
    # touches down before its end)
    sc = load_ideal_deck("deck-moving", ['faults=[{kind = "camera_blackout", start_s = 9.0, duration_s = 2.0}]',
                                         "control.deck.reference_lead_s=0"], seed=7)
    sim = make_simulation(sc)
    res = sim.run()
    assert res.error is None, res.error
    modes = list(sim.log.get("mode")["mode"])
    assert modes == ["manual", "hover", "approach", "descend", "landed"]
    assert "no fix" in sim.log.get("mode")["reason"][3]
    assert list(sim.log.get("integrity_reaction")["action"]) == ["land on"]
    td = sim.log.get("touchdown")
    assert bool(td["on_deck"][0]) and float(td["t"][0]) < 11.0  # before the lights come back
    assert float(td["rel_speed"][0]) <= 0.4 and float(td["pos_err"][0]) <= 0.27
    # it never climbed away from the deck while blind
    v = sim.log.get("vehicle")
    blind = (v["t"] >= 10.28) & (v["t"] <= float(td["t"][0]))
    assert np.all(v["velocity"][blind][:, 2] > -0.05)  # NED: never up


def test_static_deck_holds_when_the_navigator_is_unusable_mid_approach():
    """deck-static seed 4, a 2 s camera black-out from 9 s, 11 s of the straight approach to go. Before round 5
    the static mission acted on no integrity state: an approach whose filter lost the lights went on blind, then
    descended on the IMU alone (IMU drops seed 4 then: the vehicle flew 100 m away, never touching down). Now the
    approach is abandoned for the blind hold on the IMU 0.5 s after the navigator turns unusable, starts again
    once the fix has been good for 2 s, and lands. (IMU drops, the old case, no longer lose the lights: since
    the overshoot lies along the path, issue 30 round 10, their seeds 1-12 land or hold near the end.)"""
    sc = load_ideal_deck("deck-static", ['faults=[{kind = "camera_blackout", start_s = 9.0, duration_s = 2.0}]',
                                       "run.duration_s=40"], seed=4)
    sim = make_simulation(sc)
    res = sim.run()
    assert res.error is None, res.error
    mode = sim.log.get("mode")
    assert list(mode["mode"][:4]) == ["manual", "approach", "hover", "approach"]
    assert "integrity: navigator unusable" in mode["reason"][2] and 9.5 < float(mode["t"][2]) < 10.5
    assert "go-around" in list(sim.log.get("integrity_reaction")["action"])
    tr = sim.log.get("truth")
    assert np.max(np.linalg.norm(tr["position"], axis=1)) < 12.0
    td = sim.log.get("touchdown")
    assert bool(td["on_deck"][0]) and float(td["rel_speed"][0]) < 0.3 and float(td["t"][0]) > 15.0


# the bearing rates predicted at the frame with the newest gyro sample, no time offset in R (the thesis' form, the
# defaults before issue 30 round 18): what the tests of the re-lock and the thesis' comparisons were written with
FRAME_RATES = ("navigation.rates_at_midpoint=false", "navigation.time_offset_in_r=false")


def _static_seed5(fault: str, seed: int = 5, sets=()):
    from visnav.scenarios.schema import load_scenario
    sc = load_scenario("deck-static", [f"faults=[{{{fault}}}]", *sets], seed)  # the realistic sensors (the scenario's own)
    sim = make_simulation(sc)
    res = sim.run()
    assert res.error is None, res.error
    return sim, res


def test_static_deck_realistic_blackout_rides_out_the_reacquisition():
    """deck-static seed 5 with the realistic sensors, a 2 s black-out from 9 s (issue 30): the filter re-acquires at
    11 s with the deck attitude from its sea-state prior. Before, the accelerometer-bias NIS test read the
    re-converging attitude as a bias step and widened the bias every 1.2 s for 20 s; the estimate wandered 1 m
    off with a 0.05 m sigma, and the hover's IMU height hold flew without a vertical-speed loop (its trusted fix
    needed the moving deck's 0.15 m HPL): it touched down at 1.30 m/s off the plate. Now the bias test rests 3 s
    after a re-acquisition and the static deck's trusted fix is an ``ok`` one within ``hover_hpl_m``."""
    sim, res = _static_seed5('kind = "camera_blackout", start_s = 9.0, duration_s = 2.0')
    assert res.metrics["outcome"] == "safe", res.metrics["outcome_reason"]
    init = [str(s) for s in sim.log.get("nav_init")["source"]]
    assert sum("bias test" in s for s in init) <= 1
    td = sim.log.get("touchdown")
    if "t" in td and len(td["t"]):  # a landing, if there is one, on the plate and gentle
        assert bool(td["on_deck"][0]) and float(td["rel_speed"][0]) <= 0.5


def test_static_deck_realistic_blur_relocks_a_filter_lost_on_a_wrong_solution():
    """deck-static seed 7, realistic sensors, 3 s of blur from 9 s (issue 30): after the re-acquisition the
    filter fitted the four lights on a wrong solution (relative pitch 10-17 deg, position 0.5-0.9 m off with a
    5 cm sigma) and its bias test widened the bias every 1.2 s to the end of the run (25 times; a round earlier the
    vehicle touched down at 5.8 m/s off the plate). Now the third widening within 6 s re-locks the filter from the
    deck's sea-state prior (``DeckNavigator._relock``) instead. The re-lock does not always find the right
    solution (on this seed the run holds, re-locked 5 times, or lands on the plate, depending on last-digit
    changes): what it must give is a safe run and no more widening than a re-lock cycle allows. (With the bearing
    rates predicted at their frame interval's midpoint, round 18, this run is not lost: the thesis' rate timing,
    ``FRAME_RATES``, keeps the lost filter this test is about.)"""
    blur = 'kind = "camera_blur", start_s = 9.0, duration_s = 3.0, blur_px = 9'
    sim, res = _static_seed5(blur, seed=7, sets=FRAME_RATES)
    assert res.metrics["outcome"] == "safe", res.metrics["outcome_reason"]
    init = [str(s) for s in sim.log.get("nav_init")["source"]]
    relocks = sum("re-locked" in s for s in init)
    widened = sum("bias variance widened" in s for s in init)
    assert relocks >= 1 and widened <= 2 * relocks + 2  # at most two widenings before each re-lock
    td = sim.log.get("touchdown")
    if "t" in td and len(td["t"]):
        assert bool(td["on_deck"][0]) and float(td["rel_speed"][0]) <= 0.5
    # the defaults (rates at their midpoint): the re-acquired filter is not lost at all
    sim, res = _static_seed5(blur, seed=7)
    init = [str(s) for s in sim.log.get("nav_init")["source"]]
    assert not any("re-locked" in s or "bias variance widened" in s for s in init)
    _on_the_plate(res)


def _on_the_plate(res, within_m: float = 0.15):
    m = res.metrics
    assert m["outcome"] == "safe", m["outcome_reason"]
    assert m["touchdown_position_error_m"] < within_m and m["hpl_bound_violations"] == 0


def test_static_deck_level_update_keeps_the_pose_through_lost_imu_samples():
    """deck-static seed 5, realistic sensors, half the IMU samples lost for 3 s from 9 s (issue 30 round 11). The
    thesis' filter (``level_deck_sigma_deg = 0``) came out of it on the second pose the four near-coplanar lights
    allow (relative pitch 15-20 deg off), fitting one light of four for 8 s with a 2 cm sigma: every round since 9
    this seed was unsafe (a hard touchdown; on the compiled prediction a fly-away, 133 m at 10 m/s). With the
    autopilot's roll and pitch fused as the level deck's: on the plate, no ``ok`` step over the HPL."""
    fault = 'kind = "imu_drop", start_s = 9.0, duration_s = 3.0, drop_probability = 0.5'
    sim, res = _static_seed5(fault, seed=5)
    _on_the_plate(res)
    e, tr = sim.log.get("estimate"), sim.log.get("truth")
    assert np.degrees(np.abs(e["euler"][:, 1] - np.interp(e["t"], tr["t"], tr["euler"][:, 1]))).max() < 5.0
    from visnav.scenarios.schema import load_scenario

    thesis = [f"faults=[{{{fault}}}]", "navigation.level_deck_sigma_deg=0", *FRAME_RATES]
    m0 = make_simulation(load_scenario("deck-static", thesis + ["navigation.range_check_sigmas=0"], 5)).run().metrics
    assert m0["outcome"] != "safe" or m0["hpl_bound_violations"] > 20  # the thesis' filter (176 steps over)
    # the range check (round 14) alone re-locks the thesis' filter off that wrong range: no step over the HPL
    m1 = make_simulation(load_scenario("deck-static", thesis, 5)).run().metrics
    assert m1["outcome"] == "safe" and m1["hpl_bound_violations"] == 0
    # the rates at their midpoint (round 18) alone keep the thesis' filter off the second pose
    mid = thesis[:2] + ["navigation.range_check_sigmas=0"]
    m2 = make_simulation(load_scenario("deck-static", mid, 5)).run().metrics
    assert m2["outcome"] == "safe" and m2["hpl_bound_violations"] == 0


def test_static_deck_level_update_keeps_the_pose_through_blur():
    """deck-static seed 4, 3 s of blur from 9 s (issue 30 round 11): without the level update the re-acquired
    filter settled on the second pose (pitch 10-15 deg off, position 0.2-0.5 m), re-locked every 3 s for 40 s
    and landed 2 m off the plate (on the compiled prediction; the readable one happened to land). Now on the
    plate with no ``ok`` step over the HPL."""
    sim, res = _static_seed5('kind = "camera_blur", start_s = 9.0, duration_s = 3.0, blur_px = 9', seed=4)
    _on_the_plate(res)


def test_static_deck_descent_without_a_fix_does_not_fly_away():
    """deck-static seed 3, half the IMU samples lost for 3 s from 9 s, the deck 1 deg off level and the level
    update at 1 deg: the trajectory ends without contact and no frame is fused from 17 s on. Descending on the last
    estimate the vehicle hovered 28 s and flew 11 m off at 8 m/s (issue 30 round 18); now the descent goes on
    blind for ``blind_land_s`` and climbs away: no touchdown off the plate, and it stays near the deck."""
    sim, res = _static_seed5('kind = "imu_drop", start_s = 9.0, duration_s = 3.0, drop_probability = 0.5', seed=3,
                             sets=("world.deck.level_error_deg=1", "navigation.level_deck_sigma_deg=1.0"))
    assert res.metrics["outcome"] == "safe", res.metrics["outcome_reason"]
    reasons = [str(r) for r in sim.log.get("integrity_reaction")["reason"]]
    assert any("in the descent" in r for r in reasons)
    v = sim.log.get("vehicle")
    assert np.abs(np.asarray(v["position"])[:, :2]).max() < 3.0
