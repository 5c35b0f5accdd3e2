"""PX4 ULog layouts of every generation, written with tests/io/ulog_writer.py (no shared data needed):
separate sensor topics, sensor_combined with and without magnetometer / barometer (and with a field that
is all invalid), GPS in both field generations, sensor_baro pressure, distance sensor, optical flow,
camera events, appended data, ~1 Hz logging, and damaged files read to the damage with one line."""

from __future__ import annotations

import numpy as np
import pytest

from tests.io.ulog_writer import ULogWriter
from visnav.io.logs import open_recording
from visnav.io.ulog import pressure_altitude, read_ulog

T0 = 1_000_000  # [us] first IMU sample
INVALID = 2**31 - 1  # PX4's "no sample in this message" relative timestamp
G = 9.80665


def _gyro(t):  # a body rate that varies, rad/s
    return np.column_stack([0.1 * np.sin(t), 0.05 * np.cos(2 * t), 0.02 + 0 * t])


def _attitude(w: ULogWriter, n: int = 11, dt_us: int = 100_000):
    a = w.topic("vehicle_attitude", [("uint64_t", "timestamp_sample"), ("float", "q[4]")])
    for k in range(n):
        w.data(a, T0 + k * dt_us, T0 + k * dt_us, 1.0, 0.0, 0.0, 0.0)


def _combined(w: ULogWriter, n=201, dt_us=5000, mag=False, baro=None):
    """sensor_combined; ``mag``: magnetometer_ga[3] + its relative stamp; ``baro``: 'valid' or 'invalid'
    (every baro_timestamp_relative INT32 max: the sensor was never sampled)."""
    f = [("float", "gyro_rad[3]"), ("int32_t", "accelerometer_timestamp_relative"), ("float", "accelerometer_m_s2[3]")]
    f += [("float", "magnetometer_ga[3]"), ("int32_t", "magnetometer_timestamp_relative")] if mag else []
    f += [("float", "baro_alt_meter"), ("int32_t", "baro_timestamp_relative")] if baro else []
    sc = w.topic("sensor_combined", f)
    t = np.arange(n) * dt_us * 1e-6
    g = _gyro(t)
    for k in range(n):
        vals = [*g[k], 0, 0.0, 0.0, -G]
        if mag:  # a new magnetometer sample every 4th message, held (negative age) in between
            vals += [0.2, 0.0, 0.4, -(k % 4) * dt_us]
        if baro:
            vals += [100.0 + 0.01 * (k - k % 4), INVALID if baro == "invalid" else -(k % 4) * dt_us]
        w.data(sc, T0 + k * dt_us, *vals)
    return t, g


def _write(tmp_path, w: ULogWriter, name="f.ulg", **kw):
    p = tmp_path / name
    p.write_bytes(w.bytes(**kw))
    return p


def test_an_all_invalid_baro_field_leaves_the_baro_out_with_a_note(tmp_path):
    """issue 28: the old reader ended in IndexError (an empty series in _relative_series)."""
    w = ULogWriter()
    _combined(w, mag=True, baro="invalid")
    _attitude(w)
    d = read_ulog(_write(tmp_path, w))
    assert d.baro_t is None and any("sensor_combined: no barometer" in n for n in d.notes)
    assert d.mag_source == "sensor_combined" and len(d.mag_t) == 51  # every 4th of 201 messages
    np.testing.assert_allclose(d.mag[0], [0.2, 0.0, 0.4], rtol=1e-6)


def test_sensor_combined_with_valid_baro_and_without_mag(tmp_path):
    w = ULogWriter()
    _combined(w, baro="valid")
    _attitude(w)
    d = read_ulog(_write(tmp_path, w))
    assert d.mag is None and d.baro_source == "sensor_combined" and len(d.baro_t) == 51
    np.testing.assert_allclose(np.diff(d.baro_alt), 0.04, atol=1e-4)  # 0.01 m per message, sampled every 4th


