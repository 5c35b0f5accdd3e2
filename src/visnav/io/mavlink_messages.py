"""MAVLink <-> visnav measurement types: decoders (autopilot -> navigator) and encoders (estimate -> autopilot).

Decoders turn one pymavlink message into a measurement of ``visnav.measurements`` in SI units and the
NED frame of an origin (``geometry.frames.LocalTangentPlane``), stamped in OUR clock: ``stamp(peer_ns)``
maps the autopilot's time-since-boot (ns) to our monotonic seconds (``estimation.clock_sync``). They
return None for a message they cannot use (NaN, no fix, out of range); the caller counts it.

Encoders turn a ``NavEstimate`` (NED, body FRD, 6x6 covariance of [position, velocity]) into ODOMETRY,
VISION_POSITION_ESTIMATE + VISION_SPEED_ESTIMATE, GPS_INPUT or SET_GPS_GLOBAL_ORIGIN, stamped with
``time_usec`` = the instant the estimate describes in the autopilot's clock.

Covariances (MAVLink convention): a 6x6 symmetric matrix over (x, y, z, roll, pitch, yaw) -- or
(vx, vy, vz, rollspeed, pitchspeed, yawspeed) -- is sent as its upper triangle, row by row: 21 values,
index 0 = xx, 6 = yy, 11 = zz, 15 = roll-roll, 18 = pitch-pitch, 20 = yaw-yaw. NaN in element 0 means
"unknown". VISION_SPEED_ESTIMATE has a full 3x3 row-major matrix (9 values).
"""

from __future__ import annotations

import math
import os
from typing import Callable

import numpy as np

os.environ.setdefault("MAVLINK20", "1")  # ODOMETRY's quality / estimator_type are MAVLink 2 extensions

from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from visnav.estimation.ins import euler_to_quat, quat_to_euler  # noqa: E402
from visnav.geometry.frames import LocalTangentPlane  # noqa: E402
from visnav.geometry.rotations import euler_to_dcm  # noqa: E402
from visnav.measurements import (AttitudeSample, BaroSample, GpsSample, Health, ImuSample,  # noqa: E402
                                 NavCommand, NavEstimate, RangeSample)

G0 = 9.80665  # m/s^2 per g (SCALED_IMU's mG)
SATELLITES_VISIBLE = 10  # GPS_INPUT: a constant >= the autopilots' minimum for a 3D fix (ArduPilot, PX4: 6)
ATTITUDE_SIGMA_RAD = 0.1  # 1-sigma sent for roll/pitch/yaw: visnav echoes the autopilot's own attitude
BOOT_TIME_MAX_US = 10**14  # a time_usec above ~3 years is UNIX time, not time since boot

Stamp = Callable[[int], float]  # autopilot time since boot [ns] -> our clock [s]


# ---------------------------------------------------------------------------------------------- covariance
def upper_triangle(C: np.ndarray) -> list[float]:
    """The 21 (or n(n+1)/2) upper-triangle elements of a symmetric matrix, row by row (MAVLink order)."""
    C = np.asarray(C, float)
    i, j = np.triu_indices(C.shape[0])
    return C[i, j].tolist()


def from_upper_triangle(v, n: int = 6) -> np.ndarray:
    """Inverse of ``upper_triangle``: the symmetric n x n matrix."""
    C = np.zeros((n, n))
    i, j = np.triu_indices(n)
    C[i, j] = np.asarray(v, float)
    C[j, i] = C[i, j]
    return C


def pose_covariance(est: NavEstimate) -> np.ndarray:
    """6x6 over (x, y, z, roll, pitch, yaw): the estimate's position block, attitude ATTITUDE_SIGMA_RAD."""
    C = np.zeros((6, 6))
    C[:3, :3] = np.asarray(est.covariance, float)[:3, :3]
    C[3:, 3:] = np.eye(3) * ATTITUDE_SIGMA_RAD**2
    return C


def velocity_covariance_body(est: NavEstimate) -> np.ndarray:
    """6x6 over (vx, vy, vz, p, q, r) with the velocity block rotated into body FRD (C^T P C); the
    angular rates are not estimated: their variances are NaN."""
    Cbn = euler_to_dcm(est.attitude)
    C = np.zeros((6, 6))
    C[:3, :3] = Cbn.T @ np.asarray(est.covariance, float)[3:6, 3:6] @ Cbn
    C[3:, 3:] = np.diag([np.nan] * 3)
    return C


