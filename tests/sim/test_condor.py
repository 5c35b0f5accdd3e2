"""CONDOR scenarios end to end: the ground test of Tables 4.1-4.2 and short vision orbits."""

import math

import numpy as np
import pytest

from visnav.scenarios.schema import ScenarioError, load_scenario
from visnav.app.missions import make_simulation

KEYS = ("radius_est_error_rms_pct", "radius_est_error_max_pct", "orbit_radius_error_rms_m",
        "orbit_radius_error_max_m", "tracking_lost_s", "controller")


def test_ground_test_thesis_method_vs_ours():
    r = make_simulation(load_scenario("condor-ground-test")).run()
    m = r.metrics
    assert r.error is None and all(k in m for k in KEYS)
    # thesis' method (mirrored quadrant table, printed roll line, linear pan): within the thesis'
    # ground figures for the peak (9 %); its mean comes out near the thesis' 3 % (3.6 % in its tables)
    assert m["thesis_max_abs_error_pct"] <= 9.0
    assert m["thesis_mean_abs_error_pct"] <= 4.0
    # ours (whole-frame table, 2-D roll rotation, pinhole pan): mean <= 1 %
    assert m["ours_mean_abs_error_pct"] <= 1.0
    assert m["ours_max_abs_error_pct"] < m["thesis_max_abs_error_pct"]
    g = r.log.get("ground_test")
    assert len(g["t"]) == 12 and np.all(np.isfinite(g["ours_radius"]))
    assert math.isnan(m["orbit_radius_error_rms_m"])


def test_ground_test_ours_is_exact_without_noise():
    sc = load_scenario("condor-ground-test",
                       ["mission.ground_test.pixel_noise_px=0", "mission.gimbal.ahrs_noise_deg=0"])
    m = make_simulation(sc).run().metrics
    assert m["ours_max_abs_error_pct"] < 0.1  # only the distortion table's interpolation is left (0.02 %)
    assert m["thesis_mean_abs_error_pct"] > 2.0  # the thesis' method keeps its systematic errors


def test_short_vision_orbit_coordinated():
    sc = load_scenario("condor-orbit", ["run.duration_s=150", "mission.orbit.switch_time_s=20",
                                        "mission.orbit.transition_s=40"])
    sim = make_simulation(sc)
    r = sim.run()
    m = r.metrics
    assert r.error is None, r.error
    assert all(k in m for k in KEYS) and m["controller"] == "coordinated"
    assert m["switched_at_s"] == pytest.approx(20.0, abs=0.05)
    assert m["orbit_radius_error_rms_m"] <= 6.0  # issue target 5 m over the full 240 s run (docs/results-condor.md)
    assert m["radius_est_error_rms_pct"] <= 3.0
    assert m["tracking_lost_s"] < 2.0
    assert 0.05 < m["link_drop_fraction"] < 0.2  # the 0.33 s link drops ~10 %
    # eq. 3.24 range + bearing with the compass: its turn-on bias b turns the fix about the tent (R |b|);
    # the rest (pot and compass noise, 1 deg each: 1.9 m; the fix's 0.33-0.47 s age in 4 m/s of wind
    # flown on airspeed: ~2 m; the frame's age and range error: 2.4 m before) adds to ~4 m
    from visnav.sensors.baro import Compass

    b = next(s.bias for s in sim.sensors.values() if isinstance(s, Compass))
    assert m["position_est_error_rms_m"] < math.hypot(110.0 * b, 5.5)
    # nothing non-finite ever reached the controller
    ctl = r.log.get("control")
    vis = ctl["mode"] == "vision_orbit"
    assert np.all(np.isfinite(ctl["phi_ref"])) and np.all(np.isfinite(ctl["R"][vis]))
    assert {"truth", "estimate", "vision", "control"} <= set(r.log.streams())


@pytest.mark.slow
@pytest.mark.parametrize("logic", ["original", "modified", "coordinated"])
def test_full_orbit_three_controllers(logic):
    m = make_simulation(load_scenario("condor-orbit", [f"control.condor.orbit.logic={logic}"])).run().metrics
    if logic == "original":  # the drift of §7.2.1: orbit pushed off the tent, radius wandering
        assert m["orbit_centre_offset_m"] > 20.0 and m["orbit_radius_error_rms_m"] > 15.0
    else:
        assert m["orbit_radius_error_rms_m"] <= 5.5
    if logic == "coordinated":
        assert m["orbit_radius_error_rms_m"] <= 5.0 and m["radius_est_error_rms_pct"] <= 3.0


def test_bad_config_is_one_line():
    with pytest.raises(ScenarioError, match="logic"):
        load_scenario("condor-orbit", ["control.condor.orbit.logic=fancy"])
    with pytest.raises(ScenarioError, match="airspeed_mps"):
        load_scenario("condor-orbit", ["mission.airframe.airspeed_mps=40"])


def test_run_keeps_what_it_has_on_failure():
    # started 5.2 m up, nose down: the aircraft sinks below 5 m and the run stops, keeping its log
    sc = load_scenario("condor-orbit", ["run.duration_s=20", "mission.altitude_m=20",
                                        "mission.orbit.switch_time_s=0"])
    sim = make_simulation(sc)
    sim.vehicle.x[2] = -5.2
    sim.vehicle.x[7] = -0.6  # nose down
    r = sim.run()
    assert r.error is not None and "below 5 m" in r.error
    assert r.log.get("truth") and "error" in r.metrics
