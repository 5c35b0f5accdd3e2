"""``visnav run SCENARIO --sil``: the simulator plays the autopilot, the navigator runs behind the bridge.

The closed loop of a scenario is flown as usual (vehicle, sensors, mission, controller), paced to the
wall clock, but its navigator is replaced by ``SilLink``, the autopilot side of a MAVLink link on
127.0.0.1:

* every measurement the simulation delivers is sent to the bridge as the autopilot would send it
  (ImuSample -> HIGHRES_IMU, AttitudeSample -> ATTITUDE_QUATERNION, BaroSample -> SCALED_PRESSURE,
  RangeSample -> DISTANCE_SENSOR, GpsSample -> GLOBAL_POSITION_INT), stamped with the instant it describes
  in the autopilot's boot clock (simulation time + ``boot_offset_s``); HEARTBEAT at 1 Hz, TIMESYNC answered,
  GPS_GLOBAL_ORIGIN on request;
* camera frames go to the bridge's camera input (an in-process queue: a frame does not travel over
  MAVLink), stamped with the instant they show;
* what the bridge sends back (ODOMETRY) is the navigation solution the mission and controller fly on:
  ``estimate(t)`` = the newest ODOMETRY carried forward to ``t`` with its velocity, in the simulation's NED.

The bridge runs in this process (threads) with the scenario's own navigator built a second time by
``io.bridge_navigators`` (so it never sees the simulation's truth). Compass samples have no MAVLink path
here and are not forwarded. The navigator behind the bridge writes its diagnostics into the flying
simulation's log, so that the mission's metrics find them.
"""

from __future__ import annotations

import math
import queue
import threading
import time

import numpy as np

from visnav.estimation.ins import euler_to_quat, quat_to_euler
from visnav.geometry.frames import LocalTangentPlane
from visnav.geometry.rotations import euler_to_dcm
from visnav.io import mavlink_messages as mm
from visnav.io.camera_source import Captured, FrameSource
from visnav.io.mavlink_link import mavutil
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import (AttitudeSample, BaroSample, Frame, GpsSample, Health, ImuSample, NavEstimate,
                                 RangeSample)

P0_HPA = 1013.25  # pressure at the NED origin's height


class QueueSource(FrameSource):
    """Frames handed over in-process (the SIL camera)."""

    def __init__(self):
        super().__init__()
        self.q: queue.Queue = queue.Queue(maxsize=64)
        self.closed = False

    def read(self):
        while not self.closed:
            try:
                return self.q.get(timeout=0.1)
            except queue.Empty:
                continue
        return None

    def close(self) -> None:
        self.closed = True


