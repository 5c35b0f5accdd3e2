"""The live bridge: autopilot MAVLink + camera -> a visnav navigator -> ODOMETRY / VISION_* / GPS_INPUT.

Threads: a MAVLink reader (poll, HEARTBEAT/TIMESYNC upkeep, decoding into measurements stamped in our
clock), a camera reader (frames stamped at capture), and the navigator loop (this thread: it alone calls
``navigator.update / estimate / health``, so navigators need no locks). After every frame the estimate
at the frame's instant is encoded with ``time_usec`` = that instant in the autopilot's clock and sent;
the capture-to-send latency is recorded.

Mission requests (COMMAND_LONG MAV_CMD_USER_1, ``io/mavlink_messages``) go through the same queue and are
applied on the navigator thread between two updates, acknowledged (COMMAND_ACK, ``result_param2`` = the
request's sequence number); with ``send_health`` the navigator's Health goes out as DEBUG_FLOAT_ARRAY
"VN_HEALTH" with every estimate and after every request. MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (param2 = 2)
addressed to us ends the session. ``BridgeRecording`` writes the log as a replayable recording.

GPS for the navigator: GPS_RAW_INT (the receiver) when the autopilot streams it; GLOBAL_POSITION_INT (the
autopilot's fused solution) only when it does not -- once the autopilot fuses our output, its fused
position would otherwise come back to the navigator as if it were GPS.

Faults, each reported once through ``notify`` (one line) and counted:

* autopilot link lost / back (HEARTBEAT watch in ``MavlinkLink``): the bridge keeps running; on link
  back the message intervals are requested again and ``reset_counter`` is incremented (the autopilot's
  filter must not blend the estimate across the gap);
* camera stall (no frame for ``stall_s``): the estimate keeps going out at ``stall_output_hz`` from the
  navigator's inertial propagation with ``quality`` capped at ``stall_quality``; "camera back" when
  frames return;
* frames out of order (a stamp not after the previous one): dropped, counted; the same for MAVLink samples
  of one kind (an IMU message stamped before the previous one), so a navigator never integrates backwards;
* stale inputs (``io/bridge_freshness.py``): every estimate's covariance, ODOMETRY quality and GPS_INPUT fix
  type / accuracies grow with the age of each input stream (IMU/attitude, GPS, range/baro, camera) and with
  the filter's own covariance; past a stream's timeout (IMU/attitude 1 s, camera 10 s) no estimate is sent
  (said once: console/log and a STATUSTEXT to the autopilot) until the stream is back, then
  ``reset_counter`` + 1 unless the link-back already counted it;
* malformed MAVLink packets: counted and skipped (``MavlinkLink``);
* an estimate jump (position moved more than ``jump_sigma`` standard deviations, and ``jump_min_m``,
  against the previous estimate propagated with its velocity), a navigator reinitialisation, a source change (gps -> vision)
  or an invalid -> valid transition: ``reset_counter`` + 1.
"""

from __future__ import annotations

import json
import queue
import threading
import time
from collections import Counter, deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from visnav.geometry.frames import LocalTangentPlane
from visnav.io import mavlink_messages as mm
from visnav.io.bridge_freshness import LABELS, Assessment, Freshness, FreshnessConfig, stream_of
from visnav.io.camera_source import FrameSource
from visnav.io.mavlink_link import MavlinkLink
from visnav.io.mavlink_messages import mavlink
from visnav.log_schema import register_stream
from visnav.measurements import Frame, NavCommand, NavEstimate
from visnav.app.record import RecordingNavigator
from visnav.io.recording_writer import RecordingWriter
from visnav.scenarios.schema import to_toml

register_stream(
    "bridge_estimate", position=("m", "NED about the bridge's origin", "the estimate sent (float64, before encoding)"),
    velocity=("m/s", "NED", "velocity of the estimate sent"),
    euler=("rad", "3-2-1 Euler angles of body FRD relative to NED", "attitude of the estimate sent"),
    valid=("bool", "", "the estimate was valid"), time_usec=("us", "the autopilot's time since boot",
                                                             "time_usec the messages carried (t in its clock)"),
    quality=("1", "", "ODOMETRY quality 0..100"),
    sigma_h=("m", "", "horizontal 1-sigma sent (the navigator's covariance grown with its inputs' age)"), reset_counter=("1", "", "reset_counter sent"),
    frame_index=("1", "", "the frame whose estimate it is (-1: the inertial estimate of a camera stall)"))