def horizontal_sigma(P: np.ndarray) -> float:
    """1-sigma along the worst horizontal axis: sqrt of the largest eigenvalue of the 2x2 block."""
    return float(math.sqrt(max(np.linalg.eigvalsh(np.asarray(P, float)[:2, :2]).max(), 0.0)))


# ---------------------------------------------------------------------------------------------- decoders
def _ms(stamp: Stamp, time_boot_ms: int) -> float:
    return stamp(int(time_boot_ms) * 1_000_000)


def _us(stamp: Stamp, time_usec: int) -> float | None:
    return None if time_usec >= BOOT_TIME_MAX_US else stamp(int(time_usec) * 1000)


def decode_attitude(msg, stamp: Stamp) -> AttitudeSample | None:
    """ATTITUDE (rad) or ATTITUDE_QUATERNION (w, x, y, z; body FRD -> NED) -> AttitudeSample."""
    if msg.get_type() == "ATTITUDE_QUATERNION":
        q = np.array([msg.q1, msg.q2, msg.q3, msg.q4])
        if not np.all(np.isfinite(q)) or np.linalg.norm(q) < 0.5:
            return None
        euler = quat_to_euler(q / np.linalg.norm(q))
    else:
        euler = np.array([msg.roll, msg.pitch, msg.yaw])
        if not np.all(np.isfinite(euler)):
            return None
    return AttitudeSample(t=_ms(stamp, msg.time_boot_ms), euler=euler)


def decode_imu(msg, stamp: Stamp) -> ImuSample | None:
    """HIGHRES_IMU (m/s^2, rad/s, time_usec) or SCALED_IMU (mG, mrad/s, time_boot_ms) -> ImuSample (FRD)."""
    if msg.get_type() == "HIGHRES_IMU":
        if (msg.fields_updated & 0x3F) not in (0, 0x3F):  # bits 0-5: acc + gyro; 0 = field not used
            return None
        acc = np.array([msg.xacc, msg.yacc, msg.zacc])
        gyr = np.array([msg.xgyro, msg.ygyro, msg.zgyro])
        t = _us(stamp, msg.time_usec)
    else:  # SCALED_IMU / SCALED_IMU2 / SCALED_IMU3
        acc = np.array([msg.xacc, msg.yacc, msg.zacc], float) * (G0 / 1000.0)
        gyr = np.array([msg.xgyro, msg.ygyro, msg.zgyro], float) / 1000.0
        t = _ms(stamp, msg.time_boot_ms)
    if t is None or not (np.all(np.isfinite(acc)) and np.all(np.isfinite(gyr))):
        return None
    return ImuSample(t=t, accel=acc, gyro=gyr)


def pressure_altitude(p_hpa: float, p0_hpa: float) -> float:
    """Height [m] of pressure ``p_hpa`` above the level of ``p0_hpa`` (ISA troposphere)."""
    return 44330.77 * (1.0 - (p_hpa / p0_hpa) ** 0.190263)


def reference_pressure(p_hpa: float, height_m: float) -> float:
    """The pressure [hPa] at ``height_m`` below a point where ``p_hpa`` is read (inverse of pressure_altitude)."""
    return p_hpa / (1.0 - height_m / 44330.77) ** (1.0 / 0.190263)


def decode_baro(msg, stamp: Stamp, p0_hpa: float) -> BaroSample | None:
    """SCALED_PRESSURE (press_abs hPa) -> altitude above the reference pressure ``p0_hpa``."""
    p = float(msg.press_abs)
    if not (math.isfinite(p) and 100.0 < p < 1200.0):
        return None
    return BaroSample(t=_ms(stamp, msg.time_boot_ms), altitude=pressure_altitude(p, p0_hpa))


