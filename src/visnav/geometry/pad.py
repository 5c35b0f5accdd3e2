"""The landing pad of the WITAS vision landing (seed 002 ch. 6, Fig. 6.1; pattern of its ref. [43]).

Our own design (docs/pad.md): ``len(legs_m)`` nested *configurations*, each three dark rings on a
white board at the vertices of a right isosceles triangle whose circumcentre (the midpoint of the
hypotenuse) is the pad centre, i.e. the landing point and the origin of the pad frame. Pad frame
= the local NED frame translated to the pad centre (x north, y east, z down, the board at z = 0).

Configuration k, leg L, ring outer radius r = ``ring_ratio[k]`` L, inner radius ``inner_ratio[k]`` r:

    A = (-L/2, -L/2)   (the right angle)      B = (L/2, -L/2)      C = (-L/2, L/2)

The configurations are not similar to each other: neighbours differ in r/L and pairs in the inner
ratio, so that a triple of rings identifies its configuration (a similar copy would be a scale
ambiguity: config k from height h looks like config k+1 from h/2). Successive legs halve, which
nests each configuration inside the free disc of the one around it (its rings end at
L (1/sqrt(2) - r/L) from the centre; the next reaches L'(1/sqrt(2) + r'/L')), with a gap of at least
5 % of L so that blurred rings of neighbouring configurations never merge into one dark blob.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PadLayout", "RingConfig"]


@dataclass(frozen=True)
class RingConfig:
    """One three-ring configuration: centres (3, 2) NE [m] in the pad frame (A, B, C), radii [m]."""

    index: int
    leg_m: float
    centres: np.ndarray
    r_outer: float
    r_inner: float

    @property
    def extent_radius_m(self) -> float:
        """Radius of the disc about the pad centre that holds the whole configuration."""
        return self.leg_m / math.sqrt(2.0) + self.r_outer

    def line_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Pad-frame points used for the pose: the three centres, then for each ring i and each
        other ring j the points c_i -/+ rho u_ij on the line of centres (rho = outer, inner radius).
        Returns (points (27, 2), keys (27, 4) = (i, j, which radius 0/1/2 = centre/outer/inner, sign))."""
        pts, keys = [], []
        for i in range(3):
            pts.append(self.centres[i])
            keys.append((i, -1, 0, 0))
        for i in range(3):
            for j in range(3):
                if i == j:
                    continue
                u = self.centres[j] - self.centres[i]
                u = u / np.linalg.norm(u)
                for w, rho in ((1, self.r_outer), (2, self.r_inner)):
                    for sgn in (-1, 1):
                        pts.append(self.centres[i] + sgn * rho * u)
                        keys.append((i, j, w, sgn))
        return np.array(pts), np.array(keys)


@dataclass(frozen=True)
class PadLayout:
    """Nested configurations, largest first. Defaults: docs/pad.md (camera f = 640 px, 640x480)."""

    legs_m: tuple[float, ...] = (4.4, 2.2, 1.2, 0.58)
    ring_ratio: tuple[float, ...] = (0.20, 0.15, 0.20, 0.15)
    inner_ratio: tuple[float, ...] = (0.50, 0.50, 0.65, 0.65)
    board_margin_m: float = 0.25

    def __post_init__(self) -> None:
        n = len(self.legs_m)
        if n < 1 or len(self.ring_ratio) != n or len(self.inner_ratio) != n:
            raise ValueError("legs_m, ring_ratio and inner_ratio must have the same (>= 1) length")
        if any(not (0.05 <= r <= 0.3) for r in self.ring_ratio) or any(not (0.2 <= q <= 0.85)
                                                                        for q in self.inner_ratio):
            raise ValueError("ring_ratio must be in [0.05, 0.3] and inner_ratio in [0.2, 0.85]")
        cfgs = self.configurations()
        for a, b in zip(cfgs, cfgs[1:]):  # a gap of 5 % of the outer leg: blurred rings must not merge
            if b.extent_radius_m + 0.05 * a.leg_m > a.leg_m / math.sqrt(2.0) - a.r_outer:
                raise ValueError(f"configuration {b.index} (leg {b.leg_m} m) overlaps the rings of "
                                 f"configuration {a.index} (leg {a.leg_m} m) or lies within 5 % of its leg")

    def configurations(self) -> list[RingConfig]:
        out = []
        for k, (L, rr, qi) in enumerate(zip(self.legs_m, self.ring_ratio, self.inner_ratio)):
            h = 0.5 * L
            c = np.array([[-h, -h], [h, -h], [-h, h]], float)
            out.append(RingConfig(k, float(L), c, rr * L, qi * rr * L))
        return out

    @property
    def board_half_m(self) -> float:
        """Half side of the square white board carrying the rings."""
        return self.configurations()[0].extent_radius_m + self.board_margin_m