@dataclass(frozen=True)
class NavRequest:
    """A mission request that came over MAVLink (COMMAND_LONG MAV_CMD_USER_1, io/mavlink_messages.py)."""

    seq: int
    cmd: NavCommand
    src: tuple[int, int]

OUTPUTS = ("odometry", "vision", "gps-input")
DEFAULT_RATES_HZ = {  # what the navigators consume (seed 002: IMU 50-100 Hz, attitude, baro, GPS until lost)
    mavlink.MAVLINK_MSG_ID_HIGHRES_IMU: 100.0, mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: 50.0,
    mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE: 10.0, mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR: 20.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0, mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 5.0,
}


@dataclass
class BridgeConfig:
    output: str = "odometry"
    frame_id: int = mavlink.MAV_FRAME_LOCAL_FRD
    origin: LocalTangentPlane | None = None  # else the autopilot's GPS_GLOBAL_ORIGIN or its first fix
    p0_hpa: float | None = None  # pressure at the origin's height; else from the first SCALED_PRESSURE and the GPS
    # height of the first fix (the first pressure itself when no fix comes within origin_wait_s: take-off)
    origin_wait_s: float = 2.0  # wait this long for the autopilot's GPS_GLOBAL_ORIGIN before taking a fix
    stall_s: float = 1.0
    stall_output_hz: float = 5.0
    stall_quality: int = 10
    jump_sigma: float = 5.0
    jump_min_m: float = 1.0  # and at least this far (navigators whose covariance is optimistic)
    rates_hz: dict = field(default_factory=lambda: dict(DEFAULT_RATES_HZ))
    status_period_s: float = 1.0
    frame_log: Path | None = None  # a folder: every frame as lossless PNG + frames.csv (index, t, capture_t)
    send_health: bool = False  # the navigator's Health as DEBUG_FLOAT_ARRAY "VN_HEALTH" with every estimate
    gps_sigma_m: float = mm.GPS_SIGMA_M  # 1-sigma of a position fix whose message carries no accuracy
    freshness: FreshnessConfig = field(default_factory=FreshnessConfig)  # input budgets (io/bridge_freshness.py)


