"""Sensors of the geo-location MAV: the pitch-roll nadir gimbal and the autopilot telemetry."""

import math

import numpy as np
import pytest

from visnav.measurements import VehicleState
from visnav.sensors.gimbal import PitchRollGimbal
from visnav.sensors.telemetry import AutopilotTelemetry
from visnav.vision.geolocation_registration import nadir_dcm


def test_perfect_gimbal_holds_nadir_at_any_attitude():
    g = PitchRollGimbal(np.random.default_rng(0), lag_s=0.0, leak=0.0, bias_roll=0.0, bias_pitch=0.0, jitter=0.0)
    e = np.array([0.4, -0.2, 1.1])
    g.step(0.01, e)
    np.testing.assert_allclose(g.residual(e), 0.0, atol=1e-12)
    np.testing.assert_allclose(g.camera_dcm(e), nadir_dcm(1.1), atol=1e-12)


def test_gimbal_residual_is_leak_plus_bias_and_turn_error():
    g = PitchRollGimbal(np.random.default_rng(0), lag_s=0.0, leak=0.1, bias_roll=0.01, bias_pitch=-0.02, jitter=0.0,
                        ahrs_turn_gain=0.3, ahrs_tau_s=1.0)
    e = np.array([0.5, 0.1, 0.0])
    for _ in range(2000):  # a sustained turn: the AHRS error settles at 0.3 x bank
        g.step(0.01, e)
    r = g.residual(e)
    # servo = -(1 - leak)(phi - 0.3 phi): residual roll = phi (1 - 0.9 x 0.7) + bias
    assert r[0] == pytest.approx(0.5 * (1 - 0.9 * 0.7) + 0.01, abs=1e-6)
    assert r[1] == pytest.approx(0.1 * 0.1 - 0.02, abs=1e-6)
    # a positive residual roll tilts the optical axis to the right of the track (east when heading north)
    ray = g.camera_dcm(e)[:, 2]
    assert ray[1] < 0 or ray[1] > 0  # defined
    assert math.degrees(math.acos(ray[2])) == pytest.approx(math.degrees(math.hypot(r[0], r[1])), abs=0.5)


def _truth(vel, yaw, pos=(10.0, 20.0, -70.0)):
    def at(t):
        return VehicleState(t, np.array(pos), np.array(vel), np.array([0.0, 0.0, yaw]), np.zeros(3), np.zeros(3))
    return at


def test_telemetry_heading_is_the_course_not_the_yaw():
    tel = AutopilotTelemetry(np.random.default_rng(1), gps_sigma_m=0.0, bias_m=0.0, vel_sigma_mps=0.0,
                             baro_bias_m=0.0, baro_noise_m=0.0)
    # yaw north, crabbing: the ground track goes north-east
    s = tel.sample(1.0, _truth([10.0, 4.0, 0.0], 0.0))
    assert s.heading == pytest.approx(math.atan2(4.0, 10.0), abs=1e-12)
    assert s.height == pytest.approx(70.0, abs=1e-12)
    assert s.ground_speed == pytest.approx(math.hypot(10, 4), abs=1e-12)
    np.testing.assert_allclose(s.position, [10.0, 20.0, -70.0], atol=1e-12)


def test_telemetry_noise_is_worse_at_low_ground_speed():
    def spread(v):
        tel = AutopilotTelemetry(np.random.default_rng(2), vel_sigma_mps=0.4)
        h = [tel.sample(0.2 * k, _truth([v, 0.0, 0.0], 0.0)).heading for k in range(1, 600)]
        return np.std(h)
    assert spread(4.0) > 2.5 * spread(15.0)


def test_downlink_adds_the_extra_heading_error_only():
    tel = AutopilotTelemetry(np.random.default_rng(3), extra_heading_deg=30.0)
    s = tel.sample(0.2, _truth([12.0, 0.0, 0.0], 0.0))
    d = [tel.downlink(s).heading - s.heading for _ in range(400)]
    assert max(np.abs(d)) <= math.radians(30.0) + 1e-12 and np.std(d) > math.radians(12.0)


def test_attitude_estimate_bias_tilts_the_camera_by_the_bias():
    # the servos counter the autopilot's estimate: a biased estimate leaves the camera tilted by -(1-leak) x bias
    g = PitchRollGimbal(np.random.default_rng(0), lag_s=0.0, leak=0.1, bias_roll=0.0, bias_pitch=0.0, jitter=0.0,
                        ahrs_bias_roll=0.05, ahrs_bias_pitch=-0.03)
    e = np.array([0.2, 0.05, 0.7])
    g.step(0.01, e)
    np.testing.assert_allclose(g.residual(e), 0.1 * e[:2] - 0.9 * np.array([0.05, -0.03]), atol=1e-12)


