"""A small navigator with the visnav interface (update / estimate / health) for the bridge tests.

It follows the autopilot's GPS (GLOBAL_POSITION_INT): estimate(t) = the last fix at or before t
extrapolated with its velocity, attitude from the newest AttitudeSample. Enough to prove the bridge's
plumbing (stamps, frames, faults) without the vision pipelines; it records what it was given.
"""

from __future__ import annotations

import numpy as np

from visnav.measurements import AttitudeSample, Frame, GpsSample, Health, ImuSample, NavEstimate


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
