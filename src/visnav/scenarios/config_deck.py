"""Scenario config of the ship-deck landing (seed 003, issue #6): ``[mission] type = "deck"`` (guidance, start),
the deck ``[world.deck]``, the gains ``[control.deck]``, its ``[vehicle] kind = "multirotor"``, ``[sensors.imu] kind = "multirotor-imu"``, ``[sensors.camera]
kind = "led-camera"`` and ``[navigation] kind = "deck"``."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from visnav.scenarios.base import _M
from visnav.world.deck import validate_lights
from visnav.geometry.camera import PinholeCamera
from visnav.estimation.deck import camera_rotation


#: lens distortion of eq. 5.6-5.7 in OpenCV's rational order (k1, k2, p1, p2, k3, k4, k5, k6)
DIST_EQ_5_6_5_7 = (-0.188, -0.1631, 0.00136, 0.001605, 0.1631, 0.131, -0.366, 0.2436)


class DeckWorldConfig(_M):
    motion: Literal["static", "moving"] = "static"
    sea_state: Literal["calm", "stewart", "ship_ss4"] = "stewart"
    motion_scale: float = Field(1.0, ge=0, le=3, description="multiplies the sea state's amplitudes")
    sinusoids: int = Field(1, ge=1, le=3, description="sinusoids per axis (eq. 5.11)")
    size_m: float = Field(0.6, gt=0.1, le=30, description="side of the square deck plate")
    lights_m: list[list[float]] = Field(
        default_factory=lambda: [[-0.128, 0.0, 0.0], [0.0, -0.102, 0.0], [0.0, 0.102, 0.0], [0.058, 0.0, 0.0]],
        description="deck lights, deck frame (eq. 5.10)")
    light_survey_error_m: float = Field(0.01, ge=0, le=0.2, description="1-sigma per axis of each light's true "
                                        "position about lights_m, the surveyed one the filter uses (issue 30)")
    level_error_deg: float = Field(0.0, ge=0, le=10, description="1-sigma per axis of the deck's departure from level "
                                   "(roll and pitch), drawn once per run: a landing pad on the ground, a moored "
                                   "ship's list and trim (1 deg is typical); a moving deck oscillates about it. 0: a "
                                   "level deck, the default; deck-static sets 1 deg (with the level update at 1 deg: "
                                   "NEES 19 of 20 static runs in band, 0 unsafe of 100 fault runs; on the moving "
                                   "deck it cost 1 of 60 fault-free landings, docs/results-deck.md round 18)")

    @field_validator("lights_m")
    @classmethod
    def _lights(cls, v):
        validate_lights(v)
        return v


class MultirotorConfig(_M):
    kind: Literal["multirotor"] = "multirotor"
    mass_kg: float = Field(2.4, gt=0.2, le=50)
    thrust_to_weight: float = Field(2.0, gt=1.2, le=5)
    attitude_bandwidth_rad_s: float = Field(12.0, gt=1, le=60)
    attitude_damping: float = Field(0.8, gt=0.1, le=2)
    thrust_time_constant_s: float = Field(0.04, gt=0, le=0.5)
    drag_per_s: float = Field(0.3, ge=0, le=3)
    gear_offset_m: float = Field(0.17, ge=0, le=1)
    max_tilt_deg: float = Field(20.0, gt=2, le=40)


class DeckCameraConfig(_M):
    kind: Literal["led-camera"] = "led-camera"
    width_px: int = Field(752, ge=64, le=4096)
    height_px: int = Field(480, ge=64, le=4096)
    focal_px: float = Field(420.0, gt=50, le=5000)
    distortion: bool = Field(True, description="lens distortion of eq. 5.6-5.7")
    rate_hz: float = Field(30.0, gt=1, le=120)
    position_m: list[float] = Field(default_factory=lambda: [0.101, 0.008, 0.11],
                                    description="camera in the body frame (eq. 5.9; z read as 11.0 cm)")
    depression_deg: float = Field(43.5, ge=0, le=90, description="optical axis below the body x axis (eq. 5.9: 0.76 rad)")
    yaw_deg: float = Field(-3.4, ge=-45, le=45, description="eq. 5.9: -0.06 rad")
    noise_gray: float = Field(2.0, ge=0, le=30)
    centroid_noise_px: float = Field(0.3, ge=0, le=20, description="white noise added to each blob centroid "
                                     "(real LED blobs: flicker, blooming, rolling shutter; the rendered image alone "
                                     "gives about 0.02 px)")
    blob_threshold: int = Field(150, ge=1, le=254)
    extra_blobs_deck_m: list[list[float]] = Field(default_factory=list,
                                                  description="bright points that are not deck lights (deck frame)")
    hide_light: int = Field(-1, ge=-1, le=63, description="index of a light that drops out of view")
    hide_after_s: float = Field(0.0, ge=0, le=3600)
    misalignment_deg: float = Field(1.0, ge=0, le=10, description="1-sigma per axis of the small rotation between "
                                    "the true camera mounting and the calibrated one (depression_deg, yaw_deg) the "
                                    "filter uses (issue 30)")
    focal_error_frac: float = Field(0.01, ge=0, le=0.2, description="1-sigma of the true focal length's relative "
                                    "error against focal_px (one factor for fx and fy; issue 30)")
    principal_point_error_px: float = Field(4.0, ge=0, le=50, description="1-sigma per axis of the true principal "
                                            "point about the image centre (about 1 % of the focal length)")
    time_offset_s: float = Field(0.01, ge=0, le=0.2, description="each frame shows the scene this long before "
                                 "its stamp on the IMU's clock (an uncompensated camera/IMU offset; issue 30)")

    def pinhole(self):
        """The camera's intrinsics (``geometry.camera.PinholeCamera``), with eq. 5.6-5.7 distortion if enabled."""

        dist = DIST_EQ_5_6_5_7 if self.distortion else (0.0,) * 8
        return PinholeCamera(self.width_px, self.height_px, self.focal_px, self.focal_px, (self.width_px - 1) / 2,
                             (self.height_px - 1) / 2, dist)

    def rotation(self) -> np.ndarray:
        """T_cam: body FRD -> camera axes (eq. 5.9)."""

        return camera_rotation(np.radians(self.depression_deg), np.radians(self.yaw_deg))


