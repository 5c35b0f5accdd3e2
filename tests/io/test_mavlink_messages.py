"""MAVLink decoders (units, frames, stamps) and encoders: every field after pymavlink decoding over UDP."""

import math

import numpy as np
import pymap3d
import pytest
from scipy.spatial.transform import Rotation

from tests.io.mavlink_helpers import free_udp_port, receive
from visnav.geometry.frames import LocalTangentPlane
from visnav.io import mavlink_messages as mm
from visnav.io.mavlink_link import mavutil
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import NavEstimate

pytestmark = pytest.mark.realtime  # paced to the wall clock: run apart from the CPU-heavy suite (Makefile)

ORIGIN = LocalTangentPlane(58.3950, 15.5750, 95.0)


def _roundtrip(msg):
    """Pack with one MAVLink instance, parse with another (a second parser, as on the autopilot)."""
    rx = mavlink.MAVLink(None)
    out = rx.parse_buffer(msg.pack(mavlink.MAVLink(None, srcSystem=1, srcComponent=1)))
    assert len(out) == 1
    return out[0]


def stamp(peer_ns):  # autopilot boot clock = ours + 1000 s
    return peer_ns / 1e9 - 1000.0


TX = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)


def test_decode_imu_units():
    m = _roundtrip(TX.scaled_imu_encode(123456, 10, -20, -1000, 100, -200, 300, 0, 0, 0))
    s = mm.decode_imu(m, stamp)
    np.testing.assert_allclose(s.accel, np.array([10, -20, -1000]) * 9.80665e-3)
    np.testing.assert_allclose(s.gyro, [0.1, -0.2, 0.3])
    assert s.t == pytest.approx(123.456 - 1000.0)
    m = _roundtrip(TX.highres_imu_encode(5_000_000, 0.1, 0.2, -9.8, 0.01, 0.02, 0.03, 0, 0, 0, 1000, 0, 0, 20,
                                         0x3F))
    s = mm.decode_imu(m, stamp)
    np.testing.assert_allclose(s.accel, [0.1, 0.2, -9.8], rtol=1e-6)
    np.testing.assert_allclose(s.gyro, [0.01, 0.02, 0.03], rtol=1e-6)
    assert s.t == pytest.approx(5.0 - 1000.0)
    bad = _roundtrip(TX.highres_imu_encode(1, float("nan"), 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x3F))
    assert mm.decode_imu(bad, stamp) is None


def test_decode_attitude_quaternion_matches_scipy():
    e = np.array([0.1, -0.2, 2.5])
    x, y, z, w = Rotation.from_euler("ZYX", e[::-1]).as_quat()
    m = _roundtrip(TX.attitude_quaternion_encode(2000, w, x, y, z, 0, 0, 0))
    s = mm.decode_attitude(m, stamp)
    np.testing.assert_allclose(s.euler, e, atol=1e-6)
    assert s.t == pytest.approx(2.0 - 1000.0)
    s2 = mm.decode_attitude(_roundtrip(TX.attitude_encode(2000, *e, 0, 0, 0)), stamp)
    np.testing.assert_allclose(s2.euler, e, atol=1e-6)