def test_separate_sensor_topics_without_sensor_combined(tmp_path):
    """Newer PX4 logs only sensor_gyro / sensor_accel / sensor_mag; the old reader refused them."""
    w = ULogWriter()
    gy = w.topic("sensor_gyro", [("uint64_t", "timestamp_sample"), ("uint32_t", "device_id"), ("float", "x"),
                                 ("float", "y"), ("float", "z")])
    ac = w.topic("sensor_accel", [("uint64_t", "timestamp_sample"), ("uint32_t", "device_id"), ("float", "x"),
                                  ("float", "y"), ("float", "z")])
    mg = w.topic("sensor_mag", [("uint64_t", "timestamp_sample"), ("float", "x"), ("float", "y"), ("float", "z")])
    t = np.arange(400) * 0.0025
    g = _gyro(t)
    for k in range(400):
        ts = T0 + k * 2500
        w.data(gy, ts + 100, ts, 1, *g[k])
        w.data(ac, ts + 1350, ts + 1250, 2, 0.1 * t[k], 0.0, -G)  # a ramp, sampled half a period later
        if k % 10 == 0:
            w.data(mg, ts, ts, 0.2, 0.1, 0.4)
    _attitude(w)
    d = read_ulog(_write(tmp_path, w))
    assert d.imu_source == "sensor_gyro+sensor_accel"
    # the first gyro sample precedes the first accelerometer sample: the IMU starts at the second
    assert len(d.gyro) == 399 and d.t0_us == T0 + 2500
    np.testing.assert_allclose(d.gyro, g[1:], rtol=1e-6, atol=1e-7)
    # the accelerometer interpolated onto the gyro stamps: the ramp 0.1 (t - 1.25 ms) at the gyro's instants
    np.testing.assert_allclose(d.accel[:, 0], 0.1 * (d.imu_t + 0.0025 - 0.00125), atol=1e-6)
    assert d.mag_source == "sensor_mag" and len(d.mag_t) == 40


