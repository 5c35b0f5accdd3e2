"""Figure-eight path over a ground target (seed 002 §7.5, Fig. 7.7) with L1 lateral guidance.

The path is the lemniscate of Gerono ``(x, y) = (a cos s, a sin s cos s)`` in a frame rotated by
``axis`` (the long axis, from north) and centred on the target: the two lobes cross over the target
at +-45 deg to the axis, so every pass of the crossing flies over it. Guidance: the L1 law of
Park, Deyst and How (AIAA GNC 2004): lateral acceleration ``a = 2 V^2 sin(eta) / L1`` towards the
point ``L1`` ahead along the path, turned into a heading-rate reference ``a / V`` for the
autopilot's eq. 5.4 bank reference (``control/fixedwing.py``). Progress along the path is searched
only ahead of the last point, so the crossing never sends the aircraft onto the other lobe.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["FigureEight"]


class FigureEight:
    def __init__(self, centre_ne, half_length_m: float, axis: float, l1_m: float = 30.0, n: int = 2000) -> None:
        if not half_length_m > 0 or not l1_m > 0:
            raise ValueError(f"half_length_m and l1_m must be positive, got {half_length_m}, {l1_m}")
        s = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        a = float(half_length_m)
        xy = np.stack([a * np.cos(s), a * np.sin(s) * np.cos(s)], -1)
        c, sn = math.cos(axis), math.sin(axis)
        R = np.array([[c, -sn], [sn, c]])
        self.points = np.asarray(centre_ne, float)[:2] + xy @ R.T  # (n, 2) north, east
        seg = np.linalg.norm(np.diff(np.vstack([self.points, self.points[:1]]), axis=0), axis=1)
        self.ds = float(seg.mean())
        self.length = float(seg.sum())
        self.l1 = float(l1_m)
        self.index: int | None = None

    def start_pose(self) -> tuple[np.ndarray, float]:
        """A point on the path (the tip of the first lobe) and the path direction there."""
        d = self.points[1] - self.points[0]
        return self.points[0].copy(), math.atan2(d[1], d[0])

    def cross_track(self, ne) -> float:
        return float(np.min(np.linalg.norm(self.points - np.asarray(ne, float)[:2], axis=1)))

    def heading_rate(self, ne, vel_ne) -> tuple[float, dict]:
        """Heading-rate reference [rad/s] from the GPS position and ground velocity."""
        p = np.asarray(ne, float)[:2]
        v = np.asarray(vel_ne, float)[:2]
        n = len(self.points)
        if self.index is None:
            self.index = int(np.argmin(np.linalg.norm(self.points - p, axis=1)))
        else:  # only ahead, within a quarter of the path
            ahead = (self.index + np.arange(0, n // 4)) % n
            self.index = int(ahead[int(np.argmin(np.linalg.norm(self.points[ahead] - p, axis=1)))])
        k = int(round(self.l1 / self.ds))
        target = self.points[(self.index + k) % n]
        los = target - p
        V = max(float(np.hypot(*v)), 1.0)
        eta = math.atan2(v[0] * los[1] - v[1] * los[0], v @ los)  # angle from velocity to the L1 point
        L = max(float(np.hypot(*los)), 1e-3)
        a_cmd = 2.0 * V * V * math.sin(eta) / L
        return a_cmd / V, {"eta": eta, "index": self.index, "cross_track": float(np.linalg.norm(self.points[self.index] - p))}