def test_decode_baro_range_gps():
    b = mm.decode_baro(_roundtrip(TX.scaled_pressure_encode(10, 1001.0, 0, 2000)), stamp, p0_hpa=1013.25)
    assert b.altitude == pytest.approx(44330.77 * (1 - (1001.0 / 1013.25) ** 0.190263))
    assert 100 < b.altitude < 105  # ~8.3 m/hPa near sea level
    p0 = mm.reference_pressure(1001.0, 60.0)
    assert mm.pressure_altitude(1001.0, p0) == pytest.approx(60.0, abs=1e-9) and p0 > 1001.0
    r = mm.decode_range(_roundtrip(TX.distance_sensor_encode(10, 20, 4000, 1234, 0, 0, 25, 0)), stamp)
    assert r.range == pytest.approx(12.34) and r.sensor == "laser"
    r = mm.decode_range(_roundtrip(TX.distance_sensor_encode(10, 20, 4000, 4001, 1, 0, 25, 0)), stamp)
    assert math.isnan(r.range) and r.sensor == "sonar"
    lat, lon, h = 58.3951, 15.5762, 120.0
    g = mm.decode_gps(_roundtrip(TX.global_position_int_encode(3000, int(lat * 1e7), int(lon * 1e7),
                                                                int(h * 1000), 0, 150, -250, 30, 0)),
                      stamp, ORIGIN, recv_t=0.0)
    np.testing.assert_allclose(g.position, pymap3d.geodetic2ned(lat, lon, h, 58.3950, 15.5750, 95.0), atol=0.02)
    np.testing.assert_allclose(g.velocity, [1.5, -2.5, 0.3])
    assert g.sigma == mm.GPS_SIGMA_M == 2.5  # no accuracy in the message: the bridge's --gps-sigma, default 2.5 m
    g2 = mm.decode_gps(_roundtrip(TX.global_position_int_encode(3000, int(lat * 1e7), int(lon * 1e7),
                                                                 int(h * 1000), 0, 150, -250, 30, 0)),
                       stamp, ORIGIN, recv_t=0.0, sigma_m=0.02)
    assert g2.sigma == 0.02 and np.array_equal(g2.position, g.position)
    raw = TX.gps_raw_int_encode(int(4e6), 3, int(lat * 1e7), int(lon * 1e7), int(h * 1000), 80, 120, 500, 9000,
                                12, 0, 1500, 2000, 300, 0)
    g = mm.decode_gps(_roundtrip(raw), stamp, ORIGIN, recv_t=0.0)
    np.testing.assert_allclose(g.velocity, [0.0, 5.0, 0.0], atol=1e-9)
    assert g.sigma == pytest.approx(1.5) and g.t == pytest.approx(4.0 - 1000)
    nofix = TX.gps_raw_int_encode(1, 1, 0, 0, 0, 0, 0, 0, 0, 0)
    assert mm.decode_gps(_roundtrip(nofix), stamp, ORIGIN, recv_t=0.0) is None
    unix = TX.gps_raw_int_encode(1_700_000_000_000_000, 3, int(lat * 1e7), int(lon * 1e7), 0, 0, 0, 0, 0, 9)
    assert mm.decode_gps(_roundtrip(unix), stamp, ORIGIN, recv_t=7.5).t == 7.5  # UNIX time: stamped on arrival


def _estimate():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(6, 6))
    P = A @ A.T + np.eye(6)  # full, correlated, SPD
    return NavEstimate(t=12.0, position=np.array([12.5, -40.25, -30.0]), velocity=np.array([3.0, -1.0, 0.5]),
                       attitude=np.array([0.05, -0.1, 1.2]), covariance=P, valid=True, source="vision")


UPPER = [(i, j) for i in range(6) for j in range(i, 6)]  # MAVLink order, written out independently


@pytest.fixture
def udp_pair():
    port = free_udp_port()
    rx = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", dialect="common")
    tx = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1, source_component=197,
                                    dialect="common")
    yield tx, rx
    tx.close()
    rx.close()


