"""ArduPilot DataFlash logs of both eras, written with tests/io/dataflash_writer.py: the older one stamped in
``TimeMS`` (ArduCopter <= 3.2: GPS ``TimeMS`` is the GPS time of week, ``T`` the boot time; CAM in GPS time
only; MAG in milligauss; IMU2 a message of its own), the newer one in ``TimeUS`` with instance columns and
UNIT / MULT / FMTU multipliers (GPS altitude in cm, MAG x 1e-3, no ATT: the EKF's XKF1 core 0). Damaged
copies are read to the damage with one line."""

from __future__ import annotations

import numpy as np
import pytest

from tests.io.dataflash_writer import DataFlashWriter
from visnav.io.logs import open_recording

LAT0, LON0 = 45.0, 7.0
A, E2 = 6378137.0, 6.69437999014e-3
M45 = A * (1 - E2) / (1 - E2 * np.sin(np.radians(LAT0)) ** 2) ** 1.5  # WGS-84 meridian radius at 45 deg


def _old_era(n=100) -> bytes:
    w = DataFlashWriter()
    w.fmt("IMU", "Iffffff", "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
    w.fmt("IMU2", "Iffffff", "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
    w.fmt("ATT", "IccccCCCC", "TimeMS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw")
    w.fmt("GPS", "BIHBcLLeeEefI", "Status,TimeMS,Week,NSats,HDop,Lat,Lng,RelAlt,Alt,Spd,GCrs,VZ,T")
    w.fmt("BARO", "Iffcf", "TimeMS,Alt,Press,Temp,CRt")
    w.fmt("MAG", "Ihhhhhhhhh", "TimeMS,MagX,MagY,MagZ,OfsX,OfsY,OfsZ,MOfsX,MOfsY,MOfsZ")
    w.fmt("RFND", "IHH", "TimeMS,Dist1,Dist2")
    w.fmt("CAM", "IHLLeeccC", "GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,Roll,Pitch,Yaw")
    for k in range(n):
        tm = 5000 + 20 * k  # 50 Hz from 5 s after boot [ms]
        w.msg("IMU", tm, 0.01 * k, -0.02, 0.03, 0.1, -0.2, -9.81)
        w.msg("IMU2", tm, 7.0, 7.0, 7.0, 7.0, 7.0, 7.0)
        if k % 5 == 0:
            w.msg("ATT", tm, 0, 150, 0, -250, 0, 35000, 0, 0)  # 1.5, -2.5, 350 deg in centi-degrees
            w.msg("GPS", 3, 200_000_000 + tm + 40, 1800, 9, 120, int(round((LAT0 + 1e-5 * k / 5) * 1e7)),
                  int(LON0 * 1e7), 1000, 25000 + k, 550, 0, -0.5, tm)  # TimeMS: GPS ms of week, T: boot ms
            w.msg("BARO", tm, 10.0 + 0.1 * k, 101000.0, 2000, 0.0)
            w.msg("MAG", tm, 300, 0, 400, 0, 0, 0, 0, 0, 0)  # milligauss
            w.msg("RFND", tm, 425, 0)  # centimetres
    w.msg("CAM", 200_000_000 + 5400 + 40, 1800, int(LAT0 * 1e7), int(LON0 * 1e7), 25000, 1000, 0, 0, 0)
    return w.bytes()


def _new_era(n=100) -> bytes:
    w = DataFlashWriter()
    for ident, factor in (("-", 0.0), ("0", 1.0), ("B", 1e-2), ("C", 1e-3), ("F", 1e-6), ("G", 1e-7)):
        w.mult(ident, factor)
    w.fmt("IMU", "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
    w.fmt("XKF1", "QBccCf", "TimeUS,C,Roll,Pitch,Yaw,VN")
    w.fmt("GPS", "QBBIHBcLLiffff", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw")
    w.fmt("BARO", "QBf", "TimeUS,I,Alt")
    w.fmt("MAG", "QBhhh", "TimeUS,I,MagX,MagY,MagZ")
    w.fmt("RFND", "QBCBB", "TimeUS,Instance,Dist,Stat,Orient")
    w.fmt("OF", "QBffff", "TimeUS,Qual,flowX,flowY,bodyX,bodyY")
    w.fmt("TRIG", "QBHIHLLeeeccC", "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R,P,Y")
    for name, mults in (("IMU", "F-000000"), ("XKF1", "F-BBB0"), ("GPS", "F--C--BGGB0000"), ("BARO", "F-0"),
                        ("MAG", "F-CCC"), ("RFND", "F-B--"), ("OF", "F-0000"), ("TRIG", "F---CGGBBBBBB")):
        w.fmtu(name, "s" + "-" * (len(mults) - 1), mults)
    for k in range(n):
        tu = 2_000_000 + 10_000 * k  # 100 Hz from 2 s after boot [us]
        w.msg("IMU", tu, 0, 0.01 * k, -0.02, 0.03, 0.1, -0.2, -9.81)
        w.msg("IMU", tu, 1, 9.0, 9.0, 9.0, 9.0, 9.0, 9.0)
        if k % 10 == 0:
            w.msg("XKF1", tu, 0, 150, -250, 35000, 0.0)
            w.msg("XKF1", tu, 1, 0, 0, 0, 0.0)
            w.msg("GPS", tu, 0, 3, 300_000_000, 2300, 12, 80, int(round((LAT0 + 1e-5 * k / 10) * 1e7)),
                  int(LON0 * 1e7), 12345 + k, 11.1, 90.0, -0.2, 0.0)  # Alt in cm (FMTU 'B')
            w.msg("BARO", tu, 0, 12.5)
            w.msg("MAG", tu, 0, 300, 0, 400)  # x 1e-3 (FMTU 'C'): gauss
            w.msg("RFND", tu, 0, 750, 1, 0)  # 'C': 7.50 m, facing forward
            w.msg("OF", tu, 180, 0.3, -0.1, 0.05, 0.0)
    w.msg("TRIG", 2_500_000, 0, 42, 300_000_500, 2300, int(LAT0 * 1e7), int(LON0 * 1e7), 10000, 500, 10000, 0, 0, 0)
    return w.bytes()


def test_the_older_timems_era(tmp_path):
    """ArduCopter <= 3.2 (issue 28: the old reader failed with KeyError 'TimeUS')."""
    p = tmp_path / "old.bin"
    p.write_bytes(_old_era())
    rec = open_recording(p)
    imu = rec.streams["imu"]
    assert len(imu["t_s"]) == 100  # IMU2 not mixed in
    np.testing.assert_allclose(imu["t_s"][:3], [0.0, 0.02, 0.04], atol=1e-12)
    np.testing.assert_allclose(imu["gx_radps"][:3], np.float32([0.0, 0.01, 0.02]))
    att = rec.streams["attitude"]
    np.testing.assert_allclose([att["roll_rad"][0], att["pitch_rad"][0], att["yaw_rad"][0]],
                               np.radians([1.5, -2.5, -10.0]), atol=1e-12)
    gps = rec.streams["gps"]  # stamped with T (boot ms), not TimeMS (GPS time of week)
    np.testing.assert_allclose(gps["t_s"][:2], [0.0, 0.1], atol=1e-12)
    assert gps["n_m"][1] == pytest.approx(M45 * np.radians(1e-5), abs=2e-3)
    np.testing.assert_allclose(gps["vn_mps"][0], 5.5, atol=1e-5)  # Spd 'E' 550 -> 5.50 m/s, course 0
    np.testing.assert_allclose(rec.streams["baro"]["altitude_m"][:2], np.float32([10.0, 10.5]))
    np.testing.assert_allclose(rec.streams["mag_field"]["mx_ga"], 0.3)  # milligauss -> gauss
    np.testing.assert_allclose(rec.streams["range"]["range_m"], 4.25)  # centimetres -> m
    cam = rec.streams["camera_trigger"]  # GPS time 5.440 s of week offset -> boot 5.400 s -> t = 0.4 s
    np.testing.assert_allclose(cam["t_s"], [0.4], atol=1e-9)
    assert rec.summary.startswith("old.bin: read 2.0 s; to the end") and "TimeMS era" in rec.summary
    assert "not read: IMU2" in rec.summary


def test_the_newer_timeus_era_with_fmtu_multipliers(tmp_path):
    p = tmp_path / "new.bin"
    p.write_bytes(_new_era())
    rec = open_recording(p)
    imu = rec.streams["imu"]
    assert len(imu["t_s"]) == 100 and np.all(imu["ax_mps2"] == np.float32(0.1))  # instance 1 left out
    att = rec.streams["attitude"]  # no ATT: the EKF's core 0 (XKF1 C = 0)
    assert len(att["t_s"]) == 10 and any("the attitude is XKF1's" in n for n in rec.notes)
    np.testing.assert_allclose(att["roll_rad"], np.radians(1.5), atol=1e-12)
    gps = rec.streams["gps"]  # Alt 12345 cm -> 123.45 m through FMTU 'B'; the NED down is -(alt - alt0)
    np.testing.assert_allclose(gps["d_m"][:3], [0.0, -0.1, -0.2], atol=1e-6)  # +10 cm per fix
    np.testing.assert_allclose(gps["ve_mps"], 11.1, atol=1e-5)  # course 90 deg: east
    np.testing.assert_allclose(rec.streams["mag_field"]["mz_ga"], 0.4)  # FMTU 'C'
    r = rec.streams["range"]
    np.testing.assert_allclose(r["range_m"], 7.5)
    assert set(r["sensor"]) == {"laser"}
    f = rec.streams["optical_flow"]
    np.testing.assert_allclose([f["flow_x_radps"][0], f["body_x_radps"][0], f["quality"][0]], [0.3, 0.05, 180],
                               rtol=1e-6)
    c = rec.streams["camera_trigger"]
    assert c["seq"][0] == 42 and c["t_s"][0] == pytest.approx(0.5) and c["lat_deg"][0] == pytest.approx(LAT0)
    assert "TimeUS era, FMTU multipliers" in rec.summary and "to the end" in rec.summary
    assert "not read: IMU instances 1" in rec.summary


@pytest.mark.parametrize("era", [_old_era, _new_era])
def test_damaged_copies_read_to_the_damage(tmp_path, era, capfd):
    from typer.testing import CliRunner

    from visnav.cli import app

    whole = era(n=1000)
    cut = tmp_path / "cut.bin"
    cut.write_bytes(whole[: int(0.6 * len(whole))])
    rec = open_recording(cut)
    full = open_recording(_write(tmp_path / "whole.bin", whole))
    assert 0.5 < len(rec.streams["imu"]["t_s"]) / len(full.streams["imu"]["t_s"]) < 0.7
    assert "cut at byte" in rec.summary
    at = int(0.5 * len(whole))
    bad = _write(tmp_path / "garbage.bin", whole[:at] + bytes(range(7, 250, 3)) * 10 + whole[at:])
    capfd.readouterr()
    rec = open_recording(bad)
    assert capfd.readouterr() == ("", "")  # pymavlink's C indexer would print a line per bad byte
    n_at = int(rec.summary.split("damaged at byte ")[1].split()[0])
    assert abs(n_at - at) <= 100  # within a message of where the garbage starts
    assert len(rec.streams["imu"]["t_s"]) >= 0.95 * len(full.streams["imu"]["t_s"])  # read on past it
    r = CliRunner().invoke(app, ["replay", str(cut), "--navigator", "witas", "--out", str(tmp_path / "r")])
    assert r.exit_code == 2 and "Traceback" not in r.output and "cut.bin: read" in r.stderr


def _write(p, b):
    p.write_bytes(b)
    return p


@pytest.mark.parametrize("att", ["AHR2", "NKF1", "EKF1"])
def test_attitude_and_imu_fallbacks(tmp_path, att):
    """No IMU message: IMU2; no ATT: AHR2 (degrees), NKF1 (core column C: core 0), EKF1 (older, centi-degrees)."""
    w = DataFlashWriter()
    w.fmt("IMU2", "QffffffB", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,U")
    spec = {"AHR2": ("QccCfLL", "TimeUS,Roll,Pitch,Yaw,Alt,Lat,Lng"), "NKF1": ("QBccCf", "TimeUS,C,Roll,Pitch,Yaw,VN"),
            "EKF1": ("IccCf", "TimeMS,Roll,Pitch,Yaw,VN")}[att]
    w.fmt(att, *spec)
    for k in range(50):
        tu = 1_000_000 + 20_000 * k
        w.msg("IMU2", tu, 0.0, 0.0, 0.1, 0.0, 0.0, -9.8, 1)
        if k % 5 == 0:
            if att == "AHR2":
                w.msg(att, tu, -300, 200, 9000, 10.0, int(LAT0 * 1e7), int(LON0 * 1e7))
            elif att == "NKF1":
                w.msg(att, tu, 1, 0, 0, 0, 0.0)  # core 1 first: not read
                w.msg(att, tu, 0, -300, 200, 9000, 0.0)
            else:
                w.msg(att, tu // 1000, -300, 200, 9000, 0.0)
    p = tmp_path / "f.bin"
    p.write_bytes(w.bytes())
    rec = open_recording(p)
    assert len(rec.streams["imu"]["t_s"]) == 50 and "IMU2 0.98 s" not in rec.summary and "IMU2 1.0 s" in rec.summary
    a = rec.streams["attitude"]
    assert len(a["t_s"]) == 10 and any(f"the attitude is {att}'s" in n for n in rec.notes)
    np.testing.assert_allclose([a["roll_rad"][0], a["pitch_rad"][0], a["yaw_rad"][0]], np.radians([-3.0, 2.0, 90.0]),
                               atol=1e-12)
