"""3-D cubic Hermite path segments and multi-segment paths (seed 002 §4.3.1, eq. 4.1-4.5).

A segment is p(s) = A s³ + B s² + C s + D, s in [0, 1], fixed by its 12 boundary parameters
(start and end points p(0), p(1) and tangents ṗ(0), ṗ(1), eq. 4.2):

    p(s) = [s³ s² s 1] M [p(0); p(1); ṗ(0); ṗ(1)],   M = [[2, −2, 1, 1], [−3, 3, −2, −1],
                                                        [0, 0, 1, 0], [1, 0, 0, 0]]

Tangent t(s) = dp/ds (eq. 4.3), q(s) = d²p/ds² (eq. 4.4) and the curvature vector (eq. 4.5)
k(s) = (t × q) × t / |t|⁴, which points to the centre of curvature with |k| = 1/radius.

A path is a sequence of segments joined with continuous position and tangent *direction*: the
tangent magnitudes are the planner's two free parameters per segment (they shape the curvature).
Arc length is integrated with 16-point Gauss-Legendre quadrature, vectorized over s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import math

import numpy as np
from numpy.typing import ArrayLike

from visnav.guidance import kernels

#: eq. 4.2 Hermite basis: rows give the coefficients A, B, C, D of s³, s², s, 1
HERMITE_BASIS = np.array([[2.0, -2.0, 1.0, 1.0], [-3.0, 3.0, -2.0, -1.0], [0.0, 0.0, 1.0, 0.0],
                          [1.0, 0.0, 0.0, 0.0]])
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W  # nodes and weights on [0, 1]
_GL_XW = tuple(zip(_GL_X.tolist(), _GL_W.tolist()))  # (the kernel's floats)


def _vec(x: ArrayLike, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be 3 finite values [m], got {x!r}")
    return a


@dataclass(frozen=True)
class HermiteSegment:
    """One cubic segment from its 12 boundary parameters (eq. 4.2); NED metres.

    ``name`` is used in error messages (e.g. "segment 3"). A zero tangent, or a tangent that
    vanishes inside the segment (a cusp), raises ValueError: the control-point feedback divides
    by |dp/ds| (eq. 4.10).
    """

    p0: np.ndarray
    p1: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    name: str = "segment"
    coeffs: np.ndarray = field(init=False, repr=False)  # (4, 3): A, B, C, D
    _tangent_rows: tuple = field(init=False, repr=False, compare=False)  # (3A, 2B, C) as floats (the kernel's)

    def __post_init__(self) -> None:
        vals = {k: _vec(getattr(self, k), f"{self.name} {k}") for k in ("p0", "p1", "t0", "t1")}
        for k, v in vals.items():
            v.setflags(write=False)
            object.__setattr__(self, k, v)
        scale = max(float(np.linalg.norm(vals["p1"] - vals["p0"])), 1.0)
        for k, label in (("t0", "start"), ("t1", "end")):
            if np.linalg.norm(vals[k]) <= 1e-9 * scale:
                raise ValueError(f"{self.name}: {label} tangent {k} is zero ({vals[k].tolist()}): degenerate segment")
        G = np.stack([vals["p0"], vals["p1"], vals["t0"], vals["t1"]])
        c = HERMITE_BASIS @ G
        c.setflags(write=False)
        object.__setattr__(self, "coeffs", c)
        object.__setattr__(self, "_tangent_rows", tuple(map(tuple, (c[:3] * [[3.0], [2.0], [1.0]]).tolist())))
        s = np.linspace(0.0, 1.0, 257)
        t = self.tangent(s)
        speed = np.linalg.norm(t, axis=-1)
        turn = np.sum(t[:-1] * t[1:], axis=1)  # < 0: the tangent reverses between two samples
        if speed.min() <= 1e-6 * max(speed.max(), 1e-12) or np.any(turn < 0):
            k = int(np.argmin(speed)) if not np.any(turn < 0) else int(np.argmax(turn < 0))
            raise ValueError(f"{self.name}: the tangent vanishes near s = {s[k]:.3f} (cusp): degenerate segment")

    # -- eq. 4.2-4.5, vectorized over s --------------------------------------------------------
    def position(self, s: ArrayLike) -> np.ndarray:
        """p(s), shape (..., 3) (eq. 4.1-4.2)."""
        s = np.asarray(s, float)[..., None]
        A, B, C, D = self.coeffs
        return ((A * s + B) * s + C) * s + D

    def tangent(self, s: ArrayLike) -> np.ndarray:
        """t(s) = dp/ds, shape (..., 3) (eq. 4.3)."""
        s = np.asarray(s, float)[..., None]
        A, B, C, _ = self.coeffs
        return (3.0 * A * s + 2.0 * B) * s + C

    def second_derivative(self, s: ArrayLike) -> np.ndarray:
        """q(s) = d²p/ds², shape (..., 3) (eq. 4.4)."""
        s = np.asarray(s, float)[..., None]
        A, B, _, _ = self.coeffs
        return 6.0 * A * s + 2.0 * B

    def curvature(self, s: ArrayLike) -> np.ndarray:
        """Curvature vector k(s) = (t × q) × t / |t|⁴ (eq. 4.5) [1/m], towards the centre."""
        t, q = self.tangent(s), self.second_derivative(s)
        n2 = np.sum(t * t, axis=-1)[..., None]
        return np.cross(np.cross(t, q), t) / (n2 * n2)

    def frame_at(self, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p(s), t(s) and k(s) (eq. 4.2-4.5) at one scalar s: the guidance's per-step call."""
        s = float(s)
        # eq. 4.2-4.4: p, t, q = (s^3, s^2, s, 1), its first and its second derivative times (A, B, C, D)
        p, t, q = np.array([[s * s * s, s * s, s, 1.0], [3.0 * s * s, 2.0 * s, 1.0, 0.0], [6.0 * s, 2.0, 0.0, 0.0]]) \
            @ self.coeffs
        n2 = t @ t
        k = (q * n2 - t * (t @ q)) / (n2 * n2)  # eq. 4.5: (t × q) × t = q (t·t) − t (t·q)
        return p, t, k

    def arc_length(self, s: ArrayLike = 1.0, s0: ArrayLike = 0.0) -> np.ndarray | float:
        """Arc length from s0 to s [m]: the integral of |t(u)| (eq. 4.3) by 16-point Gauss-Legendre,
        vectorized over s."""
        if kernels.ENABLED and isinstance(s, float) and isinstance(s0, float):  # the guidance's per-step call
            return kernels.arc_length_1(self._tangent_rows, s, s0, _GL_XW)
        s, s0 = np.asarray(s, float), np.asarray(s0, float)
        h = s - s0
        u = s0[..., None] + h[..., None] * _GL_X  # (..., 16)
        t = self.tangent(u)
        speed = np.sqrt(np.sum(t * t, axis=-1))
        out = h * (speed @ _GL_W)
        return float(out) if out.ndim == 0 else out

    @property
    def length(self) -> float:
        """Whole-segment arc length [m] (on 4 sub-intervals: tight for strongly bent segments)."""
        edges = np.linspace(0.0, 1.0, 5)
        return float(np.sum(self.arc_length(edges[1:], edges[:-1])))


