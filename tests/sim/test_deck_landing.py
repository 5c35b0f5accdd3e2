"""Closed-loop deck landings (seed 003 §5.3): static and moving deck, robustness, bad configs."""

import numpy as np
import pytest

from visnav.analysis.deck_metrics import NEES_BAND_12
from visnav.scenarios.schema import ScenarioError
from visnav.app.missions import make_simulation

from tests.deck_ideal import load_ideal_deck


def _run(name, seed, *sets):
    sim = make_simulation(load_ideal_deck(name, list(sets), seed=seed))
    res = sim.run()
    assert res.error is None, res.error
    return sim, res.metrics


def _assert_landing(m):
    assert m["landed"]
    assert m["touchdown_rel_speed_mps"] <= 0.5
    assert m["touchdown_attitude_mismatch_deg"] <= 5.0
    assert m["pos_error_final_approach_median_m"] <= 0.05
    assert m["att_error_final_approach_median_deg"] <= 3.0
    assert m["vel_error_final_approach_median_mps"] <= 0.1


def test_static_deck_landing():
    sim, m = _run("deck-static", 1)
    _assert_landing(m)
    modes = list(sim.log.get("mode")["mode"])
    assert modes == ["manual", "approach", "landed"]
    # after hand-over R is the camera's own noise: the innovations fit it (NIS per measurement ~ 1; with
    # the thesis' 2 deg it was 0.007), and with the gyro noise the velocity carries (navigator.covariance)
    # the NEES lies in the chi2(12) band (seed 1: 9.7; 23.6 without that term)
    t_ho = sim.log.get("mode")["t"][1]
    cam = sim.log.get("camera")
    ok = (cam["t"] > t_ho) & (cam["dof"] > 0)
    assert 0.5 <= np.sum(cam["nis"][ok]) / np.sum(cam["dof"][ok]) <= 2.0
    assert NEES_BAND_12[0] <= m["nees_mean"] <= NEES_BAND_12[1]
    # the estimator started from eq. 5.12 while the truth was elsewhere, and converged
    init = sim.log.get("nav_init")
    np.testing.assert_array_equal(init["x0"][0][:3], [1.0, 0.0, 1.0])
    assert init["source"][0] == "static"
    tr = sim.log.get("truth")
    assert np.linalg.norm(tr["position"][0] - [1.0, 0.0, 1.0]) > 0.3


def test_moving_deck_landing():
    sim, m = _run("deck-moving", 8)
    _assert_landing(m)
    modes = list(sim.log.get("mode")["mode"])
    assert modes[:3] == ["manual", "hover", "approach"] and modes[-1] == "landed"
    t = dict(zip(sim.log.get("mode")["mode"], sim.log.get("mode")["t"]))
    assert t["approach"] - t["hover"] >= 5.0  # hovered at least 5 s (§5.3.5)
    # landing 0.2 m behind the deck origin, three lights stay in view to contact (at the origin: none for 0.2-1.7 s)
    assert m["blind_before_touchdown_s"] <= 0.1
    assert m["touchdown_position_error_m"] <= 0.15


def test_extra_bright_blob_is_rejected():
    sim, m = _run("deck-static", 1, "mission.camera.extra_blobs_deck_m=[[0.22, 0.2, 0.0]]")
    _assert_landing(m)
    assert m["blobs_rejected"] > 20
    cam = sim.log.get("camera")
    assert np.max(cam["lights_used"]) == 4 and np.max(cam["blobs"]) == 5


def test_one_light_leaving_the_view():
    sim, m = _run("deck-static", 1, "mission.camera.hide_light=0", "mission.camera.hide_after_s=8.0")
    _assert_landing(m)
    cam = sim.log.get("camera")
    late = cam["t"] > 8.0
    assert np.max(cam["lights_used"][late]) == 3


