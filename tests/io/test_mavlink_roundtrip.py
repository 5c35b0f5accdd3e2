"""Round trip of every message the bridge (and the SIL's autopilot side) sends: every field equals the value
we meant after decoding with pymavlink's parser, and with MAVSDK's (libmav, an independent C++
implementation, through its MavlinkDirect plugin) where MAVSDK hands the message to an application.

The messages come from the code paths that send them (MavlinkLink.heartbeat / tick / request_* / the
TIMESYNC answer, Bridge._apply_request / _send, the encoders); the intended values are written out here
independently of them (closed forms, scipy rotations, pymap3d). ``_check`` insists that the intended dict
names every field of the message.
"""

import gc
import json
import math
import threading
import time

import numpy as np
import pymap3d
import pytest
from scipy.spatial.transform import Rotation

from tests.io.bridge_fixtures import GpsFollowNavigator
from tests.io.mavlink_helpers import free_udp_port
from visnav.geometry.frames import LocalTangentPlane
from visnav.io import mavlink_messages as mm
from visnav.app.bridge import Bridge, BridgeConfig, NavRequest
from visnav.io.mavlink_link import MavlinkLink, mavutil
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import Health, NavCommand, NavEstimate

ORIGIN = LocalTangentPlane(58.3950, 15.5750, 95.0)
NOW_NS = 5_000_000_123
PEER_OFFSET_US = 1_000_000_000  # the stub autopilot clock: ours + 1000 s
UPPER = [(i, j) for i in range(6) for j in range(i, 6)]


class _SyncedClock:
    """A converged ClockSync stand-in: the autopilot's clock = ours + 1000 s."""

    synced = True

    def to_peer(self, t_ns):
        return t_ns + PEER_OFFSET_US * 1000

    def to_ours(self, peer_ns):
        return peer_ns - PEER_OFFSET_US * 1000


def _estimate():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6))
    return NavEstimate(t=12.25, position=np.array([12.5, -40.25, -30.0]), velocity=np.array([3.0, -1.0, 0.5]),
                       attitude=np.array([0.05, -0.1, 1.2]), covariance=A @ A.T + np.eye(6), valid=True, source="mpe")


def _odometry_intended(est, usec, reset, quality):
    P = est.covariance
    C = Rotation.from_euler("ZYX", est.attitude[::-1]).as_matrix()  # body FRD -> NED
    x, y, z, w = Rotation.from_matrix(C).as_quat()
    Pvb = C.T @ P[3:, 3:] @ C
    pose = [P[i, j] if (i < 3 and j < 3) else (0.1**2 if i == j else 0.0) for i, j in UPPER]
    vel = [Pvb[i, j] if (i < 3 and j < 3) else (math.nan if i == j else 0.0) for i, j in UPPER]
    return {"time_usec": usec, "frame_id": 20, "child_frame_id": 12, "x": est.position[0], "y": est.position[1],
            "z": est.position[2], "q": np.array([w, x, y, z]) * np.sign(w), "vx": (C.T @ est.velocity)[0],
            "vy": (C.T @ est.velocity)[1], "vz": (C.T @ est.velocity)[2], "rollspeed": math.nan,
            "pitchspeed": math.nan, "yawspeed": math.nan, "pose_covariance": pose, "velocity_covariance": vel,
            "reset_counter": reset, "estimator_type": 2, "quality": quality}


def _health_intended(usec, applied, frame):
    data = [1, 1, 0, 0.75, 320.5, 240.25, 9.5, 1, 0, 2, 3, 1, 1, 4.5, 0.999, 1.25, applied, frame] + [0.0] * 40
    return {"time_usec": usec, "name": "VN_HEALTH", "array_id": 1, "data": data}


HEALTH = Health(source="mpe", tracking=True, tracking_pending=False, coherence=0.75, tracked_px=(320.5, 240.25),
                mpe_rate_hz=9.5, mpe_jump=True, laser_ok=False, rejected_ranges=2, rejected_samples=3,
                reinitializations=1, integrity="degraded", hpl_m=4.5, hpl_probability=0.999, consistency_k2=1.25)


class _HealthNav(GpsFollowNavigator):
    def estimate(self, t):
        e = _estimate()
        return NavEstimate(t=t, position=e.position, velocity=e.velocity, attitude=e.attitude,
                           covariance=e.covariance, valid=True, source="mpe")

    def health(self, t=None):
        return HEALTH

    def command(self, cmd):
        self.commands = getattr(self, "commands", []) + [cmd]


