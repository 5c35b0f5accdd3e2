"""``visnav run SCENARIO --sil``: the simulator plays the autopilot, the navigator runs in ``visnav bridge``,
a separate process, over MAVLink on 127.0.0.1.

The closed loop of a scenario is flown as usual (vehicle, sensors, mission, controller), paced to the
wall clock, but its navigator slot holds ``SilLink`` (through the simulation's ``navigator_wrapper``), the
autopilot side of a MAVLink link:

* every measurement the simulation delivers is sent as the autopilot would send it (ImuSample -> HIGHRES_IMU,
  AttitudeSample -> ATTITUDE_QUATERNION, BaroSample -> SCALED_PRESSURE, RangeSample -> DISTANCE_SENSOR,
  GpsSample -> GLOBAL_POSITION_INT), stamped with the instant it describes in the autopilot's boot clock;
  HEARTBEAT at 1 Hz, TIMESYNC answered, GPS_GLOBAL_ORIGIN on request;
* camera frames, all of them (the mission's camera gate is an in-process economy), go to the bridge's camera
  input ``vnframes://127.0.0.1:PORT`` (``io/camera_source``: TCP, with the exposure instant in CLOCK_MONOTONIC,
  the clock every process of the machine shares);
* the mission's requests to its navigator (``command(NavCommand)``) travel as COMMAND_LONG MAV_CMD_USER_1
  (acknowledged, retried), the navigator's health comes back as DEBUG_FLOAT_ARRAY "VN_HEALTH"
  (``io/mavlink_messages``, docs/autopilots.md); a request is pending for the mission until a health
  message says the navigator applied it;
* what the bridge sends back (ODOMETRY) is fused by the autopilot's own navigation solution
  (``ExternalFusion``), which the mission and controller fly on: as PX4's EKF2 and ArduPilot's EKF3 do with
  an external vision source, each estimate is fused at the instant it describes (``time_usec``, the delayed
  horizon) and the solution is carried from there to the present with the autopilot's IMU (its specific
  force through its attitude), sample by sample, so neither the capture-to-send latency nor the time
  between two estimates (a camera the mission switched off) is flown on a stale state.

``run_sil`` starts ``visnav bridge`` as a subprocess (``spawn=True``) or waits for one the user starts in
another terminal (it prints the command line), and ends the bridge's session with MAV_CMD_PREFLIGHT_REBOOT_
SHUTDOWN (param2 = 2: shut the companion computer down). Afterwards the streams the navigator recorded in
the bridge process (``navigator.h5``, e.g. PALACE's ``mpe``, WITAS's ``pmf``) are merged into the flying
log on the simulation's clock and the metrics are computed again from the log, so a SIL run is scored like
an in-process one. Compass samples have no MAVLink path here and are not forwarded.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import socket
import subprocess
import sys
import threading
import time
from collections import deque
from pathlib import Path

import numpy as np

from visnav.estimation.ins import euler_to_quat, quat_to_euler
from visnav.estimation.position_filter import accel_ned
from visnav.geometry.frames import LocalTangentPlane
from visnav.geometry.rotations import euler_to_dcm
from visnav.io import mavlink_messages as mm
from visnav.io.camera_source import FrameStreamServer
from visnav.io.mavlink_link import mavutil
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import (AttitudeSample, BaroSample, Frame, GpsSample, Health, ImuSample, NavEstimate,
                                 RangeSample)
from visnav.navigation.base import propagate
from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.app.missions import make_simulation
from visnav.app.navigators import navigator_for
from visnav.flightlog import FlightLog
import tempfile
from visnav.scenarios.schema import to_toml

P0_HPA = 1013.25  # pressure at the NED origin's height
ORIGIN = (58.395, 15.575, 0.0)  # the simulation's NED origin as the autopilot reports it
BRIDGE_COMPONENT = mavlink.MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
REQUEST_RETRY_S, REQUEST_TRIES = 0.3, 10
SIL_BEHIND_LIMIT_S = 0.1  # a paced run that fell further behind the wall clock than this is said not real-time
SIL_NAVIGATORS = ("palace", "witas")  # navigators the bridge can run from a scenario alone


class SilError(RuntimeError):
    """The SIL could not start or talk to the bridge (one line)."""


def free_port(kind=socket.SOCK_DGRAM) -> int:
    s = socket.socket(socket.AF_INET, kind)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


class ExternalFusion:
    """The autopilot's position/velocity solution from an external navigation source and its own IMU.

    ``imu(t, a)`` carries the solution to the IMU sample's instant with its kinematic acceleration ``a``
    (NED: the specific force through the autopilot's attitude, plus gravity) over the interval ending at
    ``t`` -- the mechanization of the in-process navigators (``PositionFilter.predict``). ``fuse(ts, p, v)``
    takes an external estimate at the instant ``ts`` it describes (in the past: the bridge's latency): the
    solution at ``ts`` becomes that estimate (the navigator's filtered position and velocity: the autopilot
    trusts it fully -- with its tight covariance an EKF's gain is near one) and is propagated again to the
    newest IMU sample through the accelerations buffered since ``ts``: the delayed-horizon fusion of PX4's
    EKF2 (EKF2_EV_DELAY) and ArduPilot's EKF3 (VISO_DELAY_MS), with the IMU carrying it to the present.
    ``at(t)`` is the solution carried on to ``t`` with the newest acceleration (``navigation.base.propagate``).
    """

    def __init__(self, horizon_s: float = 5.0):
        self.horizon_s = horizon_s
        self._acc: deque = deque()  # (t, kinematic acceleration NED) of the IMU samples within the horizon
        self.t: float | None = None  # the solution's instant (None: nothing fused yet)
        self.p = np.zeros(3)
        self.v = np.zeros(3)
        self.a = np.zeros(3)  # the newest acceleration it was carried with
        self.fused = 0

    def imu(self, t: float, a: np.ndarray) -> None:
        acc = self._acc
        if acc and t <= acc[-1][0]:
            return  # not after the previous sample
        acc.append((t, a))
        while acc and acc[0][0] < t - self.horizon_s:
            acc.popleft()
        if self.t is not None and t > self.t:
            self.p, self.v = propagate(self.p, self.v, a, t - self.t)
            self.t, self.a = t, a

    def fuse(self, ts: float, p, v) -> None:
        p, v, t, a = np.asarray(p, float), np.asarray(v, float), ts, self.a
        for tk, ak in self._acc:  # the IMU samples after the estimate's instant, in order
            if tk > t:
                p, v = propagate(p, v, ak, tk - t)
                t, a = tk, ak
        self.t, self.p, self.v, self.a = t, p, v, a
        self.fused += 1

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        return propagate(self.p, self.v, self.a, t - self.t)


class SilLink:
    """The simulation's navigator slot, talking MAVLink to the bridge (module docstring)."""

    def __init__(self, port: int, frames: FrameStreamServer, origin: LocalTangentPlane,
                 boot_offset_s: float = 1000.0, pace: bool = True):
        self.port = port
        self.conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1, source_component=1,
                                               dialect="common")
        self.mav = self.conn.mav
        self.frames, self.origin, self.pace = frames, origin, pace
        self.boot_base = time.monotonic() - boot_offset_s  # the autopilot booted boot_offset_s ago
        self.wall0 = time.monotonic()  # monotonic instant of simulation time 0 (``start_clock``)
        self._next_hb = 0.0
        self._odo: list = []  # (t_sim, position, velocity_ned, euler, covariance 6x6, reset_counter, quality)
        self._odo_usec: set[int] = set()
        self._odo_new: list = []  # received, not fused yet (the simulation's thread fuses them)
        self.fusion = ExternalFusion()  # the autopilot's solution the mission and controller fly on
        self._att: np.ndarray | None = None  # the autopilot's newest attitude (Euler 3-2-1)
        self.received: dict[str, int] = {}
        self.sent = 0
        self.timesync_answered = 0
        self.bridge_seen = False
        self._ts_rx: list[float] = []  # when the bridge's last TIMESYNC requests came
        self.frame_t: dict[int, float] = {}  # frame index -> exposure instant (simulation time)
        self.behind_s = 0.0  # how far the simulation fell behind the wall clock at worst (paced runs) [s]
        self.frame_lag_ms: list[float] = []  # the simulated camera's latency plus any lag behind the wall clock
        self.stamp_errors_ms: list[float] = []  # ODOMETRY time_usec -> sim time, minus the frame's exposure
        self.h = Health(source="bridge")
        self._jump = False
        self.applied = 0  # newest request the navigator applied (from its health)
        self._seq = 0
        self._pending: dict[int, list] = {}  # seq -> [message, last sent (monotonic), tries]
        self.requests_failed: list[str] = []
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        # the autopilot's receive side, HEARTBEAT and request retries run on their own thread (TIMESYNC answered
        # at once, as a flight controller does, whatever the simulation loop is doing)
        self._rx = threading.Thread(target=self._rx_loop, daemon=True, name="sil-autopilot-rx")
        self._rx.start()

    def _send(self, msg) -> None:
        with self._send_lock:
            self.mav.send(msg)

    def _rx_loop(self) -> None:
        while not self._stop.is_set():
            self._service()
            try:
                r = self.conn.recv_match(blocking=True, timeout=0.05)
            except OSError:
                return
            if r is not None:
                self._receive(r)

    # ------------------------------------------------------------------ clocks
    def start_clock(self) -> None:
        """Simulation time 0 = now (the autopilot's boot clock runs on unchanged)."""
        self.wall0 = time.monotonic()

    def boot_us(self, t_sim: float) -> int:
        return int(round((self.wall0 + t_sim - self.boot_base) * 1e6))

    def sim_of_boot_us(self, usec: int) -> float:
        return usec * 1e-6 + self.boot_base - self.wall0

    def now_sim(self) -> float:
        return time.monotonic() - self.wall0

    def _pace(self, t_sim: float) -> None:
        if self.pace:
            lead = t_sim - self.now_sim()
            if lead > 0:
                time.sleep(lead)
            elif -lead > self.behind_s:
                self.behind_s = -lead  # the simulation could not keep up with the wall clock

    # ------------------------------------------------------------------ navigator interface
    def update(self, m) -> None:
        self._pace(m.t)
        mav = self.mav
        if isinstance(m, AttitudeSample) and np.all(np.isfinite(m.euler)):
            self._att = np.asarray(m.euler, float)
        elif isinstance(m, ImuSample) and self._att is not None and np.all(np.isfinite(m.accel)):
            self.fusion.imu(float(m.t), accel_ned(euler_to_dcm(self._att), np.asarray(m.accel, float)))
            self._fuse_received(float(m.t))
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
            self.frame_t[int(m.index)] = float(m.t)
            self.frame_lag_ms.append((self.now_sim() - m.t) * 1e3)  # exposure -> handed to the frame stream
            self.frames.send(np.asarray(m.image), self.wall0 + m.t, int(m.index))
            return
        else:
            return
        self._send(msg)
        self.sent += 1

    def command(self, cmd) -> None:
        """A mission request: COMMAND_LONG MAV_CMD_USER_1 to the bridge, retried until acknowledged."""
        self._seq += 1
        msg = mm.encode_nav_command(self.mav, cmd, self._seq, 1, BRIDGE_COMPONENT)
        self._pending[self._seq] = [msg, time.monotonic(), 1]
        self._send(msg)

    def initialize(self, init) -> None:
        raise ValueError("an explicit navigator start (NavInit) has no MAVLink mapping: a scenario with a nav_init "
                         "cannot fly --sil")

    def _service(self) -> None:
        """HEARTBEAT at 1 Hz and the retries of unacknowledged requests (the receive thread calls it)."""
        now = time.monotonic()
        if now >= self._next_hb:
            self._next_hb = now + 1.0
            self._send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_HELICOPTER, mavlink.MAV_AUTOPILOT_GENERIC,
                                                    mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0,
                                                    mavlink.MAV_STATE_ACTIVE))
        for seq, p in list(self._pending.items()):  # unacknowledged requests (UDP may lose one)
            if now - p[1] >= REQUEST_RETRY_S:
                if p[2] >= REQUEST_TRIES:
                    self.requests_failed.append(f"request {seq} not acknowledged after {REQUEST_TRIES} tries")
                    self._pending.pop(seq, None)
                    continue
                self._send(p[0])
                p[1], p[2] = now, p[2] + 1

    def _receive(self, r) -> None:
        typ = r.get_type()
        self.received[typ] = self.received.get(typ, 0) + 1
        if typ == "HEARTBEAT" and r.get_srcComponent() == BRIDGE_COMPONENT:
            self.bridge_seen = True
        elif typ == "TIMESYNC" and r.tc1 == 0:
            now = time.monotonic()
            self._send(self.mav.timesync_encode(int((now - self.boot_base) * 1e9), r.ts1))
            self.timesync_answered += 1
            self._ts_rx.append(now)
            del self._ts_rx[:-4]
        elif typ == "COMMAND_LONG" and r.command == mavlink.MAV_CMD_REQUEST_MESSAGE and int(r.param1) == 49:
            o = self.origin
            self._send(self.mav.gps_global_origin_encode(int(round(o.lat0_deg * 1e7)), int(round(o.lon0_deg * 1e7)),
                                                            int(round(o.h0_m * 1000)), 0))
        elif typ == "COMMAND_ACK" and r.command == mm.NAV_COMMAND_ID:
            self._pending.pop(int(r.result_param2), None)
            if r.result != mavlink.MAV_RESULT_ACCEPTED:
                self.requests_failed.append(f"request {r.result_param2} refused (MAV_RESULT {r.result})")
        elif typ == "DEBUG_FLOAT_ARRAY" and mm.is_health(r):
            h, applied, frame = mm.decode_health(r)
            with self._lock:
                self.h, self.applied = h, max(self.applied, applied)
                self._jump |= h.mpe_jump
            if frame >= 0 and frame in self.frame_t and r.time_usec in self._odo_usec:
                self.stamp_errors_ms.append((self.sim_of_boot_us(r.time_usec) - self.frame_t[frame]) * 1e3)
        elif typ == "ODOMETRY":
            e = quat_to_euler(np.array(r.q))
            Cb = euler_to_dcm(e)
            v_ned = Cb @ np.array([r.vx, r.vy, r.vz])
            P = np.zeros((6, 6))
            P[:3, :3] = mm.from_upper_triangle(r.pose_covariance)[:3, :3]
            P[3:, 3:] = Cb @ mm.from_upper_triangle(r.velocity_covariance)[:3, :3] @ Cb.T
            odo = (self.sim_of_boot_us(r.time_usec), np.array([r.x, r.y, r.z]), v_ned, e, P, r.reset_counter,
                   r.quality)
            with self._lock:
                self._odo.append(odo)
                del self._odo[:-50]
                self._odo_usec.add(int(r.time_usec))
                self._odo_new.append(odo)

    def _fuse_received(self, t_imu: float) -> None:
        """The ODOMETRY received since the last call (a valid one: quality > 0), each fused at its instant once
        the autopilot's IMU has reached it (``t_imu``: a stamp ahead of it waits, as on an EKF's buffer)."""
        with self._lock:
            due = [o for o in self._odo_new if o[0] <= t_imu]
            self._odo_new = [o for o in self._odo_new if o[0] > t_imu]
        for ts, p, v, _, _, _, q in due:
            if q > 0 and np.all(np.isfinite(p)) and np.all(np.isfinite(v)):
                self.fusion.fuse(ts, p, v)

    def estimate(self, t: float) -> NavEstimate:
        """The autopilot's solution at ``t`` (``ExternalFusion``): the bridge's estimates fused at their instants,
        carried to ``t`` with the IMU; its attitude is the autopilot's own."""
        self._fuse_received(t)
        with self._lock:
            last = self._odo[-1] if self._odo else None
        if last is None or self.fusion.t is None:
            return NavEstimate(t=t, position=np.zeros(3), velocity=np.zeros(3), attitude=np.zeros(3), valid=False,
                               source="bridge")
        _, _, _, e, P, _, q = last
        p, v = self.fusion.at(t)
        return NavEstimate(t=t, position=p, velocity=v, attitude=self._att.copy() if self._att is not None else e,
                           covariance=P, valid=q > 0, source=self.h.source if self.h.source != "bridge" else "bridge")

    def health(self, t: float | None = None) -> Health:
        """The navigator's newest health; a request it has not applied yet is pending (``tracking_pending``),
        a position jump reported since the last call is kept (``mpe_jump``)."""
        with self._lock:
            h = Health(**{k: getattr(self.h, k) for k in Health.__dataclass_fields__})
            h.tracking_pending = h.tracking_pending or self.applied < self._seq
            h.mpe_jump, self._jump = h.mpe_jump or self._jump, False
        return h

    def synced(self) -> bool:
        """The bridge's clock sync has converged: it asks TIMESYNC at 4x its steady rate until then
        (io/mavlink_link.py), so three intervals above 1.5x the fast period say it is done."""
        ts = self._ts_rx
        return len(ts) >= 4 and self.timesync_answered >= 8 and min(np.diff(ts)) > 0.06 \
            and time.monotonic() - ts[-1] < 0.5

    def shutdown_bridge(self) -> None:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, param2 = 2 (shut down the onboard computer): the bridge ends its
        session, writes its logs and exits."""
        self._send(self.mav.command_long_encode(1, BRIDGE_COMPONENT, mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
                                                   0, 0, 2, 0, 0, 0, 0, 0))

    def close(self) -> None:
        self._stop.set()
        self._rx.join(timeout=1.0)
        self.conn.close()
        self.frames.close()


def sil_simulation(sc):
    """The scenario's simulation with ``SilLink`` in its navigator slot (``sim.sil_link``)."""
    kind = getattr(sc.mission, "type", "palace")
    try:
        name = navigator_for(kind)
    except ValueError:
        name = None
    if name not in SIL_NAVIGATORS:
        raise ValueError(f"--sil flies missions whose navigator runs behind `visnav bridge` ({', '.join(SIL_NAVIGATORS)}"
                         f" navigators: palace-landing, hover, pfcm, witas-homing); mission.type {kind!r} has "
                         + ("the pad navigator, which needs a pan-tilt link" if name == "pad" else "none"))
    frames = FrameStreamServer()
    link = SilLink(free_port(), frames, LocalTangentPlane(*ORIGIN))
    sim = make_simulation(sc, navigator_wrapper=lambda nav: link)
    # the camera is the companion computer's and streams all the time: in-process the mission's gate skips
    # rendering the frames its navigator will not use (PALACE below 1 m), behind the bridge that gap would
    # be a camera stall (no estimate out for ``BridgeConfig.stall_s``, then quality capped)
    sim.parts.routing.gates.pop("camera", None)
    sim.sil_link = link
    return sim


