"""`visnav ahrs` on a DataFlash log and on a tlog (the common reader io/logs.open_recording): a level vehicle
turning at a constant rate, IMU, attitude and magnetometer consistent by construction; our AHRS matches
the log's attitude, yaw included (the magnetometer's field vectors come through the mag_field stream)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from tests.io.dataflash_writer import DataFlashWriter

G = 9.80665
RATE = 0.2  # yaw rate [rad/s]
M_NED = np.array([0.2, 0.0, 0.4])  # earth field [gauss]: north and down
N, DT = 1500, 0.01  # 15 s at 100 Hz


def _body_mag(yaw):
    return np.array([np.cos(yaw) * M_NED[0], -np.sin(yaw) * M_NED[0], M_NED[2]])


def _dataflash(p):
    w = DataFlashWriter()
    for ident, factor in (("F", 1e-6), ("C", 1e-3), ("0", 1.0), ("-", 0.0)):
        w.mult(ident, factor)
    w.fmt("IMU", "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
    w.fmt("ATT", "QccC", "TimeUS,Roll,Pitch,Yaw")
    w.fmt("MAG", "QBhhh", "TimeUS,I,MagX,MagY,MagZ")
    w.fmtu("MAG", "s#GGG", "F-CCC")
    for k in range(N):
        tu, yaw = 1_000_000 + int(k * DT * 1e6), RATE * k * DT
        w.msg("IMU", tu, 0, 0.0, 0.0, RATE, 0.0, 0.0, -G)
        if k % 4 == 0:
            w.msg("ATT", tu, 0, 0, int(round(np.degrees(yaw) * 100)) % 36000)
        if k % 10 == 0:
            w.msg("MAG", tu, 0, *[int(round(v * 1000)) for v in _body_mag(yaw)])
    p.write_bytes(w.bytes())
    return p


def _tlog(p):
    from pymavlink.dialects.v20 import common

    mav, out = common.MAVLink(None, srcSystem=1, srcComponent=1), bytearray()
    for k in range(N):
        tb, yaw = 10.0 + k * DT, RATE * k * DT
        for msg in [common.MAVLink_highres_imu_message(int(tb * 1e6), 0.0, 0.0, -G, 0.0, 0.0, RATE,
                                                       *_body_mag(yaw), 1000.0, 0.0, 0.0, 0.0, 0x1FFF)] + (
                [common.MAVLink_attitude_message(int(tb * 1000), 0.0, 0.0, np.angle(np.exp(1j * yaw)), 0, 0, RATE)]
                if k % 4 == 0 else []):
            out += struct.pack(">Q", int((1.7e9 + tb) * 1e6)) + msg.pack(mav)
    p.write_bytes(bytes(out))
    return p


@pytest.mark.parametrize("make", [_dataflash, _tlog], ids=["dataflash", "tlog"])
def test_ahrs_on_dataflash_and_tlog(tmp_path, make):
    from visnav.analysis.ahrs_check import ahrs_check

    p = make(tmp_path / ("f.bin" if make is _dataflash else "f.tlog"))
    m = ahrs_check(p)
    assert m["magnetometer_source"] == "mag_field" and m["imu_samples"] == N
    assert m["roll_rms_diff_deg"] < 0.05 and m["pitch_rms_diff_deg"] < 0.05
    assert m["yaw_rms_diff_deg"] is not None and m["yaw_rms_diff_deg"] < 1.0