def test_odometry_vision_gps_input_fields_over_udp(udp_pair):
    tx, rx = udp_pair
    est = _estimate()
    P = est.covariance
    C = Rotation.from_euler("ZYX", est.attitude[::-1]).as_matrix()  # body -> NED, independently of visnav
    tx.mav.send(mm.encode_odometry(tx.mav, est, 1_234_567_890, reset_counter=258, quality=77))
    for m in mm.encode_vision(tx.mav, est, 1_234_567_890, reset_counter=3):
        tx.mav.send(m)
    unix = 1_763_000_000.25
    tx.mav.send(mm.encode_gps_input(tx.mav, est, ORIGIN, 1_234_567_890, unix))
    tx.mav.send(mm.encode_origin(tx.mav, ORIGIN, target_system=1, time_usec=42))
    got = {m.get_type(): m for m in receive(rx, ["ODOMETRY", "VISION_POSITION_ESTIMATE", "VISION_SPEED_ESTIMATE",
                                                 "GPS_INPUT", "SET_GPS_GLOBAL_ORIGIN"], 5)}
    assert len(got) == 5, got.keys()
    o = got["ODOMETRY"]
    assert (o.time_usec, o.frame_id, o.child_frame_id) == (1_234_567_890, 20, 12)  # LOCAL_FRD, BODY_FRD
    assert (o.reset_counter, o.quality, o.estimator_type) == (258 % 256, 77, 2)  # VISION
    np.testing.assert_allclose([o.x, o.y, o.z], est.position, rtol=1e-7)
    x, y, z, w = Rotation.from_matrix(C).as_quat()
    q = np.array(o.q)
    np.testing.assert_allclose(q * np.sign(q[0]), np.array([w, x, y, z]) * np.sign(w), atol=1e-6)
    np.testing.assert_allclose([o.vx, o.vy, o.vz], C.T @ est.velocity, rtol=1e-6)
    assert all(math.isnan(v) for v in (o.rollspeed, o.pitchspeed, o.yawspeed))
    Pv_body = C.T @ P[3:, 3:] @ C
    for k, (i, j) in enumerate(UPPER):  # element by element, in MAVLink's order
        want_pose = P[i, j] if (i < 3 and j < 3) else (0.1**2 if i == j else 0.0)
        assert o.pose_covariance[k] == pytest.approx(want_pose, rel=1e-6, abs=1e-9), (k, i, j)
        if i < 3 and j < 3:
            assert o.velocity_covariance[k] == pytest.approx(Pv_body[i, j], rel=1e-5, abs=1e-9), (k, i, j)
        elif i == j:
            assert math.isnan(o.velocity_covariance[k])
        else:
            assert o.velocity_covariance[k] == 0.0
    assert [o.pose_covariance[k] for k in (0, 6, 11)] == pytest.approx(np.diag(P)[:3], rel=1e-6)
    v = got["VISION_POSITION_ESTIMATE"]
    assert (v.usec, v.reset_counter) == (1_234_567_890, 3)
    np.testing.assert_allclose([v.x, v.y, v.z, v.roll, v.pitch, v.yaw], np.r_[est.position, est.attitude],
                               rtol=1e-6)
    np.testing.assert_allclose(v.covariance, o.pose_covariance, rtol=1e-7)
    s = got["VISION_SPEED_ESTIMATE"]
    assert (s.usec, s.reset_counter) == (1_234_567_890, 3)
    np.testing.assert_allclose([s.x, s.y, s.z], est.velocity, rtol=1e-7)
    np.testing.assert_allclose(s.covariance, P[3:, 3:].ravel(), rtol=1e-6)
    g = got["GPS_INPUT"]
    lat, lon, alt = pymap3d.ned2geodetic(*est.position, 58.3950, 15.5750, 95.0)
    assert g.lat == round(lat * 1e7) and g.lon == round(lon * 1e7)
    assert g.alt == pytest.approx(alt, abs=1e-4) and g.alt == pytest.approx(125.0, abs=0.01)
    assert g.horiz_accuracy == pytest.approx(math.sqrt(np.linalg.eigvalsh(P[:2, :2]).max()), rel=1e-6)
    assert g.vert_accuracy == pytest.approx(math.sqrt(P[2, 2]), rel=1e-6)
    assert g.speed_accuracy == pytest.approx(math.sqrt(np.linalg.eigvalsh(P[3:, 3:]).max()), rel=1e-6)
    assert (g.fix_type, g.satellites_visible, g.time_usec, g.gps_id) == (3, 10, 1_234_567_890, 0)
    assert g.ignore_flags == mavlink.GPS_INPUT_IGNORE_FLAG_HDOP | mavlink.GPS_INPUT_IGNORE_FLAG_VDOP == 6
    np.testing.assert_allclose([g.vn, g.ve, g.vd], est.velocity, rtol=1e-7)
    # GPS time of UNIX 1_763_000_000.25: 2026-01-01.. week 2393 (GPS epoch 1980-01-06, +18 leap s)
    gps_s = unix - 315964800 + 18
    assert g.time_week == int(gps_s // 604800) and g.time_week_ms == round((gps_s % 604800) * 1000)
    o2 = got["SET_GPS_GLOBAL_ORIGIN"]
    assert (o2.latitude, o2.longitude, o2.altitude, o2.target_system, o2.time_usec) == (583950000, 155750000,
                                                                                         95000, 1, 42)


def test_invalid_estimate_quality_zero_and_no_fix():
    est = _estimate()
    bad = NavEstimate(t=0, position=est.position, velocity=est.velocity, attitude=est.attitude, valid=False)
    assert mm.quality_from(bad, None) == 0
    m = _roundtrip(mm.encode_gps_input(TX, bad, ORIGIN, 1, 1.7e9))
    assert m.fix_type == mavlink.GPS_FIX_TYPE_NO_FIX
    assert m.ignore_flags & mavlink.GPS_INPUT_IGNORE_FLAG_HORIZONTAL_ACCURACY
    good = NavEstimate(t=0, position=est.position, velocity=est.velocity, attitude=est.attitude,
                       covariance=np.diag([4.0, 1.0, 1, 1, 1, 1]))
    assert mm.quality_from(good, None) == 50  # sigma_h = 2 m = sigma_ref


def test_upper_triangle_inverse():
    A = np.arange(36.0).reshape(6, 6)
    S = A + A.T
    np.testing.assert_array_equal(mm.from_upper_triangle(mm.upper_triangle(S)), S)
    assert mm.upper_triangle(S)[6] == S[1, 1] and mm.upper_triangle(S)[20] == S[5, 5]
