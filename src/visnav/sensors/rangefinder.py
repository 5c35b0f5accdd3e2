"""Laser range finder along the camera axis (Sick PLS-300, seed 000 §3.1.4, §3.2) and sonar altimeter.

Both measure to the flat ground plane z = 0 of the world.
"""

from __future__ import annotations

import numpy as np

from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import RangeSample
from visnav.sensors.base import TruthAt

# Fig. 3.4: the range error grows with distance, more over rough surfaces than over concrete.
SURFACE_NOISE_FACTOR = {"concrete": 1.0, "asphalt": 1.5, "gravel": 1.5, "grass": 2.0}


def range_to_ground(origin_ned: np.ndarray, direction_ned: np.ndarray) -> float:
    """Distance along ``direction_ned`` (unit) from ``origin_ned`` to the plane z = 0; NaN if it misses."""
    dz = float(direction_ned[2])
    h = -float(origin_ned[2])
    if dz <= 1e-9 or h <= 0.0:
        return float("nan")
    return h / dz


class LaserRangeFinder:
    """Range along the camera's optical axis, with the PALACE failure modes.

    * sigma = (sigma0 + sigma_per_m * R) * surface factor (seed 000 Fig. 3.4);
    * no return below ``min_range_m`` (0.7 m) or beyond ``max_range_m`` (80 m);
    * each beam drops out with probability ``dropout``; the sensor then searches beams at
      1 deg steps up to +-``search_deg`` (3 deg) in the scan plane (the camera's vertical plane)
      and reports the first return with its ``beam_offset`` (§3.2);
    * ``delay_s``: unknown delay (stamped ``delay_s`` too late), ``latency_s`` known delay.
    """

    def __init__(
        self,
        rng: np.random.Generator,
        mount: FixedMount,
        surface: str = "asphalt",
        rate_hz: float = 10.0,
        sigma0_m: float = 0.01,
        sigma_per_m: float = 0.002,
        min_range_m: float = 0.7,
        max_range_m: float = 80.0,
        dropout: float = 0.02,
        search_deg: float = 3.0,
        latency_s: float = 0.0,
        delay_s: float = 0.0,
    ):
        self.rng = rng
        self.mount = mount
        self.factor = SURFACE_NOISE_FACTOR.get(surface, 1.0)
        self.rate_hz = rate_hz
        self.sigma0 = sigma0_m
        self.sigma_per_m = sigma_per_m
        self.min_range = min_range_m
        self.max_range = max_range_m
        self.dropout = dropout
        steps = [0.0]
        for k in range(1, int(np.floor(search_deg)) + 1):
            steps += [float(k), float(-k)]
        self.beam_offsets = np.deg2rad(steps)
        self.latency_s = latency_s
        self.delay_s = delay_s

    def sample(self, t: float, truth_at: TruthAt, world=None) -> RangeSample:
        s = truth_at(t - self.delay_s)
        cam_pos, C_cn = self.mount.camera_pose(s.position, euler_to_dcm(s.euler))
        for off in self.beam_offsets:
            if self.dropout > 0 and self.rng.random() < self.dropout:
                continue
            beam_c = np.array([0.0, np.sin(off), np.cos(off)])
            r = range_to_ground(cam_pos, C_cn @ beam_c)
            if not np.isfinite(r) or r < self.min_range or r > self.max_range:
                continue
            sigma = (self.sigma0 + self.sigma_per_m * r) * self.factor
            return RangeSample(t=t, range=r + sigma * self.rng.standard_normal(), sensor="laser", beam_offset=off)
        return RangeSample(t=t, range=float("nan"), sensor="laser")


class Sonar:
    """Downward sonar altimeter for the last metres (body z axis), valid up to ``max_range_m``."""

    def __init__(self, rng: np.random.Generator, rate_hz=20.0, sigma_m=0.01, max_range_m=5.0, latency_s=0.0):
        self.rng = rng
        self.rate_hz = rate_hz
        self.sigma = sigma_m
        self.max_range = max_range_m
        self.latency_s = latency_s

    def sample(self, t: float, truth_at: TruthAt, world=None) -> RangeSample:
        s = truth_at(t)
        C_bn = euler_to_dcm(s.euler)
        r = range_to_ground(s.position, C_bn[:, 2])
        if not np.isfinite(r) or r > self.max_range:
            return RangeSample(t=t, range=float("nan"), sensor="sonar")
        return RangeSample(t=t, range=max(0.0, r + self.sigma * self.rng.standard_normal()), sensor="sonar")