def bridge_command(sc_toml: Path, link: SilLink, out_dir: Path, gps_sigma_m: float = mm.GPS_SIGMA_M) -> list[str]:
    """The ``visnav bridge`` command line that serves this SIL flight. ``gps_sigma_m``: the simulated GPS's
    sigma (GLOBAL_POSITION_INT carries none; in-process the navigator gets it with every fix)."""
    return ["visnav", "bridge", "--mavlink", f"udpin:127.0.0.1:{link.port}", "--camera", link.frames.url,
            "--navigator", str(sc_toml), "--origin", ",".join(f"{x:g}" for x in ORIGIN), "--health",
            "--gps-sigma", f"{gps_sigma_m:g}", "--out", str(out_dir)]


def _wait_ready(link: SilLink, proc, timeout_s: float, log: Path) -> None:
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        if link.bridge_seen and link.frames.conn is not None and link.synced():
            return
        if proc is not None and proc.poll() is not None:
            tail = log.read_text().strip().splitlines()[-1:] if log.is_file() else []
            raise SilError(f"visnav bridge exited (code {proc.returncode}) before the flight: "
                           f"{tail[0] if tail else 'no output'}")
        time.sleep(0.01)
    raise SilError(f"no bridge on udp 127.0.0.1:{link.port} / {link.frames.url} within {timeout_s:g} s "
                   "(HEARTBEAT, TIMESYNC and the frame stream)")