def test_layout_with_fewer_than_three_lights_is_refused():
    with pytest.raises(ScenarioError, match="at least 3"):
        load_ideal_deck("deck-static", ["world.deck.lights_m=[[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]"])
    for key in ("navigation.gate", "mission.filter.gate"):  # the old layout's key: the error names the new one
        with pytest.raises(ScenarioError, match=r"invalid value for 'navigation\.gate': -1"):
            load_ideal_deck("deck-static", [f"{key}=-1"])


def test_filter_restarts_when_it_locks_on_a_wrong_yaw():
    """Seed 15 starts 47 deg off in relative heading. The thesis' way (the level acquisition off): from eq. 5.12's
    zero yaw the filter settles on a wrong association; the hand-over check sees its bearing innovations and
    restarts it from 45 deg. With the level acquisition (the default over a static deck) the first frame of every
    light turns the start and no restart is needed."""
    for overrides, restarted in ((["navigation.range_check_sigmas=0"], True), ([], False)):
        sim, m = _run("deck-static", 15, *overrides)
        md = sim.log.get("mode")
        assert any("restart from relative yaw 45" in r for r in md["reason"]) is restarted
        init = sim.log.get("nav_init")["source"]
        assert any(s.startswith("acquisition over a level deck; relative yaw") for s in init) is not restarted
        _assert_landing(m)
        assert m["att_error_final_approach_median_deg"] < 1.0


def _bearing_errors(sim):
    """Run ``sim`` and return the bearing and bearing-rate errors of its frames against the truth [rad]."""
    from visnav.estimation import deck as dm
    from visnav.world.deck import relative_state

    nav = sim.nav
    eb, er, orig = [], [], nav.tracker.from_pixels

    def hook(t, uv):
        fr = orig(t, uv)
        x_true = relative_state(sim.history(t), sim.world.motion.state(t))
        b, r = dm.bearings_and_rates(x_true[None], sim.world.lights, nav.cam, sim.history(t).body_rates)
        for bb, rr in zip(fr.bearings, fr.rates):
            j = np.argmin(np.linalg.norm(b[0] - bb, axis=1))
            eb.append(bb - b[0, j])
            er.append(rr - r[0, j])
        return fr

    nav.tracker.from_pixels = hook
    sim.run()
    er = np.array(er)
    return np.array(eb), er[np.all(np.isfinite(er), axis=1)]


def test_filter_noise_matches_the_simulated_camera():
    # R after hand-over is sigma_px / f and sqrt(2) sigma_b rate (closed form), and the simulated
    # bearings scatter about the truth by that sigma (hovering, so rates carry no manoeuvre lag)
    sc = load_ideal_deck("deck-static", ["run.duration_s=2.0", "mission.start.manual_s=5.0"], seed=3)
    sim = make_simulation(sc)
    sig_b, sig_r = sim.nav.cfg.tracking_sigmas
    assert sig_b == pytest.approx(np.hypot(0.3, 0.025) / 420.0, rel=1e-12)
    assert sig_r == pytest.approx(np.sqrt(2) * sig_b / 0.03, rel=1e-12)  # 30 Hz asked, every 3rd 10 ms step
    eb, er = _bearing_errors(sim)
    assert len(eb) > 200 and len(er) > 200
    assert np.std(eb) == pytest.approx(sig_b, rel=0.15)
    assert np.std(er) == pytest.approx(sig_r, rel=0.15)
    assert abs(np.mean(eb)) < 4 * sig_b / np.sqrt(eb.size)
    # the thesis' R can still be chosen
    sc2 = load_ideal_deck("deck-static", ["mission.filter.bearing_noise_deg=2", "mission.filter.bearing_rate_noise_deg_s=2"])
    assert make_simulation(sc2).nav.cfg.tracking_sigmas == pytest.approx((np.radians(2), np.radians(2)))


