"""A small navigator with the visnav interface (update / estimate / health) for the bridge tests.

It follows the autopilot's GPS (GLOBAL_POSITION_INT): estimate(t) = the last fix at or before t
extrapolated with its velocity, attitude from the newest AttitudeSample. Enough to prove the bridge's
plumbing (stamps, frames, faults) without the vision pipelines; it records what it was given.
"""

from __future__ import annotations

import numpy as np

import time

from tests.io.mavlink_helpers import free_udp_port
from visnav.io.camera_source import Captured, FrameSource
from visnav.io.mavlink_link import MavlinkLink
from visnav.measurements import AttitudeSample, Frame, GpsSample, Health, ImuSample, NavEstimate


def frame_image(i, t=None) -> np.ndarray:
    """A 64x48 frame whose grey level is the frame number (mod 256)."""
    return np.full((48, 64), i % 256, np.uint8)


class PacedFrames(FrameSource):
    """20 fps on the wall clock; no frame for ``stall_s`` after frame ``stall_after``; frame ``early`` (if given)
    stamped 0.2 s before its time (out of order)."""

    def __init__(self, stall_after: int = 30, stall_s: float = 2.0, early: int | None = None):
        super().__init__()
        self.next = time.monotonic()
        self.stall_after, self.stall_s, self.early = stall_after, stall_s, early

    def read(self):
        self.next += 0.05
        time.sleep(max(0.0, self.next - time.monotonic()))
        if self.index == self.stall_after:
            time.sleep(self.stall_s)
            self.next = time.monotonic()
        c = self._stamp(frame_image(self.index))
        if c.index == self.early:
            c = Captured(c.image, c.t - 0.2, c.capture_t, c.index)
        return c


class SyncedClock:
    """A link clock already synchronised with its peer (1000 s apart)."""

    synced = True

    def to_peer(self, t_ns):
        return t_ns + 1e12

    def to_ours(self, peer_ns):
        return peer_ns - 1e12

    def offset_ms(self):
        return 1e6

    def rtt_ms(self):
        return 0.5


def offline_link() -> tuple[MavlinkLink, list]:
    """A MAVLink link whose sends are kept in a list instead of going out (target 1/1, clock synchronised)."""
    link = MavlinkLink(f"udpout:127.0.0.1:{free_udp_port()}", notify=lambda m: None)
    sent: list = []
    link.send = sent.append
    link.sync = SyncedClock()
    link.target_system, link.target_component = 1, 1
    return link, sent


class GpsFollowNavigator:
    def __init__(self, jump_after_frame: int | None = None, jump_m: float = 10.0):
        self.gps: list[GpsSample] = []
        self.imu_t: list[float] = []
        self.frames: list[Frame] = []
        self.att = np.zeros(3)
        self.others = 0
        self.jump_after_frame, self.jump_m = jump_after_frame, jump_m

    def update(self, m) -> None:
        if isinstance(m, GpsSample):
            self.gps.append(m)
        elif isinstance(m, ImuSample):
            self.imu_t.append(m.t)
        elif isinstance(m, AttitudeSample):
            self.att = np.asarray(m.euler)
        elif isinstance(m, Frame):
            self.frames.append(m)
        else:
            self.others += 1

    def estimate(self, t: float) -> NavEstimate:
        if not self.gps:
            return NavEstimate(t=t, position=np.zeros(3), velocity=np.zeros(3), attitude=self.att, valid=False)
        ts = [g.t for g in self.gps[-20:]]
        i = int(np.searchsorted(ts, t, side="right")) - 1
        g = self.gps[-20:][max(i, 0)]
        p = g.position + g.velocity * (t - g.t)
        if self.jump_after_frame is not None and len(self.frames) > self.jump_after_frame:
            p = p + np.array([self.jump_m, 0.0, 0.0])
        return NavEstimate(t=t, position=p, velocity=g.velocity, attitude=self.att,
                           covariance=np.diag([0.25, 0.25, 1.0, 0.04, 0.04, 0.09]), valid=True, source="gps")

    def health(self, t: float | None = None) -> Health:
        return Health(source="gps", tracking=True)