def arc_tangent_magnitude(chord: float, turn_angle: float) -> float:
    """Tangent magnitude that makes a Hermite segment approximate a circular arc.

    For an arc of angle θ and radius R the cubic with |ṗ(0)| = |ṗ(1)| = 4 R tan(θ/4) is the
    standard arc approximation; with the chord c = 2 R sin(θ/2) this is c / cos²(θ/4), which is
    the chord itself for a straight segment (θ = 0).
    """
    if not (np.isfinite(chord) and chord > 0):
        raise ValueError(f"chord must be > 0 m, got {chord}")
    if not 0 <= turn_angle < np.pi:
        raise ValueError(f"turn_angle must be in [0, pi) rad, got {turn_angle}")
    return float(chord / np.cos(turn_angle / 4.0) ** 2)


class HermitePath:
    """A sequence of Hermite segments with continuous position and tangent direction.

    ``tol_m``: largest gap allowed between a segment's end and the next one's start;
    ``max_kink_deg``: largest angle allowed between the tangents at a joint. A violation raises
    ValueError naming the segment. Positions along the path are (segment index, s) pairs.
    """

    def __init__(self, segments: list[HermiteSegment], tol_m: float = 1e-3, max_kink_deg: float = 1.0):
        if len(segments) == 0:
            raise ValueError("a path needs at least one segment, got 0")
        if not (tol_m >= 0 and max_kink_deg >= 0):
            raise ValueError(f"tol_m and max_kink_deg must be >= 0, got {tol_m}, {max_kink_deg}")
        for i in range(1, len(segments)):
            a, b = segments[i - 1], segments[i]
            gap = float(np.linalg.norm(b.p0 - a.p1))
            if gap > tol_m:
                raise ValueError(f"path segment {i} starts at {b.p0.tolist()} but segment {i - 1} ends at "
                                 f"{a.p1.tolist()}: gap {gap:.3f} m > {tol_m} m")
            c = float(np.dot(a.t1, b.t0) / (np.linalg.norm(a.t1) * np.linalg.norm(b.t0)))
            kink = float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
            if kink > max_kink_deg:
                raise ValueError(f"path segment {i} starts with a tangent {kink:.2f} deg off the end tangent of "
                                 f"segment {i - 1} (> {max_kink_deg} deg)")
        self.segments = list(segments)
        self.lengths = np.array([sg.length for sg in segments])
        self.starts = np.concatenate([[0.0], np.cumsum(self.lengths)[:-1]])  # arc length at each start

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def length(self) -> float:
        return float(self.lengths.sum())

    @property
    def start(self) -> np.ndarray:
        return self.segments[0].p0

    @property
    def end(self) -> np.ndarray:
        return self.segments[-1].p1

    def arc_position(self, index: int, s: float) -> float:
        """Arc length from the path start to (segment ``index``, s) [m]."""
        return float(self.starts[index] + self.segments[index].arc_length(s))

    def distance_to_segment_end(self, index: int, s: float) -> float:
        """Arc length still to fly on segment ``index`` from s [m] (the l_end of eq. 4.20)."""
        return float(self.lengths[index] - self.segments[index].arc_length(s))

    def distance_to_end(self, index: int, s: float) -> float:
        """Arc length still to fly to the end of the path [m]."""
        return float(self.distance_to_segment_end(index, s) + self.lengths[index + 1:].sum())

    def sample(self, n_per_segment: int = 200) -> dict[str, np.ndarray]:
        """Dense samples: ``index``, ``s``, ``l`` (arc length from the start), ``position``,
        ``tangent`` (dp/ds), ``curvature`` (vector, eq. 4.5); the joints appear once."""
        if n_per_segment < 2:
            raise ValueError(f"n_per_segment must be >= 2, got {n_per_segment}")
        out: dict[str, list] = {k: [] for k in ("index", "s", "l", "position", "tangent", "curvature")}
        for i, sg in enumerate(self.segments):
            s = np.linspace(0.0, 1.0, n_per_segment)[(1 if i else 0):]
            out["index"].append(np.full(s.shape, i))
            out["s"].append(s)
            out["l"].append(self.starts[i] + sg.arc_length(s))
            out["position"].append(sg.position(s))
            out["tangent"].append(sg.tangent(s))
            out["curvature"].append(sg.curvature(s))
        return {k: np.concatenate(v) for k, v in out.items()}

    def closest(self, points: ArrayLike, n_per_segment: int = 400) -> tuple[np.ndarray, np.ndarray]:
        """Distance [m] of each point (N, 3) to the path and the arc length of its closest point:
        nearest dense sample (k-d tree), then projection on the two polyline pieces beside it."""
        from scipy.spatial import cKDTree

        pts = np.atleast_2d(np.asarray(points, float))
        if pts.shape[-1] != 3:
            raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
        smp = self.sample(n_per_segment)
        P, L = smp["position"], smp["l"]
        _, k = cKDTree(P).query(pts)
        best_d = np.full(len(pts), np.inf)
        best_l = np.zeros(len(pts))
        for a in (k - 1, k):  # the polyline pieces [a, a+1] on either side of the nearest sample
            a = np.clip(a, 0, len(P) - 2)
            seg = P[a + 1] - P[a]
            u = np.clip(np.sum((pts - P[a]) * seg, axis=1) / np.maximum(np.sum(seg * seg, axis=1), 1e-18), 0, 1)
            d = np.linalg.norm(P[a] + u[:, None] * seg - pts, axis=1)
            better = d < best_d
            best_d = np.where(better, d, best_d)
            best_l = np.where(better, L[a] + u * (L[a + 1] - L[a]), best_l)
        return best_d, best_l

    @classmethod
    def from_segments(cls, params: ArrayLike, **kwargs) -> "HermitePath":
        """Path from the planner's 12 parameters per segment, rows (p0, p1, ṗ0, ṗ1) (eq. 4.2)."""
        A = np.asarray(params, float)
        if A.ndim != 2 or A.shape[1] != 12 or len(A) == 0:
            raise ValueError(f"segment parameters must have shape (N, 12), got {A.shape}")
        return cls([HermiteSegment(a[0:3], a[3:6], a[6:9], a[9:12], name=f"segment {i}") for i, a in enumerate(A)],
                   **kwargs)

    @classmethod
    def from_waypoints(cls, points: ArrayLike, tangents: ArrayLike, scale: str = "arc",
                       **kwargs) -> "HermitePath":
        """Path through ``points`` (N, 3) with the tangent *directions* ``tangents`` (N, 3) there.

        ``scale`` sets the two free tangent magnitudes of each segment: "arc" (default) makes a
        segment whose end tangents turn by θ approximate a circular arc (``arc_tangent_magnitude``),
        "chord" uses the chord length, "given" uses the tangent vectors as they are.
        """
        P = np.asarray(points, float)
        T = np.asarray(tangents, float)
        if P.ndim != 2 or P.shape[1] != 3 or len(P) < 2:
            raise ValueError(f"points must be at least 2 waypoints of 3 values, got shape {P.shape}")
        if T.shape != P.shape:
            raise ValueError(f"tangents must have the shape of points {P.shape}, got {T.shape}")
        if not (np.all(np.isfinite(P)) and np.all(np.isfinite(T))):
            raise ValueError("points and tangents must be finite")
        if scale not in ("arc", "chord", "given"):
            raise ValueError(f"scale must be 'arc', 'chord' or 'given', got {scale!r}")
        norms = np.linalg.norm(T, axis=1)
        for i in np.flatnonzero(norms <= 1e-12):
            raise ValueError(f"waypoint {i}: tangent is zero ({T[i].tolist()}): degenerate segment")
        U = T / norms[:, None]
        segs = []
        for i in range(len(P) - 1):
            chord = float(np.linalg.norm(P[i + 1] - P[i]))
            if chord <= 1e-9:
                raise ValueError(f"segment {i}: waypoints {i} and {i + 1} coincide ({P[i].tolist()})")
            if scale == "given":
                t0, t1 = T[i], T[i + 1]
            else:
                theta = float(np.arccos(np.clip(U[i] @ U[i + 1], -1.0, 1.0)))
                if theta >= np.pi - 1e-6:
                    raise ValueError(f"segment {i}: the tangents at waypoints {i} and {i + 1} are opposite")
                m = arc_tangent_magnitude(chord, theta) if scale == "arc" else chord
                t0, t1 = U[i] * m, U[i + 1] * m
            segs.append(HermiteSegment(P[i], P[i + 1], t0, t1, name=f"segment {i}"))
        return cls(segs, **kwargs)