def test_imu_pilot_hovers_level_without_truth_before_hand_over():
    # start.pilot = "imu" (default): before the hand-over the commands are level with no heading rate,
    # thrust from the vertical-acceleration PI only; the vehicle stays near its start (no wind)
    sim = make_simulation(load_ideal_deck("deck-static", ["run.duration_s=4.0"], seed=1))
    assert sim.sc.mission.start.pilot == "imu"
    sim.run()
    cmd, veh = sim.log.get("command"), sim.log.get("vehicle")
    assert set(sim.log.get("mode")["mode"]) == {"manual"}
    np.testing.assert_array_equal(cmd["roll"], 0.0)
    np.testing.assert_array_equal(cmd["pitch"], 0.0)
    np.testing.assert_array_equal(cmd["yaw_rate"], 0.0)
    assert np.linalg.norm(veh["position"][-1] - veh["position"][0]) < 0.05
    # the truth pilot (the thesis' safety pilot) steers
    sim = make_simulation(load_ideal_deck("deck-static", ["run.duration_s=4.0", "mission.start.pilot=truth"], seed=1))
    sim.run()
    assert np.any(sim.log.get("command")["roll"] != 0.0)


def test_thesis_camera_loses_every_light_over_the_deck_origin():
    """Eq. 5.9 camera pose with the eq. 5.10 layout: over the deck origin no light is in the image.

    Closed form: the lowest image row looks atan(240 / 420) = 29.7 deg below the 43.5 deg axis, 73.2 deg
    below the body's x axis, but every light lies behind the camera (x <= 0.058 m against the camera's
    0.101 m) once the body is over the deck origin, so no height keeps one in view. Over the moving
    scenario's landing point (0.2 m behind the origin, §2.3's "desired landing location") three stay in
    view down to contact, as the thesis' deck "within view during the whole duration of the flights".
    Higher up (0.5-0.8 m) fewer are in view there: the lens distortion (applied once, as a real lens does)
    does not pull the near lights into the image the way the earlier double distortion did.
    """
    sim = make_simulation(load_ideal_deck("deck-static", seed=1))
    cam, lights, go = sim.camera, sim.world.lights, sim.extras.params.gear_offset
    assert np.max(lights[:, 0]) < sim.sc.sensors.camera.position_m[0]
    np.testing.assert_array_equal(sim.extras.landing_point, 0.0)
    land = make_simulation(load_ideal_deck("deck-moving", seed=1)).extras.landing_point
    np.testing.assert_allclose(land, [-0.2, 0.0, 0.0])
    for gear_h in (0.05, 0.1, 0.2, 0.3, 0.5, 0.8):  # level, deck frame = NED at the deck origin
        _, over = cam.project(lights, np.array([0.0, 0.0, -(gear_h + go)]), np.eye(3))
        assert not over.any()
        _, behind = cam.project(lights, np.array([-0.3, 0.0, -(gear_h + go)]), np.eye(3))
        if gear_h <= 0.3:  # the last 0.3 m: three lights in view 0.2-0.3 m behind the origin
            assert behind.sum() >= 3
            _, at_land = cam.project(lights, land - [0.0, 0.0, gear_h + go], np.eye(3))
            assert at_land.sum() >= 3


def test_landing_point_off_the_plate_is_refused():
    with pytest.raises(ScenarioError, match="landing_point_m"):
        load_ideal_deck("deck-moving", ["mission.guidance.landing_point_m=[0.35, 0.0, 0.0]"])