class DeckImuConfig(_M):
    kind: Literal["multirotor-imu"] = "multirotor-imu"
    accel_noise_mps2: float = Field(0.05, ge=0, le=2)
    gyro_noise_rad_s: float = Field(0.003, ge=0, le=0.5)
    attitude_noise_deg: float = Field(0.1, ge=0, le=5, description="autopilot roll/pitch used for T_g g (eq. 3.4): "
                                      "white noise")
    ahrs_leveled_on_accel: bool = Field(False, description="the autopilot's roll and pitch level on the "
                                        "accelerometers, whose bias tilts them by (-b_y, b_x) / g (0.3 deg for the "
                                        "0.05 m/s^2 bias); off (the default): white noise only")
    rate_hz: float = Field(100.0, gt=1, le=1000, description="IMU and autopilot attitude rate (realised as a whole "
                           "number of run.dt_s steps)")
    accel_bias_mps2: float = Field(0.05, ge=0, le=2, description="1-sigma per axis of the accelerometer bias at the "
                                   "start (left after the autopilot's calibration; issue 30)")
    gyro_bias_deg_s: float = Field(0.1, ge=0, le=10, description="1-sigma per axis of the gyro bias at the start")
    accel_bias_walk_mps2_sqrt_s: float = Field(0.002, ge=0, le=1, description="accelerometer bias random walk "
                                               "(the bias drifts by this times sqrt(t))")
    gyro_bias_walk_deg_s_sqrt_s: float = Field(0.005, ge=0, le=1, description="gyro bias random walk")


#: ``--set`` overrides that turn every simulated calibration and sensor error of issue 30 off (the ideal case)
IDEAL_DECK_SENSORS = ("world.deck.light_survey_error_m=0", "world.deck.level_error_deg=0",
                      "sensors.camera.misalignment_deg=0",
                      "sensors.camera.focal_error_frac=0", "sensors.camera.principal_point_error_px=0",
                      "sensors.camera.time_offset_s=0", "sensors.imu.accel_bias_mps2=0", "sensors.imu.gyro_bias_deg_s=0",
                      "sensors.imu.accel_bias_walk_mps2_sqrt_s=0", "sensors.imu.gyro_bias_walk_deg_s_sqrt_s=0")