class SilLink:
    """The simulation's navigator slot, talking MAVLink to the bridge (module docstring)."""

    def __init__(self, url: str, camera: QueueSource, origin: LocalTangentPlane, boot_offset_s: float = 1000.0,
                 pace: bool = True):
        self.conn = mavutil.mavlink_connection(url, source_system=1, source_component=1, dialect="common")
        self.mav = self.conn.mav
        self.camera, self.origin = camera, origin
        self.boot_offset_s, self.pace = boot_offset_s, pace
        self.wall0 = time.monotonic()
        self._next_hb = -1.0
        self._odo: list = []  # (t_sim, position, velocity_ned, euler, covariance 6x6, reset_counter)
        self.received: dict[str, int] = {}
        self.sent = 0
        self.frames_dropped = 0  # frames the bridge's camera queue had no room for (it fell behind)
        self.h = Health(source="bridge")
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ clocks
    def boot_us(self, t_sim: float) -> int:
        return int(round((t_sim + self.boot_offset_s) * 1e6))

    def now_sim(self) -> float:
        return time.monotonic() - self.wall0

    def _pace(self, t_sim: float) -> None:
        if self.pace:
            lead = t_sim - self.now_sim()
            if lead > 0:
                time.sleep(lead)

    # ------------------------------------------------------------------ navigator interface
    def update(self, m) -> None:
        self._pace(m.t)
        self._service()
        mav = self.mav
        if isinstance(m, ImuSample):
            msg = mav.highres_imu_encode(self.boot_us(m.t), *m.accel, *m.gyro, 0, 0, 0, 0, 0, 0, 20.0, 0x3F)
        elif isinstance(m, AttitudeSample):
            msg = mav.attitude_quaternion_encode(self.boot_us(m.t) // 1000, *euler_to_quat(m.euler), 0, 0, 0)
        elif isinstance(m, BaroSample):
            p = P0_HPA * (1.0 - m.altitude / 44330.77) ** (1.0 / 0.190263)
            msg = mav.scaled_pressure_encode(self.boot_us(m.t) // 1000, p, 0.0, 2000)
        elif isinstance(m, RangeSample):
            cm = 65535 if not math.isfinite(m.range) else int(round(m.range * 100))
            laser = m.sensor == "laser"  # the PALACE laser (along the camera axis) and the sonar (down)
            msg = mav.distance_sensor_encode(self.boot_us(m.t) // 1000, 10, 60000, min(cm, 65535),
                                             mavlink.MAV_DISTANCE_SENSOR_LASER if laser else
                                             mavlink.MAV_DISTANCE_SENSOR_ULTRASOUND, 0 if laser else 1, 25, 0)
        elif isinstance(m, GpsSample):
            lat, lon, alt = self.origin.ned_to_geodetic(np.asarray(m.position, float))
            v = np.asarray(m.velocity, float)
            msg = mav.global_position_int_encode(self.boot_us(m.t) // 1000, int(round(float(lat) * 1e7)),
                                                 int(round(float(lon) * 1e7)), int(round(float(alt) * 1000)),
                                                 int(round(-m.position[2] * 1000)), *[int(round(x * 100)) for x in v],
                                                 65535)
        elif isinstance(m, Frame):
            now = time.monotonic()
            try:
                self.camera.q.put_nowait(Captured(m.image, self.wall0 + m.t, now, m.index))
            except queue.Full:
                self.frames_dropped += 1
            return
        else:
            return
        mav.send(msg)
        self.sent += 1

    def _service(self) -> None:
        t = self.now_sim()
        if t >= self._next_hb:
            self._next_hb = t + 1.0
            self.mav.send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_HELICOPTER, mavlink.MAV_AUTOPILOT_GENERIC,
                                                    mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0,
                                                    mavlink.MAV_STATE_ACTIVE))
        for _ in range(1000):
            r = self.conn.recv_match(blocking=False)
            if r is None:
                return
            typ = r.get_type()
            self.received[typ] = self.received.get(typ, 0) + 1
            if typ == "TIMESYNC" and r.tc1 == 0:
                self.mav.send(self.mav.timesync_encode(self.boot_us(self.now_sim()) * 1000, r.ts1))
            elif typ == "COMMAND_LONG" and r.command == mavlink.MAV_CMD_REQUEST_MESSAGE and int(r.param1) == 49:
                o = self.origin
                self.mav.send(self.mav.gps_global_origin_encode(int(round(o.lat0_deg * 1e7)),
                                                                int(round(o.lon0_deg * 1e7)),
                                                                int(round(o.h0_m * 1000)), 0))
            elif typ == "ODOMETRY":
                q = np.array(r.q)
                e = quat_to_euler(q)
                v_ned = euler_to_dcm(e) @ np.array([r.vx, r.vy, r.vz])
                P = np.zeros((6, 6))
                P[:3, :3] = mm.from_upper_triangle(r.pose_covariance)[:3, :3]
                Cb = euler_to_dcm(e)
                P[3:, 3:] = Cb @ mm.from_upper_triangle(r.velocity_covariance)[:3, :3] @ Cb.T
                t_sim = r.time_usec * 1e-6 - self.boot_offset_s
                with self._lock:
                    self._odo.append((t_sim, np.array([r.x, r.y, r.z]), v_ned, e, P, r.reset_counter, r.quality))
                    del self._odo[:-50]

    def estimate(self, t: float) -> NavEstimate:
        self._service()
        with self._lock:
            last = self._odo[-1] if self._odo else None
        if last is None:
            return NavEstimate(t=t, position=np.zeros(3), velocity=np.zeros(3), attitude=np.zeros(3), valid=False,
                               source="bridge")
        ts, p, v, e, P, _, q = last
        return NavEstimate(t=t, position=p + v * (t - ts), velocity=v, attitude=e, covariance=P, valid=q > 0,
                           source="bridge")

    def attach(self, navigator, lock) -> None:
        """The navigator behind the bridge, for the mission's commands (see ``__getattr__``)."""
        self._remote, self._remote_lock = navigator, lock

    def __getattr__(self, name):
        """A mission's commands and queries to its navigator (PALACE: request_tracking, set_source,
        tracking_pending, source) reach the navigator behind the bridge directly, as they would from a
        mission running on the companion computer next to it; only estimates travel over MAVLink."""
        remote = self.__dict__.get("_remote")
        if remote is None or name.startswith("_"):
            raise AttributeError(name)
        with self._remote_lock:
            value = getattr(remote, name)
        if not callable(value):
            return value

        def call(*a, **kw):
            with self._remote_lock:
                return value(*a, **kw)

        return call

    def health(self, t: float | None = None) -> Health:
        remote = self.__dict__.get("_remote")
        if remote is None:
            return self.h
        with self._remote_lock:
            return remote.health(None if t is None else self.wall0 + t)

    def close(self) -> None:
        self.conn.close()


