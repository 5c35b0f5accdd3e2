"""Differential GPS receiver: noisy position and velocity, latency, and jamming windows."""

from __future__ import annotations

import numpy as np

from visnav.measurements import GpsSample
from visnav.sensors.base import TruthAt


class Gps:
    def __init__(
        self,
        rng: np.random.Generator,
        rate_hz: float = 10.0,
        sigma_m: float = 0.02,
        velocity_sigma_mps: float = 0.02,
        latency_s: float = 0.05,
        jam_start_s: float | None = None,
        jam_end_s: float | None = None,
    ):
        self.rng = rng
        self.rate_hz = rate_hz
        self.sigma = sigma_m
        self.vsigma = velocity_sigma_mps
        self.latency_s = latency_s
        self.jam_start_s = jam_start_s
        self.jam_end_s = jam_end_s

    def jammed(self, t: float) -> bool:
        if self.jam_start_s is None or t < self.jam_start_s:
            return False
        return self.jam_end_s is None or t < self.jam_end_s

    def sample(self, t: float, truth_at: TruthAt, world=None) -> GpsSample | None:
        if self.jammed(t):
            return None
        s = truth_at(t)
        n = self.rng.standard_normal(6)
        sig = np.array([self.sigma, self.sigma, 1.5 * self.sigma])
        return GpsSample(
            t=t,
            position=s.position + sig * n[:3],
            velocity=s.velocity + self.vsigma * n[3:],
            sigma=self.sigma,
        )