class Bridge:
    def __init__(self, link: MavlinkLink, camera: FrameSource | None, navigator, cfg: BridgeConfig | None = None,
                 notify: Callable[[str], None] = print, on_status: Callable[[dict], None] | None = None,
                 on_sent: Callable[[float, NavEstimate, object], None] | None = None,
                 record: Callable | None = None):
        """``record(stream, t, **fields)``: where every estimate sent is logged (stream ``bridge_estimate``,
        t = the instant it describes in our clock); the CLI gives its ``navigator.h5`` log."""
        self.link, self.camera, self.nav = link, camera, navigator
        self.cfg = cfg or BridgeConfig()
        if self.cfg.output not in OUTPUTS:
            raise ValueError(f"output must be one of {', '.join(OUTPUTS)}, got {self.cfg.output!r}")
        self.notify, self.on_status, self.on_sent, self.record = notify, on_status, on_sent, record
        self.origin = self.cfg.origin
        self.p0_hpa = self.cfg.p0_hpa
        self.q: queue.Queue = queue.Queue(maxsize=10000)
        self.nav_lock = threading.RLock()  # held around every navigator call (a mission may call it too)
        self.stop = threading.Event()
        self.reset_counter = 0
        self.counts = Counter()  # measurements_in, unsynced, rejected, frames, frames_out_of_order, ...
        self.latency_ms: deque[float] = deque(maxlen=20000)
        self.arrival_ms: deque[float] = deque(maxlen=20000)  # frame arrival (capture_t) -> sent: the bridge's own part
        self.proc_ms: deque[float] = deque(maxlen=20000)
        self.sent_stamps: deque[tuple[float, int]] = deque(maxlen=20000)  # (our t, time_usec sent)
        self._prev: NavEstimate | None = None
        self._prev_reinit = 0
        self._last_gps = None
        self._first_baro: float | None = None
        self._ever_valid = False
        self._last_frame_t = -np.inf
        self._last_frame_arrival: float | None = None
        self._stalled = False
        self._stall_next = 0.0
        self._origin_sent = False
        self._autopilot_origin = False
        self._origin_req_next = 0.0
        self._t0 = time.monotonic()
        self._rate_mark = (self._t0, Counter(), 0)
        self.fresh = Freshness(self.cfg.freshness)
        self._last_sample_t: dict[type, float] = {}  # newest stamp per measurement type (out-of-order check)
        self._withheld: Assessment | None = None  # the assessment that stopped the output, while stopped
        self._withheld_at = 0.0
        self._withheld_reset = 0
        self.requests_applied = 0  # sequence number of the newest mission request applied
        self._reset_at_loss = 0  # reset_counter when the link was lost
        self._out_at_rx = 0  # estimates out while up, as of the last message received (link-up time ends there)
        link.on_link_up.append(self._on_link_up)
        link.on_link_lost.append(self._on_link_lost)
        link.request_intervals(self.cfg.rates_hz)

    # ------------------------------------------------------------------ threads
    def _reader(self) -> None:
        while not self.stop.is_set():
            self.link.tick()
            got = self.link.poll(0.005)
            if got:
                self._out_at_rx = self.counts["estimates_out_link_up"]
            for t_recv, msg in got:
                try:
                    m = self._decode(msg, t_recv)
                except Exception as e:  # noqa: BLE001 - a message we cannot decode is skipped, counted
                    self.counts["decode_errors"] += 1
                    if self.counts["decode_errors"] == 1:
                        self.notify(f"{msg.get_type()} could not be decoded ({e}); skipped")
                    continue
                if m is not None:
                    self.q.put(m)

    def _camera_reader(self) -> None:
        log = None
        if self.cfg.frame_log is not None:
            import cv2

            d = Path(self.cfg.frame_log)
            d.mkdir(parents=True, exist_ok=True)
            log = open(d / "frames.csv", "w")
            log.write("index,t,capture_t,file\n")
        try:
            while not self.stop.is_set():
                c = self.camera.read()
                if c is None:
                    self.notify("camera: end of stream")
                    return
                self.q.put(c)
                if log is not None:  # after handing the frame over: the log costs no latency
                    name = f"{c.index:06d}.png"
                    cv2.imwrite(str(Path(self.cfg.frame_log) / name), c.image)
                    log.write(f"{c.index},{c.t:.9f},{c.capture_t:.9f},{name}\n")
        finally:
            if log is not None:
                log.close()

    def _decode(self, msg, t_recv: float):
        typ, stamp = msg.get_type(), self.link.stamp
        if typ == "COMMAND_LONG" and msg.command == mm.NAV_COMMAND_ID:
            try:
                seq, cmd = mm.decode_nav_command(msg, t_recv)
            except mm.NoMavlinkMapping as e:
                self.notify(f"mission request refused: {e}")
                self._ack(msg, mavlink.MAV_RESULT_UNSUPPORTED)
                return None
            return NavRequest(seq, cmd, (msg.get_srcSystem(), msg.get_srcComponent()))
        if (typ == "COMMAND_LONG" and msg.command == mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
                and int(round(msg.param2)) == 2 and msg.target_component in (0, self.link.mav.srcComponent)):
            self._ack(msg, mavlink.MAV_RESULT_ACCEPTED)
            self.notify("shutdown of the onboard computer requested: the bridge ends its session")
            self.stop.set()  # MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param2 = 2 (shut down the companion computer)
            return None
        if typ == "GPS_GLOBAL_ORIGIN":
            self._autopilot_origin = True
            if self.origin is None:
                self.origin = LocalTangentPlane(msg.latitude * 1e-7, msg.longitude * 1e-7, msg.altitude / 1000.0)
                self.notify(f"NED origin from the autopilot: {self.origin}")
            return None
        if not self.link.sync.synced:
            self.counts["unsynced"] += 1  # a stamp we cannot map to our clock yet
            return None
        if typ in ("HIGHRES_IMU", "SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3"):
            m = mm.decode_imu(msg, stamp)
        elif typ in ("ATTITUDE", "ATTITUDE_QUATERNION"):
            m = mm.decode_attitude(msg, stamp)
        elif typ == "SCALED_PRESSURE":
            if self.p0_hpa is None:
                gps_streaming = self.link.counts_in["GLOBAL_POSITION_INT"] or self.link.counts_in["GPS_RAW_INT"]
                self._first_baro = t_recv if self._first_baro is None else self._first_baro
                if self._last_gps is None and (gps_streaming or t_recv - self._first_baro < self.cfg.origin_wait_s):
                    self.counts["baro_before_reference"] += 1  # wait for a fix to tie the baro to the origin
                    return None
                if self._last_gps is None:
                    self.notify(f"no position fix within {self.cfg.origin_wait_s:g} s of the first pressure: the "
                                "barometric height is referenced to the height of that moment (take-off)")
                h = 0.0 if self._last_gps is None else -float(self._last_gps.position[2])
                self.p0_hpa = mm.reference_pressure(float(msg.press_abs), h)
            m = mm.decode_baro(msg, stamp, self.p0_hpa)
        elif typ == "DISTANCE_SENSOR":
            m = mm.decode_range(msg, stamp)
        elif typ in ("GLOBAL_POSITION_INT", "GPS_RAW_INT"):
            if (self.origin is None and typ == "GLOBAL_POSITION_INT" and (msg.lat or msg.lon)
                    and time.monotonic() - self._t0 > self.cfg.origin_wait_s):  # the autopilot had its chance
                self.origin = LocalTangentPlane(msg.lat * 1e-7, msg.lon * 1e-7, msg.alt / 1000.0)
                self.notify(f"NED origin from the first position fix: {self.origin}")
            if self.origin is None:
                self.counts["gps_before_origin"] += 1
                return None
            if typ == "GLOBAL_POSITION_INT" and self.link.counts_in["GPS_RAW_INT"]:
                return None  # the receiver's own fix is streamed: never feed back the autopilot's fused one
            m = mm.decode_gps(msg, stamp, self.origin, t_recv, self.cfg.gps_sigma_m)
            self._last_gps = m if m is not None else self._last_gps
        else:
            return None
        if m is None:
            self.counts["rejected"] += 1
        else:
            self.counts["measurements_in"] += 1
        return m

    def _on_link_up(self) -> None:
        self.link.request_message(mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        if self.link.link_lost_count > 0 and self.reset_counter == self._reset_at_loss:  # not told yet (a resumption)
            self._bump("autopilot link back")
        self._origin_sent = False

    def _on_link_lost(self) -> None:
        self._reset_at_loss = self.reset_counter
        self.counts["estimates_out_link_up"] = self._out_at_rx  # sent after the last message: not link-up time

    # ------------------------------------------------------------------ main loop
    def run(self, duration_s: float | None = None, max_frames: int | None = None) -> dict:
        """Run until ``duration_s`` / ``max_frames`` / ``self.stop``; returns the metrics."""
        self.counts["stale_discarded"] += self.link.discard_pending()  # queued before we listened
        threads = [threading.Thread(target=self._reader, daemon=True, name="mavlink-reader")]
        if self.camera is not None:
            threads.append(threading.Thread(target=self._camera_reader, daemon=True, name="camera-reader"))
        for th in threads:
            th.start()
        t_end = None if duration_s is None else time.monotonic() + duration_s
        next_status = time.monotonic() + self.cfg.status_period_s
        try:
            while not self.stop.is_set():
                now = time.monotonic()
                if t_end is not None and now >= t_end:
                    break
                if max_frames is not None and self.counts["frames"] >= max_frames:
                    break
                try:
                    item = self.q.get(timeout=0.01)
                except queue.Empty:
                    item = None
                if item is not None:
                    self._consume(item)
                self._watch_camera(time.monotonic())
                self._maybe_send_origin()
                if time.monotonic() >= next_status:
                    next_status += self.cfg.status_period_s
                    if self.on_status:
                        self.on_status(self.status())
        finally:
            self.stop.set()
            for th in threads:
                th.join(timeout=1.0)
        return self.metrics()

    def _ack(self, msg, result: int) -> None:
        L = self.link
        L.send(L.mav.command_ack_encode(msg.command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()))

    def _apply_request(self, r: NavRequest) -> None:
        """A mission request: applied once (a retry with the same sequence number is acknowledged again),
        answered with COMMAND_ACK, and the navigator's health sent right after it."""
        L = self.link
        result = mavlink.MAV_RESULT_ACCEPTED
        if r.seq > self.requests_applied:
            try:
                with self.nav_lock:
                    self.nav.command(r.cmd)
                self.counts["requests_applied"] += 1
            except ValueError as e:  # the navigator does not know it
                result = mavlink.MAV_RESULT_DENIED
                self.notify(f"mission request {r.cmd.name} refused by the navigator: {e}")
            self.requests_applied = r.seq
        else:
            self.counts["requests_repeated"] += 1
        L.send(L.mav.command_ack_encode(mm.NAV_COMMAND_ID, result, 0, r.seq, *r.src))  # result_param2: the seq
        if self.cfg.send_health:
            t = time.monotonic()
            usec = L.peer_usec(t)
            if usec is not None and usec > 0:
                with self.nav_lock:
                    h = self.nav.health(t)
                L.send(mm.encode_health(L.mav, h, usec, self.requests_applied))

    def _consume(self, item) -> None:
        if isinstance(item, NavRequest):
            return self._apply_request(item)
        if not hasattr(item, "capture_t"):  # a MAVLink measurement
            # one key per sensor (a laser and a sonar stream the same message type, stamps may be equal)
            kind, t = (type(item), getattr(item, "sensor", None)), float(getattr(item, "t", np.nan))
            if t < self._last_sample_t.get(kind, -np.inf):  # late and overtaken: never integrate backwards
                self.counts["samples_out_of_order"] += 1
                if self.counts["samples_out_of_order"] in (1, 10, 100, 1000):
                    self.notify(f"{kind[0].__name__} out of order (t {t:.3f} s before {self._last_sample_t[kind]:.3f}"
                                f" s): dropped ({self.counts['samples_out_of_order']} so far)")
                return
            self._last_sample_t[kind] = t
            s = stream_of(item)
            if s is not None:
                self.fresh.seen(s, t)
            with self.nav_lock:
                self.nav.update(item)
            return
        now = time.monotonic()
        if self._stalled:
            self.notify(f"camera back after {now - self._last_frame_arrival:.1f} s")
            self._stalled = False
        self._last_frame_arrival = now
        if item.t <= self._last_frame_t:
            self.counts["frames_out_of_order"] += 1
            if self.counts["frames_out_of_order"] in (1, 10, 100):
                self.notify(f"frame {item.index} out of order (t {item.t:.3f} s not after {self._last_frame_t:.3f} s):"
                            f" dropped ({self.counts['frames_out_of_order']} so far)")
            return
        self._last_frame_t = item.t
        self.fresh.seen("camera", item.t)
        self.counts["frames"] += 1
        t0 = time.perf_counter()
        with self.nav_lock:
            self.nav.update(Frame(t=item.t, image=item.image, index=item.index))
            est = self.nav.estimate(item.t)
        self.proc_ms.append((time.perf_counter() - t0) * 1e3)
        if self._send(est, frame_index=item.index):  # capture (the instant the frame shows) -> ODOMETRY on the wire
            now = time.monotonic()
            self.latency_ms.append((now - item.t) * 1e3)
            self.arrival_ms.append((now - item.capture_t) * 1e3)

    def _watch_camera(self, now: float) -> None:
        if self.camera is None or self._last_frame_arrival is None:
            return
        if not self._stalled and now - self._last_frame_arrival > self.cfg.stall_s:
            self._stalled = True
            self.counts["camera_stalls"] += 1
            self.notify(f"camera stalled: no frame for {now - self._last_frame_arrival:.1f} s; sending the inertial "
                        f"estimate at {self.cfg.stall_output_hz:g} Hz with quality <= {self.cfg.stall_quality}")
        if self._stalled and now >= self._stall_next:
            self._stall_next = now + 1.0 / self.cfg.stall_output_hz
            with self.nav_lock:
                est = self.nav.estimate(now)
            self._send(est, stalled=True)

    def _maybe_send_origin(self) -> None:
        """SET_GPS_GLOBAL_ORIGIN once per link-up when the autopilot reported none within 2 s of it."""
        L = self.link
        now = time.monotonic()
        if self.origin is None and L.link_ok and now >= self._origin_req_next:  # ask again: UDP may lose it
            self._origin_req_next = now + 0.5
            L.request_message(mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        if (self._origin_sent or self._autopilot_origin or self.origin is None or not L.link_ok
                or time.monotonic() - self._t0 < 2.0):
            return
        L.send(mm.encode_origin(L.mav, self.origin, L.target_system, L.peer_usec(time.monotonic()) or 0))
        self._origin_sent = True
        self.notify("autopilot reported no GPS origin: SET_GPS_GLOBAL_ORIGIN sent")

    # ------------------------------------------------------------------ output
    def _bump(self, why: str) -> None:
        self.reset_counter += 1
        self.notify(f"reset_counter {self.reset_counter}: {why}")

    def _check_reset(self, est: NavEstimate, health) -> None:
        prev, self._prev = self._prev, est
        if prev is None and est.valid:
            self._ever_valid = True
        reinit = getattr(health, "reinitializations", 0) if health is not None else 0
        if reinit > self._prev_reinit:
            self._prev_reinit = reinit
            return self._bump("navigator reinitialised")
        if prev is None:
            return
        if est.source != prev.source:
            return self._bump(f"source {prev.source} -> {est.source}")
        if est.valid and not prev.valid:
            if self._ever_valid:
                return self._bump("estimate valid again")
            self._ever_valid = True  # the first valid estimate is the start, not a reset
            return
        dt = est.t - prev.t
        e = np.asarray(est.position) - (np.asarray(prev.position) + np.asarray(prev.velocity) * dt)
        S = np.asarray(est.covariance)[:3, :3] + np.asarray(prev.covariance)[:3, :3]
        if np.all(np.isfinite(e)) and np.all(np.isfinite(S)):
            try:
                d2 = float(e @ np.linalg.solve(S + 1e-9 * np.eye(3), e))
            except np.linalg.LinAlgError:
                return
            if d2 > self.cfg.jump_sigma**2 and float(np.linalg.norm(e)) > self.cfg.jump_min_m:
                self._bump(f"estimate jumped {np.linalg.norm(e):.2f} m ({np.sqrt(d2):.1f} sigma)")

    def _send(self, est: NavEstimate, stalled: bool = False, frame_index: int = -1) -> bool:
        L = self.link
        usec = L.peer_usec(est.t)
        if usec is None or usec <= 0:
            self.counts["unsynced_outputs"] += 1
            return False
        a = self.fresh.assess(est)
        if not self._fresh_enough(a):
            return False
        with self.nav_lock:
            health = self.nav.health(est.t)
        self._check_reset(est, health)
        est = a.estimate  # the covariance grown with the inputs' age (io/bridge_freshness.py, eq. 3)
        q = mm.quality_from(est, health)
        if stalled:
            q = min(q, self.cfg.stall_quality)
        out = self.cfg.output
        if out == "odometry":
            msgs = [mm.encode_odometry(L.mav, est, usec, self.reset_counter, q, frame_id=self.cfg.frame_id)]
        elif out == "vision":
            msgs = list(mm.encode_vision(L.mav, est, usec, self.reset_counter))
        else:
            if self.origin is None:
                self.counts["no_origin_outputs"] += 1
                return False
            unix = time.time() - (time.monotonic() - est.t)
            msgs = [mm.encode_gps_input(L.mav, est, self.origin, usec, unix, fix_type=self.fresh.fix_type(a))]
        if self.cfg.send_health:
            msgs.append(mm.encode_health(L.mav, health, usec, self.requests_applied, frame_index))
        for m in msgs:
            L.send(m)
            if self.on_sent:
                self.on_sent(est.t, est, m)
        self.sent_stamps.append((est.t, usec))
        if self.record is not None:
            self.record("bridge_estimate", est.t, position=np.asarray(est.position, float),
                        velocity=np.asarray(est.velocity, float), euler=np.asarray(est.attitude, float),
                        valid=bool(est.valid), time_usec=int(usec), quality=int(q), reset_counter=self.reset_counter,
                        sigma_h=_sigma_h(est), 
                        frame_index=int(frame_index))
        self.counts["estimates_out"] += 1
        if L.link_ok:
            self.counts["estimates_out_link_up"] += 1
        return True

    def _statustext(self, text: str, severity: int) -> None:
        L = self.link
        if L.target_system is not None:
            L.send(L.mav.statustext_encode(severity, text.encode()[:50]))

    def _fresh_enough(self, a: Assessment) -> bool:
        """False while a stream is past its timeout (told once when the output stops, once when it resumes)."""
        now = time.monotonic()
        if not a.send:
            self.counts["estimates_withheld"] += 1
            if self._withheld is None:
                self._withheld, self._withheld_at, self._withheld_reset = a, now, self.reset_counter
                self.counts["output_stops"] += 1
                b = self.cfg.freshness.budgets
                self.notify(f"estimates stopped: {a.reason()} (timeout "
                            f"{', '.join(f'{LABELS[k]} {b[k].timeout_s:g} s' for k in a.expired)}); "
                            "resuming when it is back")
                self._statustext(f"visnav: no estimate, {a.reason()}", mavlink.MAV_SEVERITY_WARNING)
            return False
        if self._withheld is not None:
            gone = ", ".join(LABELS[k] for k in self._withheld.expired)
            self.notify(f"estimates resumed: {gone} back after {now - self._withheld_at:.1f} s without an estimate")
            self._statustext(f"visnav: estimates resumed ({gone} back)", mavlink.MAV_SEVERITY_INFO)
            if self.reset_counter == self._withheld_reset:  # not already told by a link back
                self._bump("estimates resumed after a gap")
            self._prev = None  # no jump test across the gap: the reset says it
            self._withheld = None
        return True

    # ------------------------------------------------------------------ reporting
    def status(self) -> dict:
        now = time.monotonic()
        t_prev, c_prev, n_prev = self._rate_mark
        dt = max(now - t_prev, 1e-6)
        cin = Counter(self.link.counts_in)
        rates = {k: round((cin[k] - c_prev.get(k, 0)) / dt, 1) for k in cin}
        n_out = self.counts["estimates_out"]
        self._rate_mark = (now, cin, n_out)
        lat = np.array(self.latency_ms) if self.latency_ms else np.array([np.nan])
        with self.nav_lock:
            h = self.nav.health(now)
        return {"link_ok": self.link.link_ok, "rate_in_hz": rates, "rate_out_hz": round((n_out - n_prev) / dt, 1),
                "latency_ms_median": float(np.median(lat)), "latency_ms_p95": float(np.percentile(lat, 95)),
                "timesync_offset_ms": self.link.sync.offset_ms(), "timesync_rtt_ms": self.link.sync.rtt_ms(),
                "reset_counter": self.reset_counter, "source": getattr(h, "source", "?"),
                "frames": self.counts["frames"], "malformed": self.link.malformed, "stalled": self._stalled,
                "withheld": "" if self._withheld is None else self._withheld.reason()}

    def metrics(self) -> dict:
        """``rate_in_hz`` / ``rate_out_hz``: counts over the time the link was up (``MavlinkLink.up_s``),
        not over the session: a link down, or an autopilot not there yet, does not dilute them."""
        dt = max(self.link.up_s(), 1e-6)
        lat = np.array(self.latency_ms) if self.latency_ms else np.array([np.nan])
        proc = np.array(self.proc_ms) if self.proc_ms else np.array([np.nan])
        arr = np.array(self.arrival_ms) if self.arrival_ms else np.array([np.nan])
        return {
            "link_ok": self.link.link_ok,
            "rate_in_hz": {k: round(v / dt, 2) for k, v in sorted(self.link.counts_up.items())},
            "rate_out_hz": round(self.counts["estimates_out_link_up"] / dt, 2),
            "latency_capture_to_send_ms": {"median": float(np.median(lat)), "p95": float(np.percentile(lat, 95)),
                                           "n": len(self.latency_ms)},
            "processing_ms": {"median": float(np.median(proc)), "p95": float(np.percentile(proc, 95))},
            "latency_arrival_to_send_ms": {"median": float(np.median(arr)), "p95": float(np.percentile(arr, 95))},
            "timesync_offset_ms": self.link.sync.offset_ms(), "timesync_rtt_ms": self.link.sync.rtt_ms(),
            "reset_counter": self.reset_counter, "malformed_packets": self.link.malformed,
            "link_losses": self.link.link_lost_count, "link_up_s": round(self.link.up_s(), 3),
            "session_s": round(time.monotonic() - self._t0, 3), **{k: int(v) for k, v in sorted(self.counts.items())},
        }

    def write_metrics(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.metrics(), indent=2, default=float))


class BridgeRecording:
    """The bridge's log in the recorded-flight format (``io/recording.py``), replayable with ``visnav replay
    DIR --navigator NAME``: a ``app/record.RecordingNavigator`` around the navigator, so every sample,
    frame (lossless PNG, written on a background thread: no latency), mission request and estimate / health
    query is logged with one sequence number in the order the navigator got it; an estimate row carries the
    instant it was asked for (a frame's exposure, asked after later samples arrived: ``args`` ``t``). Times
    are the bridge's monotonic clock. ``camera.yaml`` is the navigator's camera (time offset 0: the frame
    stamps already include the camera.yaml offset), ``scenario.toml`` its resolved scenario."""

    def __init__(self, navigator, out_dir: str | Path, sc, camera, mount):
        self.sc, self.camera, self.mount = sc, camera, mount
        self._images: queue.Queue = queue.Queue()
        self._th = threading.Thread(target=self._write_images, daemon=True, name="recording-frames")
        self._th.start()
        self.writer = RecordingWriter(out_dir, image_writer=self._queue_image)

        class _Proxy(RecordingNavigator):
            def estimate(self, t: float):
                if self.recording:
                    self._writer.add_command(self._clock(), self._writer.next_seq(), "estimate", kwargs={"t": t})
                return self._inner.estimate(t)

            def health(self, t: float | None = None):
                if self.recording and t is not None:
                    self._writer.add_command(self._clock(), self._writer.next_seq(), "health", kwargs={"t": t})
                return self._inner.health(t)

        self.navigator = _Proxy(navigator, self.writer, time.monotonic)
        self.dir = Path(out_dir)

    def _queue_image(self, path: str, image) -> bool:
        self._images.put((path, image))
        return True

    def _write_images(self) -> None:
        import cv2

        while True:
            item = self._images.get()
            if item is None:
                return
            cv2.imwrite(item[0], item[1], [cv2.IMWRITE_PNG_COMPRESSION, 1])

    def close(self) -> Path:
        self.navigator.recording = False
        self._images.put(None)
        self._th.join()
        return self.writer.close(self.camera, self.mount, 0.0, None, to_toml(self.sc))


def _sigma_h(est: NavEstimate) -> float:
    P = np.asarray(est.covariance, float)
    return mm.horizontal_sigma(P) if np.all(np.isfinite(P[:2, :2])) else float("nan")


def status_line(s: dict) -> str:
    rin = " ".join(f"{k.split('_')[0][:4].lower()}:{v:g}" for k, v in sorted(s["rate_in_hz"].items()) if v)
    return (f"link {'OK ' if s['link_ok'] else 'LOST'} | in {rin or '-'} Hz | out {s['rate_out_hz']:g} Hz | "
            f"lat {s['latency_ms_median']:.1f}/{s['latency_ms_p95']:.1f} ms (med/p95) | "
            f"offset {s['timesync_offset_ms']:.3f} ms rtt {s['timesync_rtt_ms']:.2f} ms | {s['source']} | "
            f"reset {s['reset_counter']} | frames {s['frames']}{' STALLED' if s['stalled'] else ''}"
            f"{' | NO OUTPUT: ' + s['withheld'] if s.get('withheld') else ''}"
            f"{' | malformed ' + str(s['malformed']) if s['malformed'] else ''}")
