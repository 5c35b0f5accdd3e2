"""A software-in-the-loop autopilot stand-in: a simulated vehicle's MAVLink stream over UDP on 127.0.0.1.

It plays PX4 towards the bridge: HEARTBEAT (quadrotor, PX4) at 1 Hz, HIGHRES_IMU and ATTITUDE_QUATERNION
at 50 Hz, SCALED_PRESSURE and DISTANCE_SENSOR at 10 Hz, GLOBAL_POSITION_INT at 10 Hz while its GPS is good;
it answers TIMESYNC with its own boot clock (which may run ``skew`` fast and start at ``boot_offset_s``),
and takes what the bridge sends back (ODOMETRY, VISION_POSITION_ESTIMATE, GPS_INPUT, SET_GPS_GLOBAL_ORIGIN).

External position fusion: the stand-in's own position solution after GPS loss is dead reckoning with a
velocity bias (an INS drifting at ``drift_mps``); each external position is compared with that solution
*at the instant the message describes* (``time_usec`` in its clock, looked up in a history: the
EKF2_EV_DELAY / VISO_DELAY_MS idea) and corrects it with gain ``ext_gain``. Because it knows the truth, it
records for every received estimate the position error against truth at ``time_usec`` and the error of
the stamp itself (the bridge's ``time_usec`` against the truth instant, when the bridge tells it which
of our instants it meant, see ``tests``).

The vehicle: a horizontal circle of radius ``radius_m`` at ``speed_mps`` and height ``height_m`` (truth in
closed form: position, velocity, attitude with yaw along the track and the coordinated-turn bank, specific
force). Faults: ``drop(seconds)`` stops all its output (a link drop), ``stop_data(seconds)`` stops its
sensor and position messages while HEARTBEAT and TIMESYNC go on (the autopilot's data stops, the link stays
up), ``send_malformed()`` sends a MAVLink 2 frame with a broken CRC. The truth goes on meanwhile.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from visnav.estimation.ins import euler_to_quat
from visnav.geometry.frames import LocalTangentPlane
from visnav.geometry.rotations import euler_to_dcm
from visnav.io.mavlink_link import mavutil
from visnav.io.mavlink_messages import mavlink

G = 9.80665


@dataclass
class CircleTruth:
    radius_m: float = 20.0
    speed_mps: float = 5.0
    height_m: float = 15.0

    def at(self, t: float):
        """(position NED, velocity NED, euler, specific force FRD) at time ``t`` [s]."""
        R, V, h = self.radius_m, self.speed_mps, self.height_m
        w = V / R
        a = w * t
        p = np.array([R * math.sin(a), R * (1 - math.cos(a)), -h])
        v = np.array([V * math.cos(a), V * math.sin(a), 0.0])
        acc = np.array([-V * w * math.sin(a), V * w * math.cos(a), 0.0])  # centripetal, NED
        yaw = math.atan2(v[1], v[0])
        roll = math.atan2(V * w, G)  # coordinated turn
        e = np.array([roll, 0.0, yaw])
        f_body = euler_to_dcm(e).T @ (acc - np.array([0.0, 0.0, G]))
        return p, v, e, f_body


@dataclass
class SilStats:
    received: dict = field(default_factory=dict)
    sent: dict = field(default_factory=dict)  # messages sent by type (muted ones not counted)
    send_span: list = field(default_factory=lambda: [None, None])  # monotonic instants of the first and last send
    ext_errors_m: list = field(default_factory=list)  # |external position - truth(time_usec)|
    ext_stamps_usec: list = field(default_factory=list)
    fused_errors_m: list = field(default_factory=list)  # |own solution - truth| after each correction
    origin_set: tuple | None = None


class SilAutopilot:
    def __init__(self, url: str, truth: CircleTruth | None = None, origin=(58.395, 15.575, 95.0),
                 skew: float = 50e-6, boot_offset_s: float = 1234.5, gps_until_s: float | None = None,
                 drift_mps=(0.3, -0.2, 0.0), ext_gain: float = 0.3, system_id: int = 1, report_origin: bool = True):
        self.conn = mavutil.mavlink_connection(url, source_system=system_id, source_component=1, dialect="common")
        self.mav = self.conn.mav
        self.truth = truth or CircleTruth()
        self.ltp = LocalTangentPlane(*origin)
        self.report_origin = report_origin
        self.ext_frame: LocalTangentPlane | None = self.ltp if report_origin else None  # the bridge's NED
        self.skew, self.boot_offset_s = skew, boot_offset_s
        self.gps_until_s = gps_until_s
        self.drift = np.asarray(drift_mps, float)
        self.ext_gain = ext_gain
        self.t0 = time.monotonic()
        self.stats = SilStats()
        self._stop = threading.Event()
        self._mute_until = 0.0
        self._data_mute_until = 0.0
        self._correction = np.zeros(3)
        self._lock = threading.Lock()
        self.p0_hpa = 1013.25
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ clocks
    def sim_t(self, mono: float | None = None) -> float:
        """Simulation time [s] (truth), from our shared monotonic clock."""
        return (time.monotonic() if mono is None else mono) - self.t0

    def boot_ns(self, mono: float | None = None) -> int:
        """The autopilot's boot clock [ns]: runs (1 + skew) fast, starts at boot_offset_s."""
        return int(((self.sim_t(mono)) * (1.0 + self.skew) + self.boot_offset_s) * 1e9)

    def mono_of_boot_us(self, usec: int) -> float:
        """Inverse of boot_ns: our monotonic instant of an autopilot stamp [s]."""
        return (usec * 1e-6 - self.boot_offset_s) / (1.0 + self.skew) + self.t0

    def own_position(self, t: float) -> np.ndarray:
        """The stand-in's own (drifting, externally corrected) position solution at sim time t."""
        p = self.truth.at(t)[0]
        return p + self.drift * max(t - (self.gps_until_s or 0.0), 0.0) + self._correction

    # ------------------------------------------------------------------ loop
    def start(self, duration_s: float) -> None:
        self._thread = threading.Thread(target=self._run, args=(duration_s,), daemon=True, name="sil-autopilot")
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.conn.close()

    def drop(self, seconds: float) -> None:
        self._mute_until = time.monotonic() + seconds

    def stop_data(self, seconds: float) -> None:
        self._data_mute_until = time.monotonic() + seconds

    def send_malformed(self) -> None:
        buf = bytearray(self.mav.heartbeat_encode(2, 12, 0, 0, 4).pack(self.mav))
        buf[-1] ^= 0xFF  # break the CRC
        self.conn.write(bytes(buf))

    def _send(self, msg) -> None:
        now = time.monotonic()
        if now >= self._mute_until and (now >= self._data_mute_until or msg.get_type() == "HEARTBEAT"):
            self.mav.send(msg)
            typ = msg.get_type()
            self.stats.sent[typ] = self.stats.sent.get(typ, 0) + 1
            self.stats.send_span[0] = now if self.stats.send_span[0] is None else self.stats.send_span[0]
            self.stats.send_span[1] = now

    def _run(self, duration_s: float) -> None:
        period = {"hb": 1.0, "imu": 0.02, "att": 0.02, "baro": 0.1, "rng": 0.1, "gps": 0.1}
        nxt = dict.fromkeys(period, 0.0)
        t_end = self.t0 + duration_s
        while not self._stop.is_set() and time.monotonic() < t_end:
            mono = time.monotonic()
            t = self.sim_t(mono)
            bn = self.boot_ns(mono)
            p, v, e, f = self.truth.at(t)
            due = [k for k in period if t >= nxt[k]]
            for k in due:  # a starved loop skips what it missed (an autopilot sends no burst of old samples)
                nxt[k] = max(nxt[k] + period[k], t)
            if "hb" in due:
                self._send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4,
                                                     mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0,
                                                     mavlink.MAV_STATE_ACTIVE))
            if "imu" in due:
                w = self.truth.speed_mps / self.truth.radius_m
                gyro = euler_to_dcm(e).T @ np.array([0.0, 0.0, w])
                self._send(self.mav.highres_imu_encode(bn // 1000, *f, *gyro, 0, 0, 0, 1000.0, 0, -p[2], 20.0,
                                                       0x3F))
            if "att" in due:
                q = euler_to_quat(e)
                self._send(self.mav.attitude_quaternion_encode(bn // 1_000_000, *q, 0, 0, 0))
            if "baro" in due:
                p_hpa = self.p0_hpa * (1 - (-p[2]) / 44330.77) ** (1 / 0.190263)  # ISA, inverse of pressure_altitude
                self._send(self.mav.scaled_pressure_encode(bn // 1_000_000, p_hpa, 0.0, 2000))
            if "rng" in due:
                self._send(self.mav.distance_sensor_encode(bn // 1_000_000, 20, 4000, int(round(-p[2] * 100)),
                                                           mavlink.MAV_DISTANCE_SENSOR_LASER, 0, 25, 0))
            if "gps" in due and (self.gps_until_s is None or t < self.gps_until_s):
                lat, lon, alt = self.ltp.ned_to_geodetic(p)
                self._send(self.mav.global_position_int_encode(
                    bn // 1_000_000, int(round(float(lat) * 1e7)), int(round(float(lon) * 1e7)),
                    int(round(float(alt) * 1000)), int(round(-p[2] * 1000)), *[int(round(x * 100)) for x in v],
                    int(round(math.degrees(e[2]) % 360 * 100))))
            self._receive()
            time.sleep(0.001)

    def _receive(self) -> None:
        while True:
            m = self.conn.recv_match(blocking=False)
            if m is None:
                return
            typ = m.get_type()
            self.stats.received[typ] = self.stats.received.get(typ, 0) + 1
            if typ == "TIMESYNC" and m.tc1 == 0 and time.monotonic() >= self._mute_until:
                self.mav.send(self.mav.timesync_encode(self.boot_ns(), m.ts1))
            elif typ in ("ODOMETRY", "VISION_POSITION_ESTIMATE"):
                usec = m.time_usec if typ == "ODOMETRY" else m.usec
                if self.ext_frame is not None:  # the bridge's NED -> ours (they differ if it set the origin)
                    z = self.ltp.geodetic_to_ned(*self.ext_frame.ned_to_geodetic(np.array([m.x, m.y, m.z])))
                    self._fuse(usec, z)
            elif typ == "GPS_INPUT" and m.fix_type >= 3:
                self._fuse(m.time_usec, self.ltp.geodetic_to_ned(m.lat * 1e-7, m.lon * 1e-7, m.alt))
            elif typ == "SET_GPS_GLOBAL_ORIGIN":
                self.stats.origin_set = (m.latitude, m.longitude, m.altitude)
                self.ext_frame = LocalTangentPlane(m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
            elif (typ == "COMMAND_LONG" and m.command == mavlink.MAV_CMD_REQUEST_MESSAGE and self.report_origin
                  and int(m.param1) == mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN):
                o = self.ltp
                self._send(self.mav.gps_global_origin_encode(int(round(o.lat0_deg * 1e7)), int(round(o.lon0_deg * 1e7)),
                                                             int(round(o.h0_m * 1000)), self.boot_ns() // 1000))

    def _fuse(self, usec: int, z: np.ndarray) -> None:
        """External position at its own instant: innovation against the solution at that instant."""
        t_meas = self.sim_t(self.mono_of_boot_us(usec))
        truth = self.truth.at(t_meas)[0]
        self.stats.ext_errors_m.append(float(np.linalg.norm(z - truth)))
        self.stats.ext_stamps_usec.append(int(usec))
        self._correction = self._correction + self.ext_gain * (z - self.own_position(t_meas))
        t_now = self.sim_t()
        self.stats.fused_errors_m.append(float(np.linalg.norm(self.own_position(t_now) - self.truth.at(t_now)[0])))