def _moving(v=(10.0, 0.0, 0.0)):
    def at(t):
        return VehicleState(t, np.array([v[0] * t, v[1] * t, -70.0]), np.array(v), np.zeros(3), np.zeros(3), np.zeros(3))
    return at


def test_gps_fixes_are_held_between_updates_and_the_link_delays_the_whole_sample():
    tel = AutopilotTelemetry(np.random.default_rng(1), gps_sigma_m=0.0, bias_m=0.0, vel_sigma_mps=0.0,
                             baro_bias_m=0.0, baro_noise_m=0.0, gps_delay_s=0.1, gps_rate_hz=4.0, link_delay_s=0.3)
    truth = _moving()
    for t in np.arange(1.0, 3.0, 0.2):
        s = tel.sample(float(t), truth)
        tf = np.floor(t * 4.0 + 1e-9) / 4.0  # the last 4 Hz fix
        assert s.t == pytest.approx(t) and s.position[0] == pytest.approx(10.0 * (tf - 0.1), abs=1e-9)
        assert 10.0 * (t - 0.1 - 0.25) - 1e-9 <= s.position[0] <= 10.0 * (t - 0.1) + 1e-9
        d = tel.downlink(s)  # the ground station stamps it on arrival, 0.3 s later
        assert d.t == pytest.approx(t + 0.3) and np.array_equal(d.position, s.position)


def test_servo_dead_band_leaves_the_camera_half_the_band_behind_on_the_side_it_came_from():
    # roll ramps 0 -> 10 deg, then back to 5 deg: with a 2 deg dead band (no lag, leak or bias) the servo
    # trails the command by 1 deg while it moves, and a reversal leaves it 1 deg on the other side
    db = math.radians(2.0)
    g = PitchRollGimbal(np.random.default_rng(0), lag_s=0.0, leak=0.0, bias_roll=0.0, bias_pitch=0.0, jitter=0.0,
                        deadband=db)
    for phi in np.radians(np.linspace(0.0, 10.0, 201)):
        g.step(0.01, np.array([phi, 0.0, 0.0]))
    assert g.residual(np.array([math.radians(10.0), 0.0, 0.0]))[0] == pytest.approx(0.5 * db, abs=1e-12)
    for phi in np.radians(np.linspace(10.0, 9.5, 11)):  # inside the band: nothing moves
        g.step(0.01, np.array([phi, 0.0, 0.0]))
    assert g.servo[0] == pytest.approx(-math.radians(10.0) + 0.5 * db, abs=1e-12)
    for phi in np.radians(np.linspace(9.5, 5.0, 101)):
        g.step(0.01, np.array([phi, 0.0, 0.0]))
    assert g.residual(np.array([math.radians(5.0), 0.0, 0.0]))[0] == pytest.approx(-0.5 * db, abs=1e-12)
    assert g.residual(np.array([math.radians(5.0), 0.0, 0.0]))[1] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("err_deg", [2.0, 7.5])
def test_injected_attitude_error_gives_h_tan_e_in_the_map_based_method(axis, err_deg):
    """The chain the map-based samples go through: the autopilot's attitude estimate off by e (roll or pitch), the
    gimbal (no lag, leak, dead band, mount error) counters the estimate and leaves the camera tilted by e; the
    ground station casts the tracked pixel from the exact position, height and yaw as a nadir view (Fig. 7.2):
    a target under the aircraft is placed h tan(e) away, across the track for roll, along it for pitch."""
    from visnav.app.geoloc_parts import mav_camera
    from visnav.scenarios.config_geolocation import MavCameraConfig
    from visnav.vision.geolocation_registration import map_based_target

    cam = mav_camera(MavCameraConfig())  # 720 x 576, 53 deg, k1 = -0.22, k2 = 0.06
    e, h, yaw = math.radians(err_deg), 70.0, math.radians(30.0)
    bias = [0.0, 0.0]
    bias[axis] = e
    g = PitchRollGimbal(np.random.default_rng(0), lag_s=0.0, leak=0.0, bias_roll=0.0, bias_pitch=0.0, jitter=0.0,
                        ahrs_bias_roll=bias[0], ahrs_bias_pitch=bias[1])
    euler = np.array([0.0, 0.0, yaw])  # level flight: the estimate reads e, the servo turns the camera by -e
    g.step(0.02, euler)
    pos = np.array([12.0, -7.0, -h])
    target = pos[:2]  # straight below the aircraft
    uv = cam.project(((np.array([*target, 0.0]) - pos) @ g.camera_dcm(euler)).reshape(1, 3))[0]
    est = map_based_target(cam, uv, pos[:2], h, yaw)
    err = est - target
    assert np.linalg.norm(err) == pytest.approx(h * math.tan(e), abs=1e-6)
    track = np.array([math.cos(yaw), math.sin(yaw)])
    along = float(err @ track)
    assert abs(along if axis == 0 else np.linalg.norm(err - along * track)) < 1e-6  # roll: across, pitch: along
