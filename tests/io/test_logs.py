"""Flight logs read into recordings: ArduPilot DataFlash (crafted with FMT messages), ROS 1 / ROS 2 bags
(written with rosbags), PX4 ULog (the shared real log)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from visnav.io.logs import headings_from_mag, open_recording
from visnav.io.recording import RecordingError

_STRUCT = {"Q": "Q", "B": "B", "f": "f", "c": "h", "C": "H", "L": "i", "h": "h", "I": "I", "H": "H"}
FORMATS = {  # type id, name, DataFlash format, columns
    "IMU": (129, "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ"),
    "ATT": (130, "QccC", "TimeUS,Roll,Pitch,Yaw"),
    "BARO": (131, "QBf", "TimeUS,I,Alt"),
    "MAG": (132, "QBhhh", "TimeUS,I,MagX,MagY,MagZ"),
    "GPS": (133, "QBBIHLLffff", "TimeUS,I,Status,GMS,GWk,Lat,Lng,Alt,Spd,GCrs,VZ"),
    "RFND": (134, "QBfB", "TimeUS,Instance,Dist,Orient"),
}


def _sfmt(df: str) -> str:
    return "<" + "".join(_STRUCT[c] for c in df)


def _fmt(name: str) -> bytes:
    tid, df, cols = FORMATS[name]
    return b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", tid, 3 + struct.calcsize(_sfmt(df)), name.encode(),
                                         df.encode(), cols.encode())


def _msg(name: str, *vals) -> bytes:
    tid, df, _ = FORMATS[name]
    return b"\xa3\x95" + bytes([tid]) + struct.pack(_sfmt(df), *vals)


LAT0, LON0 = 45.0, 7.0
YAW = np.radians(-10.0)


def _dataflash(path, n=200, truncate=False):
    out = b"".join(_fmt(k) for k in FORMATS)
    for k in range(n):
        tu = 1_000_000 + 10_000 * k  # 100 Hz from t = 1 s
        out += _msg("IMU", tu, 0, 0.01 * k, -0.02, 0.03, 0.1, -0.2, -9.81)
        out += _msg("IMU", tu, 1, 9.0, 9.0, 9.0, 9.0, 9.0, 9.0)  # a second IMU: not read
        if k % 2 == 0:
            out += _msg("ATT", tu, 150, -250, 35000)  # 1.5 deg, -2.5 deg, 350 deg (centi-degrees)
        if k % 10 == 0:
            out += _msg("BARO", tu, 0, 12.5 + 0.01 * k)
            out += _msg("MAG", tu, 0, int(300 * np.cos(YAW)), int(-300 * np.sin(YAW)), 400)
            out += _msg("GPS", tu, 0, 3, 300_000_000 + tu // 1000, 2300, int(round((LAT0 + 1e-5 * k / 10) * 1e7)), int(LON0 * 1e7), 100.0, 11.1, 0.0, 0.0)
            out += _msg("RFND", tu, 0, 4.25, 25)
    if truncate:
        out = out[:-5]
    path.write_bytes(out)
    return path


def test_dataflash_messages_become_typed_streams(tmp_path):
    rec = open_recording(_dataflash(tmp_path / "flight.bin"))
    imu = rec.streams["imu"]
    assert len(imu["t_s"]) == 200  # instance 1 left out
    np.testing.assert_allclose(imu["t_s"][:3], [0.0, 0.01, 0.02])
    np.testing.assert_allclose(imu["gx_radps"][:3], np.float32([0.0, 0.01, 0.02]))
    np.testing.assert_allclose(imu["az_mps2"], np.float32(-9.81))
    att = rec.streams["attitude"]
    np.testing.assert_allclose([att["roll_rad"][0], att["pitch_rad"][0], att["yaw_rad"][0]],
                               np.radians([1.5, -2.5, -10.0]), atol=1e-12)
    gps = rec.streams["gps"]
    assert gps["n_m"][0] == 0.0
    # 1e-5 deg of latitude at 45 deg: M dphi with the WGS84 meridian radius M = a(1-e2)/(1-e2 sin^2)^1.5
    a, e2 = 6378137.0, 6.69437999014e-3
    M = a * (1 - e2) / (1 - e2 * np.sin(np.radians(LAT0)) ** 2) ** 1.5
    assert gps["n_m"][1] == pytest.approx(M * np.radians(1e-5), abs=2e-3)
    np.testing.assert_allclose([gps["vn_mps"][0], gps["ve_mps"][0], gps["vd_mps"][0]], [11.1, 0.0, 0.0], atol=1e-5)
    assert set(rec.streams["range"]["sensor"]) == {"sonar"} and rec.streams["range"]["range_m"][0] == 4.25
    np.testing.assert_allclose(rec.streams["baro"]["altitude_m"][:2], np.float32([12.5, 12.6]))
    # level within 2.5 deg: the tilt-compensated heading is close to the field's yaw
    assert rec.streams["magnetometer"]["heading_rad"][0] == pytest.approx(YAW, abs=0.05)


def test_dataflash_truncated_is_read_up_to_the_damage(tmp_path):
    rec = open_recording(_dataflash(tmp_path / "cut.bin", n=191, truncate=True))  # ends with an RFND
    assert len(rec.streams["imu"]["t_s"]) == 191
    assert len(rec.streams["range"]["t_s"]) == 19  # the 20th RFND was cut
    assert any("RFND: log truncated" in n for n in rec.notes)


def test_dataflash_replays_on_palace(tmp_path):
    from visnav.io.replay import replay

    rec = open_recording(_dataflash(tmp_path / "flight.bin"))
    res = replay(rec, "palace")
    est = res.log.get("estimate")
    ok = np.asarray(est["valid"], bool)
    assert ok.sum() >= 15 and res.metrics["imu_samples"] == 200
    gps = rec.streams["gps"]  # 1.1 m north per fix at 10 Hz: the GPS-mode filter follows the fixes
    north = np.interp(est["t"][ok], gps["t_s"], gps["n_m"])
    assert np.max(np.abs(np.asarray(est["position"])[ok][:, 0] - north)) < 1.0


def test_headings_from_mag_equal_the_eskf_scalar_version():
    from visnav.estimation.eskf import heading_from_mag

    rng = np.random.default_rng(5)
    m = rng.normal(size=(50, 3))
    r, p = rng.uniform(-0.5, 0.5, 50), rng.uniform(-0.5, 0.5, 50)
    want = [heading_from_mag(m[i], r[i], p[i], 0.1) for i in range(50)]
    np.testing.assert_allclose(headings_from_mag(m, r, p, 0.1), want, atol=1e-12)


def test_not_a_log(tmp_path):
    (tmp_path / "x.bin").write_bytes(b"\x00" * 10)
    with pytest.raises(RecordingError, match="x.bin: no IMU messages|x.bin: not a readable"):
        open_recording(tmp_path / "x.bin")