def decode_range(msg, stamp: Stamp) -> RangeSample:
    """DISTANCE_SENSOR (cm) -> RangeSample [m]; NaN when outside [min_distance, max_distance] (no return).
    ``sensor``: "laser" for MAV_DISTANCE_SENSOR_LASER, else "sonar" (ultrasound, radar, ...)."""
    d = msg.current_distance
    r = d / 100.0 if msg.min_distance <= d <= msg.max_distance else float("nan")
    sensor = "laser" if msg.type == mavlink.MAV_DISTANCE_SENSOR_LASER else "sonar"
    return RangeSample(t=_ms(stamp, msg.time_boot_ms), range=r, sensor=sensor)


GPS_SIGMA_M = 2.5  # 1-sigma of a position with no accuracy of its own (GLOBAL_POSITION_INT; GPS_RAW_INT h_acc 0)


def decode_gps(msg, stamp: Stamp, origin: LocalTangentPlane, recv_t: float,
               sigma_m: float = GPS_SIGMA_M) -> GpsSample | None:
    """GLOBAL_POSITION_INT (the autopilot's fused position, 1e-7 deg, mm AMSL, cm/s NED) or GPS_RAW_INT
    (the receiver: fix_type >= 3, ground speed + course, h_acc mm) -> GpsSample in the origin's NED.
    GPS_RAW_INT with a UNIX time_usec is stamped at reception ``recv_t``. ``sigma_m``: the sample's sigma
    where the message gives none."""
    if msg.get_type() == "GLOBAL_POSITION_INT":
        if msg.lat == 0 and msg.lon == 0:
            return None
        t = _ms(stamp, msg.time_boot_ms)
        vel = np.array([msg.vx, msg.vy, msg.vz], float) / 100.0
    else:
        if msg.fix_type < mavlink.GPS_FIX_TYPE_3D_FIX:
            return None
        t = _us(stamp, msg.time_usec)
        t = recv_t if t is None else t
        v = msg.vel / 100.0 if msg.vel != 65535 else float("nan")
        cog = math.radians(msg.cog / 100.0) if msg.cog != 65535 else float("nan")
        vel = np.array([v * math.cos(cog), v * math.sin(cog), 0.0])
        h_acc = getattr(msg, "h_acc", 0)
        sigma_m = h_acc / 1000.0 if h_acc else sigma_m
    pos = origin.geodetic_to_ned(msg.lat * 1e-7, msg.lon * 1e-7, msg.alt / 1000.0)
    if not np.all(np.isfinite(pos)):
        return None
    return GpsSample(t=t, position=pos, velocity=vel, sigma=float(sigma_m))


# ---------------------------------------------------------------------------------------------- encoders
def quality_from(est: NavEstimate, health: Health | None, sigma_ref_m: float = 2.0) -> int:
    """ODOMETRY ``quality`` 0..100: 0 when invalid or the covariance is unknown; otherwise
    100 / (1 + sigma_h / sigma_ref) with sigma_h the worst-axis horizontal 1-sigma (100 = perfect,
    50 at sigma_ref). Halved while the navigator reports a position jump (``Health.mpe_jump``)."""
    P = np.asarray(est.covariance, float)
    if not est.valid or not np.all(np.isfinite(P[:3, :3])):
        return 0
    q = 100.0 / (1.0 + horizontal_sigma(P) / sigma_ref_m)
    if health is not None and health.mpe_jump:
        q *= 0.5
    return int(max(1, min(100, round(q))))


def encode_odometry(mav, est: NavEstimate, time_usec: int, reset_counter: int, quality: int,
                    frame_id: int = mavlink.MAV_FRAME_LOCAL_FRD,
                    estimator_type: int = mavlink.MAV_ESTIMATOR_TYPE_VISION):
    """ODOMETRY: pose in ``frame_id`` (our NED axes: a LOCAL_FRD frame aligned with north, or LOCAL_NED),
    child_frame_id BODY_FRD, q = body FRD -> local (w, x, y, z), velocity in the child (body) frame."""
    q = euler_to_quat(est.attitude)
    v_body = euler_to_dcm(est.attitude).T @ np.asarray(est.velocity, float)
    p = est.position
    nan = float("nan")
    return mav.odometry_encode(
        int(time_usec), frame_id, mavlink.MAV_FRAME_BODY_FRD, float(p[0]), float(p[1]), float(p[2]),
        [float(x) for x in q], float(v_body[0]), float(v_body[1]), float(v_body[2]), nan, nan, nan,
        upper_triangle(pose_covariance(est)), upper_triangle(velocity_covariance_body(est)),
        int(reset_counter) % 256, estimator_type, int(quality))