class DeckFilterConfig(_M):
    kind: Literal["deck"] = "deck"
    alpha: float = Field(0.1, gt=0, le=1)
    beta: float = Field(2.0, ge=0, le=10)
    kappa: float = Field(0.0, ge=-11, le=10)
    bearing_noise_deg: float | None = Field(None, gt=0, le=20, description="sigma of each bearing (§3.1.2; the "
                                            "thesis used 2); None: from the camera's centroid noise and focal length")
    bearing_rate_noise_deg_s: float | None = Field(None, gt=0, le=100, description="sigma of each bearing rate "
                                                   "(§3.1.2; the thesis used 2); None: sqrt(2) x the bearing sigma x "
                                                   "the frame rate (a difference of two frames)")
    calibration_bearing_deg: float | None = Field(None, ge=0, le=20, description="the camera calibration's share "
                                                  "of each bearing's sigma, added to R (issue 30); None: from the "
                                                  "camera's specified misalignment, principal point and focal errors")
    light_survey_sigma_m: float | None = Field(None, ge=0, le=0.5, description="the light survey's sigma the "
                                               "filter adds to R as sigma / range; None: world.deck's "
                                               "light_survey_error_m")
    calibration_floor: bool = Field(True, description="keep the position and attitude variances at least at the "
                                    "calibration's constant share (misalignment x range, survey error over the "
                                    "layout) after each update, so that the covariance does not claim what the "
                                    "frames cannot average out")
    calibration_model: Literal["inflate", "consider"] = Field("inflate", description="how the filter takes the "
                                                              "calibration's constant errors: 'inflate' (R widened "
                                                              "and the calibration_floor) or 'consider' (Schmidt-"
                                                              "Kalman consider parameters for each light's survey "
                                                              "error, the camera's misalignment, focal, principal "
                                                              "point and time-offset errors at their specified "
                                                              "sigmas; experimental: consistent before the hand-over, "
                                                              "then the vehicle swings: deck-static seed 4 lands off "
                                                              "the plate; docs/results-deck.md round 17)")
    time_offset_in_r: bool = Field(True, description="the inflate model: the camera/IMU time offset's share of R "
                                   "(sensors.camera.time_offset_s x each bearing's rate, x the angular acceleration "
                                   "for the rates); the default since the rates are predicted at their midpoint "
                                   "(round 18: 0 unsafe of 200 deck fault runs and 80 fault-free; before, one moving "
                                   "fault run of 100 landed off the plate; docs/results-deck.md, issue 30 rounds 16-18)")
    rates_at_midpoint: bool = Field(True, description="the bearing rates, backward differences over the frame "
                                    "interval, predicted at the interval's midpoint (the state taken back half an "
                                    "interval by the process model, the gyro's mean over the interval) instead of at "
                                    "the frame with the newest gyro sample (the thesis' eq. 2.27 at the frame: 0.08 "
                                    "rad/s off in a 5 rad/s^2 swing); measured with time_offset_in_r: moving-deck "
                                    "velocity errors 24-50 % smaller, the navigator's alarms outside a fault 82 -> 2 "
                                    "(docs/results-deck.md, issue 30 round 18)")
    estimate_accel_bias: bool = Field(True, description="the accelerometer bias as three more filter states "
                                      "(random walk; prior and walk from sensors.imu's accel_bias_mps2 and "
                                      "accel_bias_walk_mps2_sqrt_s; none when accel_bias_mps2 = 0; issue 30)")
    accel_bias_test_alpha: float = Field(1e-5, ge=0, lt=0.5, description="with the bias states: the summed NIS "
                                         "of the last 6 frames above its chi2 1 - alpha quantile widens the bias "
                                         "variance to accel_bias_step_mps2^2 (a bias step); 0: no test")
    accel_bias_step_mps2: float = Field(0.2, gt=0, le=5, description="the bias sigma per axis the NIS test and a "
                                        "re-tie widen to (0.5 let fault-free approaches swing: deck-static 10 seeds with "
                                        "imu_accel_bias, 0.5: 7 safe, 0.2: 10 safe)")
    acquisition_bearing_noise_deg: float = Field(2.0, gt=0, le=20, description="bearing sigma while the filter "
                                                 "converges before hand-over (the thesis' R; from a far-off start "
                                                 "a sensor-sized R collapses P before the nonlinear errors are gone)")
    acquisition_rate_noise_deg_s: float = Field(2.0, gt=0, le=100, description="bearing-rate sigma, the same")
    gate: float = Field(13.8, gt=0, le=1000, description="Mahalanobis gate / dummy cost (eq. 3.12)")
    init: Literal["static", "truth"] = Field("static", description="eq. 5.12-5.17, or truth with small sigmas (§5.3.5)")
    converged_bearing_rms_deg: float = Field(0.2, gt=0, le=10, description="hand over only when the RMS bearing "
                                             "innovation of the last second is below this")
    yaw_hypotheses_deg: list[float] = Field(default_factory=lambda: [45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0],
                                            description="relative yaws the filter restarts from, in turn, while "
                                                        "it has not converged (manual flight)")
    ship_accel_scale: float = Field(1.0, ge=0, le=100, description="multiplies the eq. 3.7 bound in Q")
    deck_oscillator: bool = Field(False, description="the deck's roll and pitch as oscillators about level at the "
                                  "sea state's frequencies (estimation/deck.ship_oscillator), Q their frequencies' "
                                  "spread; off: the thesis' constant rates driven by eq. 3.7's bound (experimental, "
                                  "docs/results-deck.md round 18)")
    sea_state: Literal["calm", "stewart", "ship_ss4"] | None = Field(
        None, description="sea state the filter's ship process noise (eq. 3.7-3.8) is tuned for; None: the "
        "nominal one of the scenario's deck (world.deck.sea_state for a moving deck, calm for a static one). The "
        "filter never sees world.deck.motion_scale")
    motion_scale: float = Field(1.0, ge=0, le=3, description="multiplies the tuned sea state's amplitudes in Q "
                                "(the filter's assumption; world.deck.motion_scale is the world's)")
    imu_noise_scale: float = Field(1.0, ge=0, le=100)
    integrity_stale_s: float = Field(0.5, gt=0, le=60, description="integrity unusable when no frame was fused "
                                     "with at least fix_min_lights lights for this long (15 frames at 30 Hz; "
                                     "issue #18)")
    range_check_sigmas: float | None = Field(None, ge=0, le=100, description="re-lock when the range the lights "
                                             "give with the filter's attitude is off the filter's by more than this "
                                             "many sigmas (3.3: 99.9 % of a normal) on range_check_frames frames in a "
                                             "row, and let a lock-out's re-tie take the position from its frame (0: "
                                             "neither; None: 3.3 over a static deck, 0 over a moving one, whose "
                                             "level prior is no attitude to solve with; issue 30)")
    range_check_frac: float = Field(0.05, ge=0, le=1, description="the range check's share of the range in its "
                                    "sigma: the 1 cm survey over lights 0.19-0.2 m apart, the focal error, the "
                                    "attitude's")
    range_check_frames: int = Field(3, ge=1, le=100)
    tilt_check_sigmas: float | None = Field(None, ge=0, le=100, description="re-lock when the deck's tilt (the "
                                            "filter's relative attitude with the autopilot's roll and pitch) exceeds "
                                            "its sea state's bound by more than this many of the filter's attitude "
                                            "sigmas on range_check_frames frames in a row (0: no check; None: 3 over "
                                            "a moving deck, 0 over a static one, which the level update holds; "
                                            "issue 30)")
    fix_min_lights: int = Field(2, ge=1, le=4, description="a frame holds the fix with this many lights; frames "
                                "with fewer are fused but do not hold off integrity_stale_s (one light, two "
                                "equations, kept a filter 'ok' near the deck while its position ran off 0.13-0.22 m "
                                "past an HPL of 0.12-0.18 m; two give four with the attitude the filter carries; "
                                "three, a pose on their own, cost static seeds 15, 16 and 20 their landings as the "
                                "lights left the view one by one; issue 30)")
    level_deck_sigma_deg: float | None = Field(None, ge=0, le=90, description="the autopilot's roll and pitch "
                                               "fused as the deck's relative ones after each frame with this sigma "
                                               "(not in the thesis' filter); 0: off; None: 2 over a static deck "
                                               "(AHRS error and the deck's departure from level; the specified ones "
                                               "of world.deck.level_error_deg = 1 and sensors.imu.ahrs_leveled_on_"
                                               "accel give 1.05), over a moving "
                                               "one the sea state's tilt sigma spread over the frames of its "
                                               "correlation time (35 for the Stewart preset at 30 frames/s)")
    lost_nis_failures: int | None = Field(None, ge=0, le=100, description="the windowed NIS test failing this many "
                                          "times within 6 s -> the filter is lost on a wrong solution and re-locked "
                                          "(deck attitude from its prior, position and velocity widened); 0: never; "
                                          "None: 3 over a static deck, 0 over a moving one, where the zero "
                                          "ship-acceleration model (§3.1) fails the rate test that often in "
                                          "fault-free flights too (re-locking there: 1 -> 8 of 100 unsafe fault "
                                          "runs; issue 30)")
    reject_repeated_frames: bool = Field(True, description="drop a frame bit-identical to the previous one (a "
                                         "frozen video link: the camera's noise never repeats an image; issue #18). "
                                         "Turn off with camera.noise_gray = 0 over a still deck")
    camera_clock_check: bool = Field(True, description="check each frame's stamp against the camera's frame counter "
                                     "x its frame interval: a step of more than half an interval is a clock jump, "
                                     "the stream is re-stamped by the step (and health degraded for a second, "
                                     "reason given; issue #18)")
    update_gate_alpha: float = Field(1e-6, ge=0, lt=0.5, description="a frame whose whole update has a NIS above the "
                                     "chi2 1 - alpha quantile is fused without its bearing rates, or not at all "
                                     "(0: off; fault-free the largest NIS is 0.83 of the 1e-4 quantile; issue #18)")
    retie_after_frames: int = Field(3, ge=0, le=100, description="this many frames in a row with at least 3 blobs "
                                    "and every light rejected (gate lock-out: the IMU carried the filter off the "
                                    "lights, e.g. an accelerometer bias or lost IMU samples) -> position, velocity "
                                    "and deck attitude uncertainty widened (retie_sigma_*) and the frame fused "
                                    "again; 0: off (issue #18)")
    retie_sigma_m: float = Field(0.05, gt=0, le=5, description="position sigma added per axis at a re-tie")
    retie_sigma_mps: float = Field(0.1, gt=0, le=5, description="velocity sigma added per axis at a re-tie")
    retie_accel_sigma_mps2: float = Field(1.0, ge=0, le=20, description="accelerometer noise sigma (per IMU "
                                          "sample) added to Q for retie_hold_s after a re-tie: the velocity then "
                                          "follows the lights and absorbs an accelerometer bias")
    retie_hold_s: float = Field(3.0, ge=0, le=60, description="how long the widened accelerometer noise stays")
    reacquire_after_outage: bool = Field(True, description="after integrity_stale_s without a fused frame the "
                                         "deck's relative roll, pitch and rates go back to their sea-state prior "
                                         "(level deck) before the next frame: the constant-rate model would "
                                         "extrapolate them without bound (issue #18)")