def _merge_navigator_streams(sim, path: Path, wall0: float) -> int:
    """The bridge navigator's own streams (monotonic clock) into the flying log (simulation time)."""
    nav = FlightLog.from_hdf5(path)
    n = 0
    for name in nav.streams():
        s = nav.get(name)
        keys = [k for k in s if k != "t"]
        for i, t in enumerate(s["t"]):
            sim.log.record(name, float(t) - wall0, **{k: s[k][i] for k in keys})
            n += 1
    return n


def run_sil(sc, progress=None, notify=None, sim=None, out_dir: str | Path | None = None, spawn: bool = True,
            ready_timeout_s: float = 120.0):
    """Fly Scenario ``sc`` against ``visnav bridge`` in another process (module docstring); the RunResult with
    the bridge's keys added to its metrics (``sil_`` prefix for the autopilot side's own figures). The
    bridge's log folder (metrics.json, bridge.tlog, recording/, navigator.h5, bridge.out) is ``out_dir``
    (default: a temporary folder)."""


    sim = sim if sim is not None else sil_simulation(sc)
    link: SilLink = sim.sil_link
    notes: list[str] = []
    say = notify or notes.append
    bdir = Path(out_dir) if out_dir is not None else Path(tempfile.mkdtemp(prefix="visnav-sil-"))
    bdir.mkdir(parents=True, exist_ok=True)
    sc_toml = bdir / "navigator-scenario.toml"
    sc_toml.write_text(to_toml(sc))
    cmd = bridge_command(sc_toml, link, bdir, float(sc.sensors.gps.sigma_m))
    out_log = bdir / "bridge.out"
    proc = None
    if spawn:
        argv = [sys.executable, "-m", "visnav.cli"] + cmd[1:]
        env = dict(os.environ, COLUMNS="200", TERM="dumb")
        with open(out_log, "w") as fh:
            proc = subprocess.Popen(argv, stdout=fh, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env)
    else:
        say("start the bridge in another terminal: " + shlex.join(cmd))
    try:
        _wait_ready(link, proc, ready_timeout_s, out_log)
        link.start_clock()
        wall0 = time.perf_counter()
        result = sim.run(progress=progress)
        wall = time.perf_counter() - wall0
    except BaseException:
        if proc is not None and proc.poll() is None:
            proc.kill()
        link.close()
        raise
    # end the bridge's session; it writes its logs
    metrics_path = bdir / "metrics.json"
    t_end = time.monotonic() + 60.0
    next_shutdown = 0.0
    while time.monotonic() < t_end:
        if time.monotonic() >= next_shutdown:
            link.shutdown_bridge()
            next_shutdown = time.monotonic() + 1.0
        if proc is not None and proc.poll() is not None:
            break
        if proc is None and metrics_path.is_file() and metrics_path.stat().st_mtime > time.time() - 60:
            time.sleep(1.0)  # navigator.h5 and the recording are written before metrics.json
            break
        time.sleep(0.05)
    if proc is not None and proc.poll() is None:
        proc.kill()
        say("the bridge did not end its session within 60 s: killed")
    link.close()
    m = json.loads(metrics_path.read_text()) if metrics_path.is_file() else {}
    if (bdir / "navigator.h5").is_file():  # score the flight like an in-process one
        _merge_navigator_streams(sim, bdir / "navigator.h5", link.wall0)
        metrics = sim._metrics(sim.log, sc, wall_time_s=wall, error=result.error)
        metrics.update(integrity_metrics(sim.log, sc))
        result.metrics = metrics
    else:
        say(f"{bdir / 'navigator.h5'} missing: metrics from the autopilot side's log only")
    stamps = np.abs(np.array(link.stamp_errors_ms)) if link.stamp_errors_ms else np.array([np.nan])
    lag = np.array(link.frame_lag_ms) if link.frame_lag_ms else np.array([np.nan])
    result.metrics.update({k: m[k] for k in ("link_ok", "rate_in_hz", "rate_out_hz", "latency_capture_to_send_ms",
                                             "latency_arrival_to_send_ms", "processing_ms", "timesync_offset_ms", "timesync_rtt_ms",
                                             "reset_counter") if k in m})
    result.metrics.update({
        "sil_stamp_error_ms_max": float(np.max(stamps)), "sil_stamp_error_ms_median": float(np.median(stamps)),
        "sil_stamps_checked": len(link.stamp_errors_ms),
        "sil_frame_handover_ms": {"median": float(np.median(lag)), "p95": float(np.percentile(lag, 95))},
        "sil_odometry_received": link.received.get("ODOMETRY", 0), "sil_messages_sent": link.sent,
        "sil_frames_dropped": link.frames.dropped, "sil_requests_sent": link._seq,
        "sil_requests_applied": link.applied, "sil_bridge_process": "spawned" if spawn else "external",
        "sil_bridge_dir": str(bdir),
    })
    result.metrics["sil_behind_wall_clock_ms_max"] = link.behind_s * 1e3
    if link.behind_s > SIL_BEHIND_LIMIT_S:
        msg = (f"the simulation fell {link.behind_s:.2f} s behind the wall clock (the machine could not fly it in "
               "real time): its latency and outcome do not describe a real-time flight")
        say(msg)
        if notify is not None:
            notes.append(msg)
    if link.requests_failed:
        notes += link.requests_failed[:5]
    if out_log.is_file():
        notes += [ln for ln in out_log.read_text().splitlines() if ln.strip()][-10:]
    result.metrics["sil_notes"] = notes[:30]
    return result