def test_gps_both_generations_baro_pressure_range_flow_and_camera(tmp_path):
    """vehicle_gps_position in the older fields (lat/lon 1e-7 deg, alt mm), sensor_baro pressure,
    distance_sensor, the older optical_flow and camera_trigger: the recording's streams."""
    w = ULogWriter()
    _combined(w)
    _attitude(w)
    gp = w.topic("vehicle_gps_position", [("int32_t", "lat"), ("int32_t", "lon"), ("int32_t", "alt"),
                                          ("float", "vel_n_m_s"), ("float", "vel_e_m_s"), ("float", "vel_d_m_s"),
                                          ("bool", "vel_ned_valid"), ("uint8_t", "fix_type")])
    for k in range(6):  # 1e-5 deg of latitude per 0.2 s going north; the first fix is 2D
        w.data(gp, T0 + k * 200_000, 473_977_000 + 100 * k, 85_000_000, 488_000 + 10 * k, 5.5, 0.0, -0.05, True,
               2 if k == 0 else 3)
    ba = w.topic("sensor_baro", [("uint64_t", "timestamp_sample"), ("float", "pressure"), ("float", "temperature")])
    for k in range(5):
        w.data(ba, T0 + k * 200_000, T0 + k * 200_000, 89874.6 - 12.0 * k, 20.0)
    ds = w.topic("distance_sensor", [("float", "min_distance"), ("float", "max_distance"),
                                     ("float", "current_distance"), ("uint8_t", "type"), ("uint8_t", "orientation")])
    for k in range(5):
        w.data(ds, T0 + k * 200_000, 0.2, 10.0, [1.5, 1.6, 12.0, 1.8, 1.9][k], 0, 25)
    of = w.topic("optical_flow", [("float", "pixel_flow_x_integral"), ("float", "pixel_flow_y_integral"),
                                  ("float", "gyro_x_rate_integral"), ("float", "gyro_y_rate_integral"),
                                  ("uint32_t", "integration_timespan"), ("uint8_t", "quality")])
    for k in range(5):
        w.data(of, T0 + k * 200_000, 0.02, -0.01, 0.004, 0.0, 100_000, 200)
    ct = w.topic("camera_trigger", [("uint32_t", "seq"), ("bool", "feedback")])
    for k in range(3):
        w.data(ct, T0 + 100_000 + k * 300_000, k, True)
    p = _write(tmp_path, w)
    rec = open_recording(p)
    g = rec.streams["gps"]
    assert len(g["t_s"]) == 5 and g["t_s"][0] == pytest.approx(0.2)
    # 1e-5 deg of latitude = 1.11 m north (WGS-84 meridian radius at 47.4 deg: 6.3674e6 m)
    np.testing.assert_allclose(np.diff(g["n_m"]), np.radians(1e-5) * 6.3674e6, rtol=2e-3)
    np.testing.assert_allclose(g["d_m"], -0.01 * np.arange(5), atol=1e-5)  # (+ the earth's curvature, 1.5 um)
    np.testing.assert_allclose(g["vn_mps"], 5.5)
    b = rec.streams["baro"]  # ISA: 89874.6 Pa is 1000 m; 12 Pa ~ 1.05 m higher each sample
    assert pressure_altitude(89874.6) == pytest.approx(1000.0, abs=0.1)
    np.testing.assert_allclose(b["altitude_m"], pressure_altitude(89874.6 - 12.0 * np.arange(5)) - 1000.0 + 0 * 0
                               - (pressure_altitude(89874.6) - 1000.0), atol=1e-3)
    r = rec.streams["range"]
    np.testing.assert_array_equal(np.isnan(r["range_m"]), [False, False, True, False, False])  # 12 m > max 10 m
    assert set(r["sensor"]) == {"sonar"}
    f = rec.streams["optical_flow"]
    np.testing.assert_allclose(f["flow_x_radps"], 0.2, rtol=1e-6)  # 0.02 rad over 0.1 s
    np.testing.assert_allclose(f["body_x_radps"], 0.04, rtol=1e-5)
    np.testing.assert_allclose(rec.streams["camera_trigger"]["seq"], [0, 1, 2])
    # streams no navigator consumes are never delivered in a replay
    _, _, si, _ = rec.delivery()
    from visnav.io.recording import STREAM_ORDER

    assert STREAM_ORDER["optical_flow"] not in si and STREAM_ORDER["camera_trigger"] not in si
    assert STREAM_ORDER["gps"] in si


def test_newer_gps_fields_vehicle_air_data_vehicle_optical_flow_camera_capture(tmp_path):
    w = ULogWriter()
    _combined(w)
    _attitude(w)
    sg = w.topic("sensor_gps", [("uint64_t", "timestamp_sample"), ("double", "latitude_deg"),
                                ("double", "longitude_deg"), ("double", "altitude_msl_m"), ("uint8_t", "fix_type")])
    for k in range(4):  # timestamp_sample left at 0, as PX4 1.14's GPS driver does: the message stamp is used
        w.data(sg, T0 + k * 250_000, 0, 47.0, 8.0 + 1e-5 * k, 400.0, 3)
    ad = w.topic("vehicle_air_data", [("uint64_t", "timestamp_sample"), ("float", "baro_alt_meter")])
    for k in range(4):
        w.data(ad, T0 + k * 250_000, T0 + k * 250_000, 400.0 + k)
    vf = w.topic("vehicle_optical_flow", [("uint64_t", "timestamp_sample"), ("float", "pixel_flow[2]"),
                                          ("float", "delta_angle[3]"), ("float", "distance_m"),
                                          ("uint32_t", "integration_timespan_us"), ("uint8_t", "quality")])
    for k in range(3):
        w.data(vf, T0 + k * 100_000, T0 + k * 100_000, 0.01, 0.03, 0.0, 0.002, 0.0, 2.5, 50_000, 255)
    cc = w.topic("camera_capture", [("uint32_t", "seq"), ("double", "lat"), ("double", "lon"), ("float", "alt")])
    w.data(cc, T0 + 500_000, 7, 47.0, 8.0, 405.0)
    rec = open_recording(_write(tmp_path, w))
    g = rec.streams["gps"]
    np.testing.assert_allclose(g["t_s"], [0, 0.25, 0.5, 0.75])
    # 1e-5 deg of longitude at 47 deg = 0.7596 m east (prime-vertical radius 6.3887e6 m x cos 47 deg)
    np.testing.assert_allclose(np.diff(g["e_m"]), np.radians(1e-5) * 6.3887e6 * np.cos(np.radians(47.0)), rtol=2e-3)
    np.testing.assert_allclose(rec.streams["baro"]["altitude_m"], [0, 1, 2, 3], atol=1e-5)
    f = rec.streams["optical_flow"]
    np.testing.assert_allclose(f["flow_y_radps"], 0.6, rtol=1e-6)
    np.testing.assert_allclose(f["body_y_radps"], 0.04, rtol=1e-5)
    np.testing.assert_allclose(f["distance_m"], 2.5)
    c = rec.streams["camera_trigger"]
    assert c["seq"][0] == 7 and c["alt_m"][0] == 405.0
    assert "GPS 4 (sensor_gps)" in rec.summary and "camera events 1 (camera_capture)" in rec.summary