class DeckGuidanceConfig(_M):
    duration_s: float = Field(15.0, gt=1, le=120, description="static deck: trajectory duration (§5.3.3)")
    touchdown_accel_mps2: float = Field(2.5, gt=0.2, le=6, description="eq. 4.1-4.3 nominal")
    hover_min_s: float = Field(5.0, ge=0, le=120)
    max_wait_s: float = Field(30.0, ge=0, le=600, description="after this long in hover, drop the lambda condition")
    lambda_max_deg: float = Field(45.0, gt=0, le=180, description="approach heading within this of the start")
    gamma_min_deg: float = Field(20.0, ge=0, le=80)
    gamma_max_deg: float = Field(60.0, ge=0, le=90, description="no near-horizontal terminal paths")
    start_tolerance_m: float = Field(0.15, gt=0, le=2)
    retarget_tau_s: float = Field(0.5, ge=0, le=10, description="low-pass of the re-aimed terminal path (0: none)")
    overshoot_m: float = Field(0.04, ge=0, le=0.5, description="static deck: aim this far below the deck surface")
    overshoot_moving_m: float = Field(0.025, ge=0, le=0.5, description="moving deck: the same (k_rho = 0.5 ends "
                                      "at a_td, so the speed at contact is about sqrt(2 a_td overshoot))")
    landing_point_m: list[float] = Field(default_factory=lambda: [0.0, 0.0, 0.0], min_length=3, max_length=3,
                                         description="the desired landing location of the gear (deck frame, "
                                         "§2.3: landing is the gear reaching it); the deck origin by default")
    flare_s: float = Field(0.3, ge=0, le=3, description="moving deck: over this last part of the trajectory turn "
                           "the commanded specific force onto the predicted deck normal (attitude before the "
                           "position and velocity feedback; 0: off, the thesis' follower throughout)")
    go_arounds: int = Field(2, ge=0, le=10, description="moving deck: a trajectory that ends without contact "
                            "returns to the start point and tries again, this many times, before the descend mode")
    go_around_hover_s: float = Field(2.0, ge=0, le=60, description="hover before the next approach of a go-around")
    static_integrity: bool = Field(True, description="static deck: the navigator unusable for integrity_unusable_s "
                                   "with more than integrity_commit_s of the straight approach to go -> hold (the "
                                   "blind hold on the IMU), and a new straight approach from where the vehicle is "
                                   "once the fix has been ok for go_around_hover_s")
    final_descent_mps: float = Field(0.25, gt=0, le=2)
    integrity_unusable_s: float = Field(0.5, ge=0, le=30, description="moving deck: navigator integrity unusable "
                                        "this long during the approach -> go-around (one of go_arounds), and no "
                                        "approach starts while it is unusable (issue #18)")
    integrity_commit_s: float = Field(1.0, ge=0, le=30, description="... except in the approach's last seconds "
                                      "(the lights leave the view near the deck): there it lands on")
    integrity_commit_m: float = Field(0.15, ge=0, le=5, description="... or within this distance of the aim point "
                                      "along the planned path (the aim is overshoot_m below the deck; the lights "
                                      "leave the view 7-11 cm above it, which on the slow static tau end is up to "
                                      "2.8 s before its end): there it lands on")
    commit_hpl_m: float = Field(0.15, gt=0, le=10, description="moving deck: no approach starts, and one with more "
                                "than integrity_commit_s to go goes around, while the navigator's horizontal "
                                "protection level of the relative position is above this (half the 0.6 m plate "
                                "less the guidance's own scatter; fault-free it stays below 0.05 m; issue #18)")
    hover_hpl_m: float = Field(0.3, gt=0, le=10, description="moving deck: a hover whose navigator's protection level "
                               "is above this holds level on the IMU as without a fix (issue #18)")
    blind_hold_s: float = Field(0.5, ge=0, le=30, description="moving deck: hover with the navigator unusable this "
                                "long -> hold level on the IMU (no position loop on a dead-reckoned estimate, "
                                "which may lead it onto the deck) until it is usable again (issue #18)")
    blind_end: Literal["land", "go-around"] = Field("land", description="moving deck: an approach that ends "
                                                    "without contact while the fix is not trusted (navigator "
                                                    "unusable, or HPL above commit_hpl_m): 'land' finishes the "
                                                    "landing (the descend mode on the deck UKF's prediction, at "
                                                    "most blind_land_s), 'go-around' flies back to the start as "
                                                    "with a fix (before round 5: the blind climb of 0.2 m/s did "
                                                    "not get clear of the heaving deck, black-out seed 7; issue #18)")
    blind_land_s: float = Field(1.0, gt=0, le=10, description="moving deck: the blind end's descent at "
                                "final_descent_mps lasts at most this long; no contact by then -> blind go-around")
    blind_climb_mps: float = Field(0.6, gt=0, le=3, description="moving deck: a hover without a fix first climbs "
                                   "at this vertical speed (on the IMU) with the horizontal velocity arrested, "
                                   "before it steers back to the start point (issue #18)")
    blind_climb_m: float = Field(0.5, ge=0, le=5, description="... by this much (above the deck's motion "
                                 "envelope), at most up to the start height by the estimate")
    descent_hold: bool = Field(True, description="descend mode: horizontal spring-damper on the touchdown point "
                                "(tilts the thrust off the deck normal; off: the vehicle drifts, moving seed 17 "
                                "missed the plate)")