def encode_vision(mav, est: NavEstimate, time_usec: int, reset_counter: int):
    """VISION_POSITION_ESTIMATE (NED position, roll/pitch/yaw, 21-element pose covariance) and
    VISION_SPEED_ESTIMATE (NED velocity, 3x3 row-major covariance)."""
    p, e = est.position, est.attitude
    pos = mav.vision_position_estimate_encode(int(time_usec), float(p[0]), float(p[1]), float(p[2]),
                                              float(e[0]), float(e[1]), float(e[2]),
                                              upper_triangle(pose_covariance(est)), int(reset_counter) % 256)
    v = est.velocity
    Pv = np.asarray(est.covariance, float)[3:6, 3:6]
    spd = mav.vision_speed_estimate_encode(int(time_usec), float(v[0]), float(v[1]), float(v[2]),
                                           Pv.reshape(-1).tolist(), int(reset_counter) % 256)
    return pos, spd


def gps_time(unix_s: float) -> tuple[int, int]:
    """(GPS week, ms of week) of a UNIX time (GPS = UTC + 18 leap seconds since 2017)."""
    g = unix_s - 315964800.0 + 18.0
    week = int(g // 604800)
    return week, int(round((g - week * 604800) * 1000.0))


def encode_gps_input(mav, est: NavEstimate, origin: LocalTangentPlane, time_usec: int, unix_s: float,
                     gps_id: int = 0, fix_type: int | None = None):
    """GPS_INPUT: lat/lon/alt (AMSL = origin height - down) from the NED estimate and the origin; accuracies
    are 1-sigma [m, m/s]: horizontal = worst horizontal axis, vertical = sqrt(Pzz), speed = worst axis of
    the velocity block. HDOP/VDOP are not meaningful for a vision fix: ignored (flags), sent as 0.
    ``fix_type``: the caller's (the bridge degrades it with its inputs' age, io/bridge_freshness.py); default
    3D when valid, no fix when not."""
    P = np.asarray(est.covariance, float)
    lat, lon, alt = origin.ned_to_geodetic(np.asarray(est.position, float))
    ign = mavlink.GPS_INPUT_IGNORE_FLAG_HDOP | mavlink.GPS_INPUT_IGNORE_FLAG_VDOP
    if np.all(np.isfinite(P[:6, :6])):
        h_acc, v_acc = horizontal_sigma(P[:3, :3]), float(math.sqrt(max(P[2, 2], 0.0)))
        s_acc = float(math.sqrt(max(np.linalg.eigvalsh(P[3:6, 3:6]).max(), 0.0)))
    else:
        ign |= (mavlink.GPS_INPUT_IGNORE_FLAG_HORIZONTAL_ACCURACY | mavlink.GPS_INPUT_IGNORE_FLAG_VERTICAL_ACCURACY
                | mavlink.GPS_INPUT_IGNORE_FLAG_SPEED_ACCURACY)
        h_acc = v_acc = s_acc = 0.0
    v = np.asarray(est.velocity, float)
    if not np.all(np.isfinite(v)):
        ign |= mavlink.GPS_INPUT_IGNORE_FLAG_VEL_HORIZ | mavlink.GPS_INPUT_IGNORE_FLAG_VEL_VERT
        v = np.zeros(3)
    week, week_ms = gps_time(unix_s)
    fix = (mavlink.GPS_FIX_TYPE_3D_FIX if est.valid else mavlink.GPS_FIX_TYPE_NO_FIX) if fix_type is None \
        else int(fix_type)
    return mav.gps_input_encode(int(time_usec), gps_id, ign, week_ms, week, fix,
                                int(round(float(lat) * 1e7)), int(round(float(lon) * 1e7)), float(alt), 0.0, 0.0,
                                float(v[0]), float(v[1]), float(v[2]), s_acc, h_acc, v_acc, SATELLITES_VISIBLE, 0)


def encode_origin(mav, origin: LocalTangentPlane, target_system: int, time_usec: int = 0):
    """SET_GPS_GLOBAL_ORIGIN at the NED origin (1e-7 deg, mm AMSL)."""
    return mav.set_gps_global_origin_encode(int(target_system), int(round(origin.lat0_deg * 1e7)),
                                            int(round(origin.lon0_deg * 1e7)), int(round(origin.h0_m * 1000)),
                                            int(time_usec))


# ------------------------------------------------------------------- mission requests and navigator health
# A mission flying on the autopilot side talks to the navigator behind the bridge with standard messages
# (docs/autopilots.md, "Mission requests and navigator health"):
#   COMMAND_LONG, command = MAV_CMD_USER_1 (31010): param1 = request code (NAV_COMMAND_CODES), param2 = its
#   enumerated argument (init_from / source code), param3 = 1 when a target follows in param4..6 (NED [m]),
#   param7 = the request's sequence number (retries carry the same one); answered with COMMAND_ACK.
#   DEBUG_FLOAT_ARRAY (350), name "VN_HEALTH", array_id = HEALTH_ARRAY_ID: the navigator's Health with
#   time_usec = the instant it describes in the autopilot's clock, data[i] = HEALTH_FIELDS[i].
NAV_COMMAND_ID = mavlink.MAV_CMD_USER_1
NAV_COMMAND_CODES = {"request-tracking": 1, "request-tracking-rebase": 2, "stop-tracking": 3, "set-source": 4}
INIT_FROM_CODES = ("gps", "estimate")
SOURCE_CODES = ("gps", "mpe", "inertial", "vision", "ins", "none", "registration", "camera", "ahrs", "bridge")
INTEGRITY_CODES = ("ok", "degraded", "unusable")
HEALTH_NAME = "VN_HEALTH"
HEALTH_ARRAY_ID = 1
HEALTH_FIELDS = ("source", "tracking", "tracking_pending", "coherence", "tracked_px_x", "tracked_px_y",
                 "mpe_rate_hz", "mpe_jump", "laser_ok", "rejected_ranges", "rejected_samples", "reinitializations",
                 "integrity", "hpl_m", "hpl_probability", "consistency_k2", "requests_applied", "frame_index")


class NoMavlinkMapping(ValueError):
    """A mission request that has no MAVLink mapping (one line naming it)."""


def _code(table: tuple[str, ...], value: str, what: str) -> int:
    if value not in table:
        raise NoMavlinkMapping(f"{what} {value!r} has no MAVLink code (known: {', '.join(table)})")
    return table.index(value)


def encode_nav_command(mav, cmd: NavCommand, seq: int, target_system: int, target_component: int):
    """A mission's ``NavCommand`` as COMMAND_LONG (MAV_CMD_USER_1, mapping above); NoMavlinkMapping when the
    request or one of its arguments has no code."""
    name = cmd.name.replace("_", "-")
    if name not in NAV_COMMAND_CODES:
        raise NoMavlinkMapping(f"navigator request {cmd.name!r} has no MAVLink mapping (mapped: "
                               f"{', '.join(NAV_COMMAND_CODES)}; docs/autopilots.md)")
    a = dict(cmd.args)
    arg = 0.0
    if name == "set-source":
        arg = _code(SOURCE_CODES, a.pop("source"), "source")
    elif name in ("request-tracking", "request-tracking-rebase"):
        arg = _code(INIT_FROM_CODES, a.pop("init_from", "gps"), "init_from")
    target = a.pop("target_ned", None) if name == "request-tracking" else None
    if a:
        raise NoMavlinkMapping(f"navigator request {cmd.name!r}: argument(s) {', '.join(a)} have no MAVLink mapping")
    xyz = [0.0, 0.0, 0.0] if target is None else [float(x) for x in np.asarray(target, float).reshape(3)]
    return mav.command_long_encode(int(target_system), int(target_component), NAV_COMMAND_ID, 0,
                                   float(NAV_COMMAND_CODES[name]), float(arg), 0.0 if target is None else 1.0,
                                   *xyz, float(seq))


def decode_nav_command(msg, t: float) -> tuple[int, NavCommand]:
    """COMMAND_LONG (MAV_CMD_USER_1) -> (sequence number, NavCommand at our instant ``t``); NoMavlinkMapping
    for a code we do not know."""
    codes = {v: k for k, v in NAV_COMMAND_CODES.items()}
    code, arg = int(round(msg.param1)), int(round(msg.param2))
    if code not in codes:
        raise NoMavlinkMapping(f"MAV_CMD_USER_1 request code {code} is not a navigator request (known: "
                               f"{', '.join(f'{v} {k}' for k, v in NAV_COMMAND_CODES.items())})")
    name = codes[code]
    args: dict = {}
    if name == "set-source":
        args["source"] = SOURCE_CODES[arg] if 0 <= arg < len(SOURCE_CODES) else "?"
    elif name in ("request-tracking", "request-tracking-rebase"):
        args["init_from"] = INIT_FROM_CODES[arg] if 0 <= arg < len(INIT_FROM_CODES) else "?"
        if name == "request-tracking":
            args["target_ned"] = (np.array([msg.param4, msg.param5, msg.param6], float) if msg.param3 >= 0.5
                                  else None)
    if any(isinstance(v, str) and v == "?" for v in args.values()):
        raise NoMavlinkMapping(f"navigator request {name}: argument code {arg} unknown")
    return int(round(msg.param7)), NavCommand(t, name, args)


def encode_health(mav, h: Health, time_usec: int, requests_applied: int, frame_index: int = -1):
    """The navigator's Health as DEBUG_FLOAT_ARRAY "VN_HEALTH" (HEALTH_FIELDS order; unknown source /
    integrity -> -1). ``frame_index``: the frame whose estimate went out with the same ``time_usec`` (-1:
    not a frame's, e.g. the inertial estimate of a camera stall)."""
    src = SOURCE_CODES.index(h.source) if h.source in SOURCE_CODES else -1
    integ = INTEGRITY_CODES.index(h.integrity) if h.integrity in INTEGRITY_CODES else -1
    vals = [src, h.tracking, h.tracking_pending, h.coherence, h.tracked_px[0], h.tracked_px[1], h.mpe_rate_hz,
            h.mpe_jump, h.laser_ok, h.rejected_ranges, h.rejected_samples, h.reinitializations, integ, h.hpl_m,
            h.hpl_probability, h.consistency_k2, requests_applied, frame_index]
    data = [float(v) for v in vals] + [0.0] * (58 - len(vals))
    return mav.debug_float_array_encode(int(time_usec), HEALTH_NAME.encode(), HEALTH_ARRAY_ID, data)


def decode_health(msg) -> tuple[Health, int, int]:
    """DEBUG_FLOAT_ARRAY "VN_HEALTH" -> (Health, requests applied, frame index)."""
    d = dict(zip(HEALTH_FIELDS, msg.data))
    src, integ = int(d["source"]), int(d["integrity"])
    h = Health(source=SOURCE_CODES[src] if 0 <= src < len(SOURCE_CODES) else "?", tracking=d["tracking"] >= 0.5,
               tracking_pending=d["tracking_pending"] >= 0.5, coherence=float(d["coherence"]),
               tracked_px=(float(d["tracked_px_x"]), float(d["tracked_px_y"])), mpe_rate_hz=float(d["mpe_rate_hz"]),
               mpe_jump=d["mpe_jump"] >= 0.5, laser_ok=d["laser_ok"] >= 0.5, rejected_ranges=int(d["rejected_ranges"]),
               rejected_samples=int(d["rejected_samples"]), reinitializations=int(d["reinitializations"]),
               integrity=INTEGRITY_CODES[integ] if 0 <= integ < len(INTEGRITY_CODES) else "?",
               hpl_m=float(d["hpl_m"]), hpl_probability=float(d["hpl_probability"]),
               consistency_k2=float(d["consistency_k2"]))
    return h, int(d["requests_applied"]), int(d["frame_index"])


def is_health(msg) -> bool:
    name = msg.name.decode() if isinstance(msg.name, bytes) else str(msg.name)
    return name.rstrip("\x00") == HEALTH_NAME and msg.array_id == HEALTH_ARRAY_ID