def test_flare_turns_the_specific_force_onto_the_deck_normal():
    """Full flare: specific force along the predicted normal with the vertical part kept; none before flare_s."""
    from visnav.control.deck import flare

    fs = load_ideal_deck("deck-moving", seed=1).mission.guidance.flare_s
    g = 9.81
    n_up = np.array([np.sin(0.1), -np.sin(0.05), 0.0])
    n_up[2] = -np.sqrt(1.0 - n_up[0] ** 2 - n_up[1] ** 2)
    a = np.array([0.7, -0.4, -1.2])
    np.testing.assert_array_equal(flare(a, n_up, fs + 0.01, fs), a)
    full = flare(a, n_up, 0.0, fs)
    f = full - [0.0, 0.0, g]
    np.testing.assert_allclose(np.cross(f, n_up), 0.0, atol=1e-12)
    assert f[2] == pytest.approx(a[2] - g)
    half = flare(a, n_up, fs / 2, fs)
    np.testing.assert_allclose(half, (a + full) / 2)
    # a normal steeper than the approach can match (asin(2.5 / 9.81) = 14.8 deg) is taken at that tilt
    steep = np.array([np.sin(np.radians(25)) * 0.6, np.sin(np.radians(25)) * 0.8, -np.cos(np.radians(25))])
    lim = np.arcsin(2.5 / g)
    f = flare(a, steep, 0.0, fs, lim) - [0.0, 0.0, g]
    assert np.degrees(np.arccos(-f[2] / np.linalg.norm(f))) == pytest.approx(np.degrees(lim), abs=1e-9)
    assert np.arctan2(f[1], f[0]) == pytest.approx(np.arctan2(0.8, 0.6), abs=1e-12) and f[2] == pytest.approx(a[2] - g)
    np.testing.assert_array_equal(flare(a, n_up, 0.0, fs, lim), full)  # 5.6 deg: within the bound, unchanged


def test_truth_start_uses_the_sensor_noise_from_the_first_frame():
    sim = make_simulation(load_ideal_deck("deck-moving", seed=1))
    sb, sr = sim.nav.cfg.tracking_sigmas
    assert sim.nav.bearing_var == pytest.approx(sb**2) and sim.nav.rate_var == pytest.approx(sr**2)
    init = sim.log.get("nav_init")  # the Vicon start: an explicit, logged NavInit from the motion capture
    assert list(init["source"]) == ["truth+noise"]
    sim = make_simulation(load_ideal_deck("deck-static", seed=1))  # eq. 5.12 start: the thesis' 2 deg while acquiring
    assert sim.nav.bearing_var == pytest.approx(np.radians(2.0) ** 2)


def test_go_around_when_the_trajectory_ends_without_contact():
    """Deck motion 1.3x the preset (the filter tuned for the nominal one), seed 7: the first trajectory ends with
    the gear above the deck. Without a go-around the descend mode holds the matched tilt and touches down 4.8 deg
    off, 0.14 m from the point; with it the vehicle climbs back to the start point and lands on the second approach within the targets."""
    # (the manual hover on the IMU alone and no reference lead, as when the test was written: with the hover's
    # vertical damping, issue 30, or the horizontal reference lead, round 14, the first trajectory of this seed
    # touches down; no level update over the moving deck either, round 15)
    # (and the bearing rates predicted at the frame, round 18: at their midpoint this seed's second approach touches
    # down 10 deg off the deck's attitude, seed 9's first 8 deg off at 0.42 m/s either way)
    sets = ("world.deck.motion_scale=1.3", "mission.start.level_damping_per_s=0", "control.deck.reference_lead_s=0",
            "navigation.level_deck_sigma_deg=0", "navigation.rates_at_midpoint=false")
    sim, m = _run("deck-moving", 7, *sets)
    modes = list(sim.log.get("mode")["mode"])
    assert modes == ["manual", "hover", "approach", "hover", "approach", "landed"]
    assert "go-around 1" in sim.log.get("mode")["reason"][3]
    assert m["touchdown_rel_speed_mps"] <= 0.5 and m["touchdown_attitude_mismatch_deg"] <= 5.0
    _, m0 = _run("deck-moving", 7, *sets, "mission.guidance.go_arounds=0")
    # (5.7 deg off before the overshoot lay along the final path, issue 30 round 10; 4.8 deg and 0.14 m after)
    assert m0["descend_s"] > 0.2 and m0["touchdown_attitude_mismatch_deg"] > 1.5 * m["touchdown_attitude_mismatch_deg"]
    assert m0["touchdown_position_error_m"] > 1.5 * m["touchdown_position_error_m"]