class DeckControlConfig(_M):
    """The gains of the deck landing (``[control.deck]``): the tau couplings k of the trajectories (guidance/deck_approach.py)
    and the spring-damper that follows them (eq. 4.25)."""

    k_static: float = Field(0.3, gt=0, lt=0.5)
    k_rho: float = Field(0.5, gt=0, le=0.5)
    k_alpha_beta: float = Field(0.45, gt=0, lt=0.5)
    feedforward_lead_s: float = Field(0.18, ge=0, le=1, description="trajectory acceleration taken this far "
                                      "ahead (about 2 zeta / omega of the attitude loop)")
    reference_lead_s: float = Field(0.1, ge=0, le=1, description="the horizontal position and velocity reference "
                                    "taken this far ahead (the tilt's lag: with 0 the moving deck landed behind "
                                    "the point in 19 of 20 seeds, 0.1: 15, 0.18: 7 but one at 1.19 m/s; "
                                    "docs/results-deck.md round 14)")
    spring_per_s2: float = Field(6.0, gt=0, le=100, description="K of eq. 4.25")
    damper_per_s: float = Field(4.0, gt=0, le=100, description="B of eq. 4.25")


class DeckStartConfig(_M):
    distance_min_m: float = Field(1.4, gt=0.3, le=50)
    distance_max_m: float = Field(2.6, gt=0.3, le=50)
    elevation_min_deg: float = Field(35.0, gt=5, le=89)
    elevation_max_deg: float = Field(55.0, gt=5, le=89)
    heading_offset_max_deg: float = Field(45.0, ge=0, le=90, description="start azimuth around 'behind the "
                                          "deck', and so the relative heading (the vehicle faces the deck)")
    manual_s: float = Field(5.0, ge=0, le=60, description="pilot holds the start (truth) while the filter converges")
    pilot_position_noise_m: float = Field(0.0, ge=0, le=1, description="pilot = truth: white noise on the "
                                          "relative position the safety pilot sees (a sensor, "
                                          "sensors/deck_observer.py); 0: round 1's exact hold")
    level_damping_per_s: float = Field(2.0, ge=0, le=20, description="pilot = imu: the level hover's vertical "
                                       "speed (the filter's, while it uses 3 lights) damped with this gain; 0: the "
                                       "IMU's thrust loop alone (an accelerometer bias runs it off; issue 30)")
    pilot: Literal["truth", "imu"] = Field("imu", description="before hand-over: 'truth' holds the start point "
                                           "(the thesis' safety pilot / motion capture); 'imu' hovers level on the "
                                           "IMU alone (no truth), the hand-over and the first plan then use the "
                                           "filter's estimate")


class DeckMissionConfig(_M):
    """What the deck landing does (guidance, start); the deck itself is ``[world.deck]``, the gains
    ``[control.deck]``."""

    type: Literal["deck"] = "deck"
    guidance: DeckGuidanceConfig = DeckGuidanceConfig()
    start: DeckStartConfig = DeckStartConfig()


def check_landing_point(landing_point_m: list[float], deck: DeckWorldConfig) -> None:
    """The landing point (``mission.guidance.landing_point_m``) lies on the plate of ``world.deck``."""
    x, y, z = landing_point_m
    h = deck.size_m / 2
    if not (np.isfinite([x, y, z]).all() and abs(x) < h and abs(y) < h and abs(z) <= 0.1):
        raise ValueError(f"mission.guidance.landing_point_m {landing_point_m} must lie on the "
                         f"{deck.size_m} m deck plate of world.deck (|x|, |y| < {h}, |z| <= 0.1)")
