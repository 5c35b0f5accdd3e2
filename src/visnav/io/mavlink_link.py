"""One MAVLink link to an autopilot, through pymavlink: connection, HEARTBEAT, link watch, TIMESYNC, intervals.

* ``udpin:HOST:PORT`` (listen), ``udpout:HOST:PORT`` (send first), ``tcp:HOST:PORT``, or a serial device
  (``/dev/ttyACM0``, ``/dev/ttyUSB0:921600``, ``COM3,57600``); a device that does not exist or a
  connection that fails raises ``MavlinkLinkError`` with one line that names it.
* We are an onboard component: HEARTBEAT type MAV_TYPE_ONBOARD_CONTROLLER, autopilot MAV_AUTOPILOT_INVALID,
  component MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY (197) by default, at 1 Hz. Our system id follows the
  autopilot's once its HEARTBEAT is seen (a companion computer shares the vehicle's system id).
* The autopilot's HEARTBEAT is watched: no HEARTBEAT for ``link_timeout_s`` is a link loss, the next one
  a link back (with how long it was gone); both are reported once through ``notify`` and counted.
  ``up_s()`` is the time the link was up: from a HEARTBEAT that brought it up to the last message received
  before it was lost (rates are measured over it, not over link-down time).
* TIMESYNC: requests at ``timesync_hz`` (tc1 = 0, ts1 = our monotonic ns); replies to our own requests go to
  ``estimation.clock_sync.ClockSync``; the autopilot's requests are answered.
* MAV_CMD_SET_MESSAGE_INTERVAL for the messages the navigator needs, (re)sent when the link comes up.
* BAD_DATA (bad CRC, truncated, unknown id) is counted and skipped, never fatal.
* Everything received and sent is written to a ``.tlog`` (UNIX-µs big-endian stamp + MAVLink frame, the
  format pymavlink, MAVProxy and Mission Planner read).
"""

from __future__ import annotations

import os
import re
import struct
import threading
import time
from collections import Counter, deque
from pathlib import Path
from typing import Callable

from visnav.estimation.clock_sync import ClockSync
from visnav.io.mavlink_messages import mavlink

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

mavutil.set_dialect("common")

NETWORK_PREFIXES = ("udpin:", "udpout:", "udp:", "tcp:", "tcpin:")


class MavlinkLinkError(RuntimeError):
    """A link that cannot be opened; the message is one line naming what is wrong."""


def open_connection(url: str, baud: int = 57600, source_system: int = 1,
                    source_component: int = mavlink.MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY):
    """A pymavlink connection for ``url`` (module docstring); MavlinkLinkError when it cannot be opened."""
    kw = dict(source_system=source_system, source_component=source_component, dialect="common",
              autoreconnect=True)
    if url.startswith(NETWORK_PREFIXES):
        try:
            return mavutil.mavlink_connection(url, **kw)
        except Exception as e:  # noqa: BLE001 - socket errors of every kind: one line
            raise MavlinkLinkError(f"cannot open MAVLink link {url!r}: {e}") from None
    m = re.fullmatch(r"(.+?)(?:[:,](\d+))?", url)
    dev, b = m.group(1), int(m.group(2)) if m.group(2) else int(baud)
    if not os.path.exists(dev):
        raise MavlinkLinkError(f"serial device {dev} does not exist (MAVLink URL {url!r}; use udpin:HOST:PORT, "
                               f"udpout:HOST:PORT, tcp:HOST:PORT or an existing serial device)")
    try:
        return mavutil.mavlink_connection(dev, baud=b, **kw)
    except Exception as e:  # noqa: BLE001
        raise MavlinkLinkError(f"cannot open serial device {dev} at {b} baud: {e}") from None


