"""MAVLink telemetry logs (.tlog) written with pymavlink: HIGHRES_IMU / SCALED_IMU, ATTITUDE, GPS_RAW_INT,
SCALED_PRESSURE, DISTANCE_SENSOR (+ OPTICAL_FLOW_RAD), read into the recording's streams; damaged copies
read to the damage with one line."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from visnav.io.logs import open_recording
from visnav.io.ulog import pressure_altitude

T_UNIX = 1_700_000_000.0  # arrival clock of the ground station [s since 1970]
BOOT_AT = T_UNIX - 100.0  # the vehicle booted 100 s before the log starts


def _tlog(n=200, scaled=False, other_system=False, v1=False) -> bytes:
    """50 Hz IMU from 100 s after boot, attitude 10 Hz, GPS 5 Hz going north at 5 m/s, baro, range."""
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    if v1:
        mav.WIRE_PROTOCOL_VERSION = "1.0"
    out = bytearray()

    def put(t_boot, msg, m=mav):
        out.extend(struct.pack(">Q", int(round((BOOT_AT + t_boot + 0.003) * 1e6))) + msg.pack(m))  # 3 ms latency

    gcs = common.MAVLink(None, srcSystem=255, srcComponent=190)
    for k in range(n):
        tb = 100.0 + 0.02 * k
        if scaled:  # milli-g, mrad/s, milligauss
            put(tb, common.MAVLink_scaled_imu_message(int(tb * 1000), 10, -20, -1000, 100, -200, 300, 200, 0, 400))
        else:
            put(tb, common.MAVLink_highres_imu_message(int(tb * 1e6), 0.098, -0.196, -9.80665, 0.1, -0.2, 0.3, 0.2,
                                                       0.0, 0.4, 1000.0, 0.0, 0.0, 0.0, 0xFFFF))
        if other_system and k % 2 == 0:  # a second vehicle, fewer messages: left out
            put(tb, common.MAVLink_attitude_message(int(tb * 1000), 1.0, 1.0, 1.0, 0, 0, 0), gcs)
        if k % 5 == 0:
            put(tb, common.MAVLink_attitude_message(int(tb * 1000), 0.05, -0.1, np.radians(350.0), 0.1, -0.2, 0.3))
        if k % 10 == 0:
            j = k // 10
            put(tb, common.MAVLink_gps_raw_int_message(int((BOOT_AT + tb) * 1e6), 3 if j else 1,
                                                       int(round((47.0 + 1e-5 * j) * 1e7)), 80_000_000,
                                                       400_000 + 100 * j, 80, 120, 500, 0, 12))  # UTC time_usec
            put(tb, common.MAVLink_scaled_pressure_message(int(tb * 1000), 1000.0 - 0.12 * j, 0.0, 2000))
            put(tb, common.MAVLink_distance_sensor_message(int(tb * 1000), 20, 1000, 150 if j != 3 else 2000, 0, 0,
                                                           25, 0))
            put(tb, common.MAVLink_optical_flow_rad_message(int(tb * 1e6), 0, 100_000, 0.02, -0.01, 0.004, 0.0,
                                                            0.0, 0, 200, 0, 1.5))
    return bytes(out)


def test_tlog_streams(tmp_path):
    p = tmp_path / "flight.tlog"
    p.write_bytes(_tlog(other_system=True))
    rec = open_recording(p)
    imu = rec.streams["imu"]
    assert len(imu["t_s"]) == 200
    np.testing.assert_allclose(imu["t_s"][:3], [0.0, 0.02, 0.04], atol=1e-9)  # the vehicle's time_usec
    np.testing.assert_allclose([imu["ax_mps2"][0], imu["az_mps2"][0], imu["gz_radps"][0]], [0.098, -9.80665, 0.3],
                               rtol=1e-6)
    np.testing.assert_allclose(rec.streams["mag_field"]["mz_ga"], 0.4, rtol=1e-6)
    att = rec.streams["attitude"]  # system 1 only; yaw wrapped to (-pi, pi]
    assert len(att["t_s"]) == 40 and np.all(att["roll_rad"] == np.float32(0.05))
    assert att["yaw_rad"][0] == pytest.approx(np.radians(-10.0), abs=1e-6)
    assert any("system 1 read" in n for n in rec.notes)
    g = rec.streams["gps"]  # the first fix is not 3D; UTC time_usec: the arrival time on the boot clock
    assert len(g["t_s"]) == 19
    np.testing.assert_allclose(g["t_s"][:2], [0.2, 0.4], atol=1e-5)
    np.testing.assert_allclose(np.diff(g["n_m"]), np.radians(1e-5) * 6.3674e6, rtol=2e-3)  # 1.11 m north
    np.testing.assert_allclose(g["vn_mps"], 5.0, atol=1e-9)
    np.testing.assert_allclose(g["d_m"][:3], [0.0, -0.1, -0.2], atol=1e-4)
    b = rec.streams["baro"]  # 0.12 hPa per step: ISA pressure altitude
    want = pressure_altitude((1000.0 - 0.12 * np.arange(20)) * 100.0)
    np.testing.assert_allclose(b["altitude_m"], want - want[0], atol=1e-3)
    assert 0.95 < b["altitude_m"][1] < 1.05  # ~1 m per 0.12 hPa near 1000 hPa
    r = rec.streams["range"]
    assert np.isnan(r["range_m"][3]) and r["range_m"][0] == 1.5 and set(r["sensor"]) == {"sonar"}
    np.testing.assert_allclose(rec.streams["optical_flow"]["flow_x_radps"], 0.2, rtol=1e-6)
    assert rec.summary.startswith("flight.tlog: read 4.0 s; to the end")


def test_scaled_imu_units_and_mavlink1(tmp_path):
    p = tmp_path / "scaled.tlog"
    p.write_bytes(_tlog(n=50, scaled=True, v1=True))
    rec = open_recording(p)
    imu = rec.streams["imu"]
    np.testing.assert_allclose([imu["ax_mps2"][0], imu["az_mps2"][0]], [0.0980665, -9.80665], rtol=1e-9)  # milli-g
    np.testing.assert_allclose(imu["gz_radps"][0], 0.3, rtol=1e-9)  # mrad/s
    np.testing.assert_allclose(rec.streams["mag_field"]["mz_ga"], 0.4)  # milligauss


def test_damaged_tlogs_say_how_much_was_read(tmp_path):
    from typer.testing import CliRunner

    from visnav.cli import app

    whole = _tlog(n=500)
    cut = tmp_path / "cut.tlog"
    k = whole.index(whole[:4], int(0.6 * len(whole)))  # a record starts with the arrival time's high bytes
    cut.write_bytes(whole[: k + 20])  # 20 bytes into that record
    rec = open_recording(cut)
    assert 290 <= len(rec.streams["imu"]["t_s"]) <= 310 and f"cut at byte {k} of {k + 20}" in rec.summary
    at = int(0.5 * len(whole))
    bad = tmp_path / "garbage.tlog"
    bad.write_bytes(whole[:at] + bytes(range(0, 256, 7)) * 20 + whole[at:])
    rec = open_recording(bad)
    n_at = int(rec.summary.split("damaged at byte ")[1].split()[0])
    assert at - 80 <= n_at <= at  # the record the garbage broke
    assert len(rec.streams["imu"]["t_s"]) >= 497  # read on where records resume
    r = CliRunner().invoke(app, ["replay", str(cut), "--navigator", "witas", "--out", str(tmp_path / "r")])
    assert "Traceback" not in r.output and "cut.tlog: read" in r.stderr
    (tmp_path / "junk.tlog").write_bytes(b"\x00" * 100)
    r = CliRunner().invoke(app, ["replay", str(tmp_path / "junk.tlog"), "--navigator", "palace"])
    assert r.exit_code == 2 and "not a MAVLink telemetry log" in r.stderr


def test_replay_help_names_the_formats_it_reads():
    import re

    from typer.testing import CliRunner

    from visnav.cli import app

    r = CliRunner().invoke(app, ["replay", "--help"], env={"COLUMNS": "200"}, terminal_width=200)
    text = " ".join(re.sub(r"[│╭╮╰╯─]", " ", r.output).split())
    for fmt in (".ulg", "DataFlash .bin", "MAVLink .tlog", "ROS bag", "EuRoC folder", "geotagged photos",
                "bridge log folder"):
        assert fmt in text, fmt
