"""Flight logs read into recordings: ArduPilot DataFlash (crafted with FMT messages), ROS 1 / ROS 2 bags
(written with rosbags), PX4 ULog (the shared real log)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from visnav.io.logs import open_recording
from visnav.io.streams import headings_from_mag
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
            lat = int(round((LAT0 + 1e-5 * k / 10) * 1e7))
            out += _msg("GPS", tu, 0, 3, 300_000_000 + tu // 1000, 2300, lat, int(LON0 * 1e7), 100.0, 11.1, 0.0, 0.0)
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
    from visnav.app.replay import replay

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


def _write_bag(path, ros1: bool, n=100):
    """IMU 100 Hz (level, facing east in ENU), NavSatFix 10 Hz, Range 10 Hz, mono8 images 5 Hz."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    cov = np.zeros(9)

    def header(ns):
        st = Time(sec=ns // 10**9, nanosec=ns % 10**9)
        return Header(seq=0, stamp=st, frame_id="base") if ros1 else Header(stamp=st, frame_id="base")

    if ros1:
        from rosbags.rosbag1 import Writer
        w = Writer(path)
        ser = ts.serialize_ros1
    else:
        from rosbags.rosbag2 import Writer
        w = Writer(path, version=8)
        ser = ts.serialize_cdr
    rng = np.random.default_rng(0)
    images = []
    t0 = 1_700_000_000 * 10**9
    with w:
        types = {"imu": "sensor_msgs/msg/Imu", "fix": "sensor_msgs/msg/NavSatFix", "rng": "sensor_msgs/msg/Range",
                 "img": "sensor_msgs/msg/Image"}
        c = {k: w.add_connection(f"/{k}", v, typestore=ts) for k, v in types.items()}
        for k in range(n):
            ns = t0 + k * 10**7
            recv = ns + 2 * 10**6  # received 2 ms after the instant it describes
            m = T[types["imu"]](header=header(ns), orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
                                orientation_covariance=cov,
                                angular_velocity=V3(x=0.1, y=0.2, z=0.3), angular_velocity_covariance=cov,
                                linear_acceleration=V3(x=0.0, y=0.0, z=9.81), linear_acceleration_covariance=cov)
            w.write(c["imu"], recv, ser(m, types["imu"]))
            if k % 10 == 0:
                st = T["sensor_msgs/msg/NavSatStatus"](status=0, service=1)
                m = T[types["fix"]](header=header(ns), status=st, latitude=45.0, longitude=7.0 + 1e-5 * k / 10,
                                    altitude=100.0, position_covariance=cov, position_covariance_type=0)
                w.write(c["fix"], recv, ser(m, types["fix"]))
                m = T[types["rng"]](header=header(ns), radiation_type=1, field_of_view=0.01, min_range=0.1,
                                    max_range=50.0, range=7.5 if k else 80.0)
                w.write(c["rng"], recv, ser(m, types["rng"]))
            if k % 20 == 0:
                img = rng.integers(0, 256, (24, 32), dtype=np.uint8)
                images.append(img)
                m = T[types["img"]](header=header(ns), height=24, width=32, encoding="mono8", is_bigendian=0, step=32,
                                    data=img.ravel())
                w.write(c["img"], recv + 10**7, ser(m, types["img"]))
    return images


@pytest.mark.parametrize("ros1", [True, False], ids=["ros1", "ros2"])
def test_rosbag_streams_in_frd_ned(tmp_path, ros1):
    from visnav.geometry.camera import PinholeCamera
    from visnav.geometry.mounts import FixedMount
    from visnav.io.recording import write_camera_yaml

    folder = tmp_path / "data"
    folder.mkdir()
    path = folder / "flight.bag" if ros1 else folder / "bag2"
    images = _write_bag(path, ros1)
    cam_dir = folder if ros1 else path
    write_camera_yaml(cam_dir / "camera.yaml", PinholeCamera.ideal(32, 24, 30.0), FixedMount.depressed(90.0))
    rec = open_recording(path)
    imu = rec.streams["imu"]
    assert len(imu["t_s"]) == 100
    np.testing.assert_allclose(imu["t_recv_s"] - imu["t_s"], 0.002, atol=1e-9)
    np.testing.assert_allclose([imu["gx_radps"][0], imu["gy_radps"][0], imu["gz_radps"][0]], [0.1, -0.2, -0.3])
    assert imu["az_mps2"][0] == pytest.approx(-9.81)  # FLU z up -> FRD z down: specific force -g
    att = rec.streams["attitude"]  # body x (forward) along ENU x = east: yaw +90 deg in NED
    np.testing.assert_allclose([att["roll_rad"][0], att["pitch_rad"][0], att["yaw_rad"][0]], [0, 0, np.pi / 2],
                               atol=1e-12)
    gps = rec.streams["gps"]
    # 1e-5 deg of longitude at 45 deg: N cos(lat) dlambda, N = a / sqrt(1 - e2 sin^2) = 6388838 m (WGS84)
    assert gps["e_m"][1] == pytest.approx(1e-5 * np.radians(1) * 6388838.0 * np.cos(np.radians(45)), rel=2e-3)
    assert gps["ve_mps"][5] == pytest.approx(gps["e_m"][1] / 0.1, rel=1e-6)  # central differences
    r = rec.streams["range"]
    assert np.isnan(r["range_m"][0]) and r["range_m"][1] == 7.5 and set(r["sensor"]) == {"laser"}
    assert len(rec.streams["frames"]["t_s"]) == 5
    for i, img in enumerate(images):
        np.testing.assert_array_equal(rec.sample("frames", i).image, img)


def test_rosbag_without_imu_is_refused(tmp_path):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    with Writer(tmp_path / "x.bag") as w:
        w.add_connection("/chatter", "std_msgs/msg/String", typestore=ts)
    with pytest.raises(RecordingError, match=r"x\.bag: no sensor_msgs/Imu topic \(topics: /chatter\)"):
        open_recording(tmp_path / "x.bag")


def test_px4_ulog_through_io_ulog():
    from tests.shared_data import missing_reason, shared_data_dir

    from visnav.io.ulog import read_ulog

    log = shared_data_dir() / "px4" / "sample_px4_events.ulg"
    if not log.is_file():
        pytest.skip(missing_reason(log))
    u = read_ulog(log)
    rec = open_recording(log)
    imu, att = rec.streams["imu"], rec.streams["attitude"]
    np.testing.assert_array_equal(imu["t_s"], u.imu_t)
    np.testing.assert_array_equal(imu["gz_radps"], u.gyro[:, 2])
    # attitude: quaternion (scalar first, FRD -> NED) -> ZYX Euler; back to the quaternion's rotation
    from scipy.spatial.transform import Rotation

    from visnav.geometry.rotations import euler_to_dcm

    C = euler_to_dcm(np.column_stack([att["roll_rad"], att["pitch_rad"], att["yaw_rad"]]))
    np.testing.assert_allclose(C, Rotation.from_quat(u.att_quat[:, [1, 2, 3, 0]]).as_matrix(), atol=1e-9)
    if u.mag is not None:
        assert np.all(np.isfinite(rec.streams["magnetometer"]["heading_rad"]))