def test_appended_data_and_1hz_logging(tmp_path):
    """A log with appended data (PX4's fault log after an unfinished message) is read to its end, not
    called damaged (the old reader did). At ~1 Hz (PX4's low-rate profile) the log reads the same way."""
    w = ULogWriter()
    _combined(w, n=40, dt_us=1_000_000)  # 1 Hz sensor_combined for 39 s
    _attitude(w, n=40, dt_us=1_000_000)
    p = _write(tmp_path, w, appended_at=79)  # the last (attitude) message unfinished
    d = read_ulog(p)
    assert len(d.imu_t) == 40 and d.imu_t[-1] == pytest.approx(39.0) and len(d.att_t) == 39
    assert not d.truncated and "to the end" in d.summary and d.notes == ["no magnetometer (vehicle_magnetometer, "
                                                                         "sensor_mag, sensor_combined.magnetometer_ga): "
                                                                         "yaw is gyro-only"]


def test_damaged_files_are_read_to_the_damage_with_one_line(tmp_path):
    from typer.testing import CliRunner

    from visnav.cli import app

    w = ULogWriter()
    _combined(w, n=2001)
    _attitude(w, n=101)
    gp = w.topic("sensor_gps", [("double", "latitude_deg"), ("double", "longitude_deg"), ("double", "altitude_msl_m")])
    ad = w.topic("vehicle_air_data", [("float", "baro_alt_meter")])
    for k in range(50):
        w.data(gp, T0 + k * 200_000, 47.0 + 1e-6 * k, 8.0, 400.0)
        w.data(ad, T0 + k * 200_000 + 1, 400.0)
    whole = w.bytes()
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(whole[: int(0.6 * len(whole))])
    d = read_ulog(cut)
    assert d.truncated and 0.4 * 10 < d.imu_t[-1] < 0.7 * 10
    assert d.summary.startswith(f"cut.ulg: read {d.imu_t[-1]:.1f} s; cut at byte ")
    at = int(0.5 * len(whole))
    bad = tmp_path / "garbage.ulg"
    bad.write_bytes(whole[:at] + bytes(range(200, 256)) * 20 + whole[at:])
    d = read_ulog(bad)
    n_at = int(d.summary.split("damaged at byte ")[1].split()[0])
    assert d.truncated and at <= n_at <= at + 60  # within a message of where the garbage starts
    r = CliRunner().invoke(app, ["replay", str(cut), "--navigator", "witas", "--out", str(tmp_path / "r")])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "cut.ulg: read" in r.stderr and "witas navigator needs frames.csv" in r.stderr