def run_sil(sc, progress=None, notify=None, sim=None):
    """Fly Scenario ``sc`` with its navigator behind the bridge (module docstring); the RunResult, with the
    bridge's keys added to its metrics (``sil_`` prefix for the stand-in's own figures)."""
    import socket

    from visnav.io.bridge import Bridge, BridgeConfig
    from visnav.io.bridge_navigators import navigator_from_scenario
    from visnav.io.mavlink_link import MavlinkLink
    from visnav.sim.missions import make_simulation

    sim = sim if sim is not None else make_simulation(sc)
    built = navigator_from_scenario(sc)  # a second, independent navigator: the one behind the bridge
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    notes: list[str] = []
    say = notify or notes.append
    link = MavlinkLink(f"udpin:127.0.0.1:{port}", notify=say)
    cam = QueueSource()
    origin = LocalTangentPlane(58.395, 15.575, 0.0)
    proxy = SilLink(f"udpout:127.0.0.1:{port}", cam, origin)
    sim.nav = proxy
    if hasattr(built.navigator, "recorder"):  # its diagnostics into the flying log, on the simulation's clock
        built.navigator.recorder = lambda name, t, *a, **kw: sim.log.record(name, t - proxy.wall0, *a, **kw)
    # the origin given, as `visnav bridge --origin` does: otherwise a GPS_GLOBAL_ORIGIN answer that comes later
    # than BridgeConfig.origin_wait_s (a loaded machine) makes the bridge take the first fix as its origin
    bridge = Bridge(link, cam, built.navigator, BridgeConfig(origin=origin), notify=say)
    proxy.attach(built.navigator, bridge.nav_lock)
    if hasattr(sim.mission, "nav"):  # the mission talks to the navigator behind the bridge
        sim.mission.nav = proxy
    th = threading.Thread(target=bridge.run, daemon=True, name="bridge")
    th.start()
    try:
        result = sim.run(progress=progress)
    finally:
        bridge.stop.set()
        th.join(timeout=3.0)
        cam.close()
        link.close()
        proxy.close()
    m = bridge.metrics()
    stamps = np.array([usec - proxy.boot_us(t - proxy.wall0) for t, usec in bridge.sent_stamps], float)
    result.metrics.update({
        "link_ok": m["link_ok"], "rate_in_hz": m["rate_in_hz"], "rate_out_hz": m["rate_out_hz"],
        "latency_capture_to_send_ms": m["latency_capture_to_send_ms"], "processing_ms": m["processing_ms"],
        "timesync_offset_ms": m["timesync_offset_ms"], "timesync_rtt_ms": m["timesync_rtt_ms"],
        "reset_counter": m["reset_counter"],
        "sil_stamp_error_ms_max": float(np.max(np.abs(stamps)) / 1000.0) if len(stamps) else float("nan"),
        "sil_odometry_received": proxy.received.get("ODOMETRY", 0), "sil_messages_sent": proxy.sent,
        "sil_frames_dropped": proxy.frames_dropped,
    })
    result.metrics["sil_notes"] = notes[:20]
    return result