def _sent_messages():
    """[(message, intended fields)] of every message type we send, from the code paths that send them."""
    port = free_udp_port()
    link = MavlinkLink(f"udpout:127.0.0.1:{port}", clock_ns=lambda: NOW_NS, notify=lambda m: None)
    out = []
    link.send = lambda m: out.append(m)  # capture instead of the socket
    try:
        link.heartbeat()
        link.target_system, link.target_component = 1, 1
        link.request_intervals({mavlink.MAVLINK_MSG_ID_HIGHRES_IMU: 100.0})
        link.request_message(mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        link._next_hb = NOW_NS + 1  # tick: only the TIMESYNC request
        link.tick()
        link._handle(mavlink.MAVLink_timesync_message(0, 987_654_321), NOW_NS + 500)  # the autopilot asks
        link.sync = _SyncedClock()
        nav = _HealthNav()
        br = Bridge(link, None, nav, BridgeConfig(send_health=True), notify=lambda m: None)
        cmd = NavCommand(1.0, "request-tracking", {"target_ned": np.array([1.5, -2.25, 0.0]), "init_from": "gps"})
        br._apply_request(NavRequest(3, cmd, (1, 1)))
        br.reset_counter = 258
        br._send(_estimate(), frame_index=42)
    finally:
        link.close()
    est = _estimate()
    usec = int(round(est.t * 1e6)) + PEER_OFFSET_US
    sigma_h = math.sqrt(np.linalg.eigvalsh(est.covariance[:2, :2]).max())
    intended = [
        {"type": 18, "autopilot": 8, "base_mode": 0, "custom_mode": 0, "system_status": 4, "mavlink_version": 3},
        {"target_system": 1, "target_component": 1, "command": 511, "confirmation": 0, "param1": 105.0,
         "param2": 10_000.0, "param3": 0.0, "param4": 0.0, "param5": 0.0, "param6": 0.0, "param7": 0.0},
        {"target_system": 1, "target_component": 1, "command": 512, "confirmation": 0, "param1": 49.0,
         "param2": 0.0, "param3": 0.0, "param4": 0.0, "param5": 0.0, "param6": 0.0, "param7": 0.0},
        {"tc1": 0, "ts1": NOW_NS},  # our TIMESYNC request
        {"tc1": NOW_NS + 500, "ts1": 987_654_321},  # our answer to the autopilot's
    ]
    k = len(out) - 4  # what the Bridge sent: intervals again on construction, then ack, health, odometry, health
    tail = out[k:]
    rest = [
        {"command": 31010, "result": 0, "progress": 0, "result_param2": 3, "target_system": 1, "target_component": 1},
        _health_intended(None, 3, -1),
        # reset_counter: 258 set, +1 as the health reports a reinitialisation, sent modulo 256; quality:
        # 100 / (1 + sigma_h / 2 m), halved while the navigator reports a jump
        _odometry_intended(est, usec, (258 + 1) % 256, int(round(50.0 / (1.0 + sigma_h / 2.0)))),
        _health_intended(usec, 3, 42),
    ]
    msgs = out[:5] + tail
    # the encoders the bridge calls for its other outputs
    tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=197)
    pos, spd = mm.encode_vision(tx, est, 1_234_567_890, 3)
    unix = 1_763_000_000.25
    gps = mm.encode_gps_input(tx, est, ORIGIN, 1_234_567_890, unix)
    origin = mm.encode_origin(tx, ORIGIN, 1, 42)
    sil_cmd = mm.encode_nav_command(tx, NavCommand(2.0, "set-source", {"source": "inertial"}), 9, 1, 197)
    P = est.covariance
    lat, lon, alt = pymap3d.ned2geodetic(*est.position, 58.3950, 15.5750, 95.0)
    gps_s = unix - 315964800 + 18
    msgs += [pos, spd, gps, origin, sil_cmd]
    rest += [
        {"usec": 1_234_567_890, "x": est.position[0], "y": est.position[1], "z": est.position[2],
         "roll": est.attitude[0], "pitch": est.attitude[1], "yaw": est.attitude[2],
         "covariance": [P[i, j] if (i < 3 and j < 3) else (0.01 if i == j else 0.0) for i, j in UPPER],
         "reset_counter": 3},
        {"usec": 1_234_567_890, "x": est.velocity[0], "y": est.velocity[1], "z": est.velocity[2],
         "covariance": P[3:, 3:].ravel().tolist(), "reset_counter": 3},
        {"time_usec": 1_234_567_890, "gps_id": 0, "ignore_flags": 6, "time_week_ms": round((gps_s % 604800) * 1000),
         "time_week": int(gps_s // 604800), "fix_type": 3, "lat": round(lat * 1e7), "lon": round(lon * 1e7),
         "alt": alt, "hdop": 0.0, "vdop": 0.0, "vn": est.velocity[0], "ve": est.velocity[1], "vd": est.velocity[2],
         "speed_accuracy": math.sqrt(np.linalg.eigvalsh(P[3:, 3:]).max()),
         "horiz_accuracy": math.sqrt(np.linalg.eigvalsh(P[:2, :2]).max()), "vert_accuracy": math.sqrt(P[2, 2]),
         "satellites_visible": 10, "yaw": 0},
        {"target_system": 1, "latitude": 583950000, "longitude": 155750000, "altitude": 95000, "time_usec": 42},
        {"target_system": 1, "target_component": 197, "command": 31010, "confirmation": 0, "param1": 4.0,
         "param2": 2.0, "param3": 0.0, "param4": 0.0, "param5": 0.0, "param6": 0.0, "param7": 9.0},
    ]
    assert [m.get_type() for m in msgs] == [
        "HEARTBEAT", "COMMAND_LONG", "COMMAND_LONG", "TIMESYNC", "TIMESYNC", "COMMAND_ACK", "DEBUG_FLOAT_ARRAY",
        "ODOMETRY", "DEBUG_FLOAT_ARRAY", "VISION_POSITION_ESTIMATE", "VISION_SPEED_ESTIMATE", "GPS_INPUT",
        "SET_GPS_GLOBAL_ORIGIN", "COMMAND_LONG"]
    assert nav.commands[0].name == "request-tracking"
    return list(zip(msgs, intended + rest))


def _same(got, want, key):
    if isinstance(want, str):
        g = got.decode() if isinstance(got, (bytes, bytearray)) else str(got)
        return g.rstrip("\x00") == want
    w = np.asarray(want, float).ravel()
    g = np.asarray([np.nan if x is None else x for x in np.atleast_1d(got)], float).ravel()
    if key == "q":
        g = g * np.sign(g[0])
    if g.shape != w.shape:
        return False
    both_nan = np.isnan(g) & np.isnan(w)
    close = np.isclose(g, w, rtol=1e-6, atol=1e-7)  # float32 fields: 6-7 significant digits
    return bool(np.all(both_nan | close))


def _check(fields: dict, want: dict, typ: str, skip=(), extensions_zero=False):
    """Every field of ``want`` matches; the decoded message has no other field (``extensions_zero``: a newer
    message definition's extension fields we do not fill may be there, holding 0)."""
    names = [k for k in fields if k not in ("message_id", "message_name", "mavpackettype")]
    extra = set(names) - set(want)
    if extensions_zero:
        assert all(fields[k] in (0, None) for k in extra), (typ, {k: fields[k] for k in extra})
        extra = set()
    assert not extra and not (set(want) - set(names)), (typ, sorted(extra), sorted(set(want) - set(names)))
    for k, v in want.items():
        if k in skip or v is None:
            continue
        assert _same(fields[k], v, k), (typ, k, fields[k], v)


def test_every_field_of_every_message_we_send_after_pymavlink_decoding():
    pairs = _sent_messages()
    for msg, want in pairs:
        tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=197)
        out = mavlink.MAVLink(None).parse_buffer(msg.pack(tx))  # a second parser, as on the autopilot
        assert out and len(out) == 1, msg.get_type()
        m = out[0]
        fields = {k: getattr(m, k) for k in m.get_fieldnames()}
        _check(fields, want, m.get_type())
    # the health sent after a request describes the instant it was applied (our clock now, mapped)
    ack_health = pairs[6][0]
    assert abs(ack_health.time_usec - (time.monotonic() * 1e6 + PEER_OFFSET_US)) < 30e6
    # and the decoders turn it back into what the navigator reported
    h, applied, frame = mm.decode_health(pairs[8][0])
    assert (applied, frame) == (3, 42)
    for k in ("source", "tracking", "tracking_pending", "mpe_jump", "laser_ok", "rejected_ranges", "rejected_samples",
              "reinitializations", "integrity", "tracked_px", "mpe_rate_hz", "hpl_m", "consistency_k2"):
        assert getattr(h, k) == getattr(HEALTH, k), k
    seq, cmd = mm.decode_nav_command(pairs[-1][0], 5.0)
    assert (seq, cmd.name, cmd.args) == (9, "set-source", {"source": "inertial"})