def helix_waypoints(center: ArrayLike, radius: float, start_angle: float, turn: float, z0: float, z1: float,
                    n_segments: int) -> tuple[np.ndarray, np.ndarray]:
    """Waypoints and unit tangents of a helix around ``center`` (N, E): bearing from the centre
    ``start_angle`` [rad], turning ``turn`` [rad] (> 0 clockwise seen from above, i.e. right),
    from down-coordinate z0 to z1, cut into ``n_segments`` segments."""
    if not (radius > 0 and n_segments >= 1 and turn != 0):
        raise ValueError(f"need radius > 0, n_segments >= 1 and turn != 0; got {radius}, {n_segments}, {turn}")
    c = np.asarray(center, float)[:2]
    a = start_angle + np.linspace(0.0, turn, n_segments + 1)
    z = np.linspace(z0, z1, n_segments + 1)
    P = np.column_stack([c[0] + radius * np.cos(a), c[1] + radius * np.sin(a), z])
    sgn = np.sign(turn)
    arc = radius * abs(turn)
    dz = (z1 - z0) / arc  # down per metre along the horizontal arc
    T = np.column_stack([-sgn * np.sin(a), sgn * np.cos(a), np.full_like(a, dz)])
    return P, T / np.linalg.norm(T, axis=1, keepdims=True)