class Tlog:
    """Append-only .tlog writer (thread-safe)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._f = open(self.path, "wb")
        self._lock = threading.Lock()

    def write(self, msg) -> None:
        buf = msg.get_msgbuf()
        with self._lock:
            if not self._f.closed:
                self._f.write(struct.pack(">Q", int(time.time() * 1e6)) + bytes(buf))

    def close(self) -> None:
        with self._lock:
            self._f.close()


class MavlinkLink:
    def __init__(self, url: str, baud: int = 57600, system_id: int = 1,
                 component_id: int = mavlink.MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY,
                 clock_ns: Callable[[], int] = time.monotonic_ns, tlog: str | Path | None = None,
                 link_timeout_s: float = 1.5, heartbeat_hz: float = 1.0, timesync_hz: float = 10.0,
                 notify: Callable[[str], None] = print):
        self.url = url
        self.conn = open_connection(url, baud, system_id, component_id)
        self.mav = self.conn.mav
        self.mav.robust_parsing = True
        self.clock_ns = clock_ns
        self.notify = notify
        self.sync = ClockSync()
        self.tlog = Tlog(tlog) if tlog else None
        self.link_timeout_ns = int(link_timeout_s * 1e9)
        self.hb_period_ns = int(1e9 / heartbeat_hz)
        self.ts_period_ns = int(1e9 / timesync_hz)
        self.target_system: int | None = None
        self.target_component: int | None = None
        self.link_ok = False
        self.link_lost_count = 0
        self.malformed = 0
        self.counts_in: Counter[str] = Counter()
        self.counts_up: Counter[str] = Counter()  # received while the link was up (what rates are measured on)
        self.counts_out: Counter[str] = Counter()
        self.intervals: dict[int, float] = {}
        self._last_hb_rx: int | None = None
        self._lost_at: int | None = None
        self._up_since: int | None = None  # when the link came up (ns), while it is up
        self._up_ns = 0  # time up in earlier up periods
        self._last_rx: int | None = None
        self._next_hb = 0
        self._next_ts = 0
        self._pending_ts: deque[int] = deque(maxlen=64)
        self._send_lock = threading.Lock()
        self.on_link_up: list[Callable[[], None]] = []
        self.on_link_lost: list[Callable[[], None]] = []

    # ------------------------------------------------------------------ sending
    def send(self, msg) -> None:
        with self._send_lock:
            try:
                self.mav.send(msg)
            except OSError as e:  # e.g. udpout peer unreachable: the link watch reports it
                self.counts_out["send_error"] += 1
                if self.counts_out["send_error"] == 1:
                    self.notify(f"MAVLink send failed ({e}); still trying")
                return
        self.counts_out[msg.get_type()] += 1
        if self.tlog:
            self.tlog.write(msg)

    def heartbeat(self) -> None:
        self.send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID,
                                            0, 0, mavlink.MAV_STATE_ACTIVE))

    def request_intervals(self, rates_hz: dict[int, float]) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL (param1 message id, param2 interval µs) for each message."""
        self.intervals.update(rates_hz)
        if self.target_system is None:
            return  # sent when the autopilot is seen
        for msg_id, hz in self.intervals.items():
            self.send(self.mav.command_long_encode(self.target_system, self.target_component or 1,
                                                   mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, float(msg_id),
                                                   float(int(1e6 / hz)), 0, 0, 0, 0, 0))

    def request_message(self, msg_id: int) -> None:
        if self.target_system is not None:
            self.send(self.mav.command_long_encode(self.target_system, self.target_component or 1,
                                                   mavlink.MAV_CMD_REQUEST_MESSAGE, 0, float(msg_id),
                                                   0, 0, 0, 0, 0, 0))

    # ------------------------------------------------------------------ time
    def stamp(self, peer_ns: int) -> float:
        """Autopilot clock [ns] -> our clock [s]; NaN until TIMESYNC has converged."""
        return self.sync.to_ours(peer_ns) / 1e9 if self.sync.synced else float("nan")

    def peer_usec(self, t_ours_s: float) -> int | None:
        """Our instant [s] -> the autopilot's time since boot [µs]; None until TIMESYNC has converged."""
        return int(round(self.sync.to_peer(t_ours_s * 1e9) / 1000.0)) if self.sync.synced else None

    # ------------------------------------------------------------------ periodic work
    def tick(self) -> None:
        now = self.clock_ns()
        if now >= self._next_hb:
            self._next_hb = now + self.hb_period_ns
            self.heartbeat()
        if now >= self._next_ts:
            # fast until converged, then at the steady rate
            self._next_ts = now + (self.ts_period_ns if self.sync.synced else self.ts_period_ns // 4)
            tc1, ts1 = self.sync.request(now)
            self._pending_ts.append(ts1)
            self.send(self.mav.timesync_encode(tc1, ts1))
        if self.link_ok and self._last_hb_rx is not None and now - self._last_hb_rx > self.link_timeout_ns:
            self.link_ok = False
            self._lost_at = self._last_hb_rx
            if self._up_since is not None:  # up until the last message that came (messages follow the heartbeat)
                self._up_ns += max(0, (self._last_rx or self._last_hb_rx) - self._up_since)
                self._up_since = None
            self.link_lost_count += 1
            self.notify(f"autopilot link lost: no HEARTBEAT from {self.target_system}/{self.target_component} "
                        f"for {(now - self._last_hb_rx) / 1e9:.1f} s")
            for cb in self.on_link_lost:
                cb()

    # ------------------------------------------------------------------ receiving
    def discard_pending(self, max_n: int = 100000) -> int:
        """Drop what queued up in the socket before anyone read it (e.g. while a navigator was being built):
        stale samples, and a burst that would make the link-up rates wrong. Returns how many."""
        n = 0
        while n < max_n and self.conn.recv_match(blocking=False) is not None:
            n += 1
        return n

    def poll(self, timeout_s: float = 0.01) -> list:
        """Messages received within ``timeout_s`` as (t_recv_s, msg), HEARTBEAT/TIMESYNC/BAD_DATA handled here."""
        out = []
        msg = self.conn.recv_match(blocking=True, timeout=timeout_s)
        while msg is not None:
            t = self.clock_ns()
            if self._handle(msg, t):
                out.append((t / 1e9, msg))
            msg = self.conn.recv_match(blocking=False)
        return out

    def _handle(self, msg, now: int) -> bool:
        typ = msg.get_type()
        if typ == "BAD_DATA":
            self.malformed += 1
            if self.malformed == 1 or self.malformed % 100 == 0:
                reason = getattr(msg, "reason", "bad data")
                self.notify(f"malformed MAVLink packet skipped ({reason}); {self.malformed} so far")
            return False
        self.counts_in[typ] += 1
        if self.link_ok:
            self.counts_up[typ] += 1
        self._last_rx = now
        if self.tlog:
            self.tlog.write(msg)
        if typ == "HEARTBEAT":
            self._on_heartbeat(msg, now)
            return False
        if typ == "TIMESYNC":
            ans = self.sync.answer(msg.tc1, msg.ts1, now)
            if ans is not None:
                self.send(self.mav.timesync_encode(*ans))
            elif msg.ts1 in self._pending_ts:
                self.sync.on_reply(msg.tc1, msg.ts1, now)
            return False
        return True

    def _on_heartbeat(self, msg, now: int) -> None:
        if msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID or msg.type in (mavlink.MAV_TYPE_GCS,
                                                                         mavlink.MAV_TYPE_ONBOARD_CONTROLLER):
            return
        first = self.target_system is None
        self.target_system, self.target_component = msg.get_srcSystem(), msg.get_srcComponent()
        self.mav.srcSystem = self.target_system
        self._last_hb_rx = now
        if not self.link_ok:
            self.link_ok = True
            self._up_since = now
            if first:
                self.notify(f"autopilot {self.target_system}/{self.target_component} seen on {self.url}")
            else:
                self.notify(f"autopilot link back after {(now - self._lost_at) / 1e9:.1f} s (HEARTBEAT gap)")
            self.request_intervals({})
            for cb in self.on_link_up:
                cb()

    def up_s(self, now_ns: int | None = None) -> float:
        """Seconds the link has been up (see the module docstring)."""
        now = self.clock_ns() if now_ns is None else now_ns
        return (self._up_ns + (max(0, now - self._up_since) if self._up_since is not None else 0)) / 1e9

    def close(self) -> None:
        try:
            self.conn.close()
        finally:
            if self.tlog:
                self.tlog.close()