def test_requests_without_a_mapping_fail_with_one_line():
    tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    for cmd, words in ((NavCommand(0.0, "restart", {"yaw_deg": 3.0}), "'restart' has no MAVLink mapping"),
                       (NavCommand(0.0, "set-source", {"source": "sonar"}), "source 'sonar' has no MAVLink code"),
                       (NavCommand(0.0, "stop-tracking", {"why": 1}), "argument(s) why have no MAVLink mapping")):
        with pytest.raises(mm.NoMavlinkMapping) as e:
            mm.encode_nav_command(tx, cmd, 1, 1, 197)
        assert words in str(e.value) and "\n" not in str(e.value)
    bad = mavlink.MAVLink_command_long_message(1, 197, 31010, 0, 77.0, 0, 0, 0, 0, 0, 1.0)
    with pytest.raises(mm.NoMavlinkMapping, match="request code 77 is not a navigator request"):
        mm.decode_nav_command(bad, 0.0)


@pytest.mark.realtime
def test_every_field_after_mavsdk_decoding():
    """MAVSDK plays the autopilot (system 1, component 1, as the bridge's peer); its MavlinkDirect plugin hands
    an application every message of a system, decoded by libmav (fields as JSON; NaN and inf as null), no
    server process needed. (As a ground station with its own system id MAVSDK drops the messages addressed
    to system 1: SET_GPS_GLOBAL_ORIGIN, COMMAND_LONG, COMMAND_ACK.)"""
    mavsdk = pytest.importorskip("mavsdk", reason="the mavsdk wheel is not installed (pip install 'mavsdk>=4.1')")
    if not hasattr(mavsdk, "Mavsdk"):
        pytest.skip("mavsdk < 4 (the gRPC mavsdk_server API) is installed; this test uses the 4.x C library API")
    from mavsdk import ComponentType, Configuration, Mavsdk
    from mavsdk.plugins.mavlink_direct.mavlink_direct import MavlinkDirect

    pairs = _sent_messages()
    port = free_udp_port()
    sdk = Mavsdk(Configuration.create_manual(1, 1, False))  # MAVSDK plays the autopilot (system 1, component 1)
    assert int(sdk.add_any_connection(f"udpin://127.0.0.1:{port}")) == 0
    tx = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1, source_component=197,
                                    dialect="common")  # as the bridge
    got: dict = {}
    system = systems = md = None
    try:
        for _ in range(50):  # bounded: 5 s at most; our HEARTBEAT makes MAVSDK see the bridge's system
            tx.mav.send(pairs[0][0])
            time.sleep(0.1)
            systems = sdk.get_systems()
            if systems:
                system = systems[0]
                break
        assert system is not None, "MAVSDK saw no system on 127.0.0.1"
        md = MavlinkDirect(system)
        md.subscribe_message("", lambda m, ud: got.setdefault(m.message_name, []).append(json.loads(m.fields_json)))
        for _ in range(20):  # bounded: 1 s at most
            for msg, _ in pairs:
                tx.mav.send(msg)
            time.sleep(0.05)
            if all(m.get_type() in got for m, _ in pairs):
                break
    finally:
        tx.close()
        # nothing MAVSDK handed out may outlive its instance (libmavsdk aborts the process otherwise)
        if md is not None:
            md.destroy()
        md = system = systems = None
        gc.collect()
        sdk.destroy()
    n = 0
    for msg, want in pairs:
        typ = msg.get_type()
        assert typ in got, f"MAVSDK delivered no {typ}: {sorted(got)}"
        # the same type may have been sent twice with other values (TIMESYNC, health): one must match
        tries = got[typ]
        errors = []
        for fields in tries:
            try:
                _check(fields, want, typ, extensions_zero=True)
                break
            except AssertionError as e:
                errors.append(e)
        else:
            raise errors[0]
        n += 1
    assert n == len(pairs) == 14  # every message, the SIL's request to the navigator included
