"""Pinhole camera with the OpenCV rational distortion model (seed 003 eq. 5.1-5.7).

Camera frame: OpenCV (x right, y down, z along the optical axis). Pixel convention: OpenCV,
pixel centres at integer coordinates, so the image spans [-0.5, width - 0.5] x
[-0.5, height - 0.5] and the centre of a W x H image is ((W - 1) / 2, (H - 1) / 2).
Distortion coefficients follow OpenCV's order (k1, k2, p1, p2, k3, k4, k5, k6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "PinholeCamera",
    "BLUEFOX_DIST",
    "ray_plane_intersection",
    "ground_sample_distance",
]

#: Calibrated BlueFox wide-angle lens of seed 003 (eq. 5.6 k1..k6, eq. 5.7 p1, p2), OpenCV order.
BLUEFOX_DIST: tuple[float, ...] = (-0.188, -0.1631, 0.00136, 0.001605, 0.1631, 0.131, -0.366, 0.2436)

_UNDISTORT_ITERS = 30
_UNDISTORT_TOL = 1e-14  # normalized units
_UNDISTORT_FEW = 16  # up to this many points Newton's method runs on floats, point by point


def _points(x, dim: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim < 1 or a.shape[-1] != dim:
        raise ValueError(f"{name} must have shape (N, {dim}), got shape {a.shape}")
    return a


def _pair(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.stack([a, b], axis=-1)`` for two arrays of one shape, without np.stack's per-call overhead."""
    out = np.empty(np.shape(a) + (2,))
    out[..., 0] = a
    out[..., 1] = b
    return out


def _any(a) -> bool:
    """``np.any`` of an array, the truth of a number."""
    return bool(a.any()) if isinstance(a, np.ndarray) else bool(a)


@dataclass(frozen=True)
class PinholeCamera:
    """Intrinsics ``K`` = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] plus rational distortion ``dist``."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple = (0.0,) * 8

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not float(v).is_integer() or v <= 0:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
            object.__setattr__(self, name, int(v))
        for name in ("fx", "fy"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite focal length [px], got {v!r}")
            object.__setattr__(self, name, v)
        for name in ("cx", "cy"):
            v = float(getattr(self, name))
            if not np.isfinite(v):
                raise ValueError(f"{name} must be finite, got {v!r}")
            object.__setattr__(self, name, v)
        d = np.asarray(self.dist, dtype=float).ravel()
        if d.size != 8 or not np.all(np.isfinite(d)):
            raise ValueError(
                f"dist must hold 8 finite coefficients (k1, k2, p1, p2, k3, k4, k5, k6), got {self.dist!r}"
            )
        object.__setattr__(self, "dist", tuple(float(c) for c in d))
        object.__setattr__(self, "_distorted", any(c != 0.0 for c in self.dist))  # (has_distortion, once)

    @classmethod
    def ideal(cls, width: int = 640, height: int = 480, f: float = 1073.0) -> PinholeCamera:
        """Distortion-free camera with square pixels and the principal point at the image centre."""
        return cls(width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0)

    @property
    def K(self) -> np.ndarray:
        """3x3 intrinsic matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def has_distortion(self) -> bool:
        return self._distorted

    # --- distortion (seed 003 eq. 5.3-5.5) -----------------------------------------------

    def _radial(self, r2, derivative: bool = False):
        """Radial factor of eq. 5.3-5.4, ``g(r^2) = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)``,
        and with ``derivative`` also dg/d(r^2) (the Newton inversion's)."""
        k1, k2, _, _, k3, k4, k5, k6 = self.dist
        num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        if not derivative:
            return num / den
        dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
        return num / den, (dnum * den - num * dden) / (den * den)

    def distort_normalized(self, xy) -> np.ndarray:
        """Distorted normalized coordinates (x'', y'') of undistorted (x', y'), seed 003 eq. 5.3-5.5.

        Eq. 5.5 as extracted reads ``r = x'^2 + y'^2``; the polynomial is in the squared radius
        (``r^2 = x'^2 + y'^2``, as in OpenCV, which the thesis' ROS calibration uses).
        """
        xy = _points(xy, 2, "xy")
        if not self.has_distortion:
            return xy.copy()
        return _pair(*self._distort_xy(xy[..., 0], xy[..., 1]))

    def _distort_xy(self, x, y):
        """Eq. 5.3-5.5 on the coordinate arrays: radial factor g(r^2) and tangential terms (p1, p2)."""
        _, _, p1, p2, *_ = self.dist
        r2 = x * x + y * y
        g = self._radial(r2)
        xd = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        return xd, yd

    def _distortion_jacobian(self, x, y):
        """The Jacobian d(x'', y'') / d(x', y') = [[a, b], [b, d]] of eq. 5.3-5.5 (symmetric)."""
        _, _, p1, p2, *_ = self.dist
        g, dg = self._radial(x * x + y * y, derivative=True)
        a = g + 2.0 * x * x * dg + 2.0 * p1 * y + 6.0 * p2 * x
        b = 2.0 * x * y * dg + 2.0 * p1 * x + 2.0 * p2 * y
        d = g + 2.0 * y * y * dg + 6.0 * p1 * y + 2.0 * p2 * x
        return a, b, d

    def undistort_normalized(self, xy_distorted) -> np.ndarray:
        """Invert :meth:`distort_normalized` by Newton's method; NaN where it does not converge."""
        target = _points(xy_distorted, 2, "xy_distorted")
        if not self.has_distortion:
            return target.copy()
        if target.ndim == 2 and len(target) <= _UNDISTORT_FEW:  # the per-frame calls: on floats, point by point
            return np.array([self._newton_point(tx, ty) for tx, ty in target.tolist()]).reshape(target.shape)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # (diverging points: rejected)
            return _pair(*self._newton(target[..., 0], target[..., 1]))

    def _newton_point(self, tx: float, ty: float) -> tuple[float, float]:
        """``_newton`` of one point given as floats (a zero Jacobian: no convergence, NaN)."""
        try:
            return self._newton(tx, ty)
        except ZeroDivisionError:
            return math.nan, math.nan

    def _newton(self, tx, ty):
        """Newton's method on eq. 5.3-5.5 from (x', y') = (x'', y'') (floats or arrays): (x', y'), NaN where it
        has not converged or has converged beyond the fold of the lens model (det J <= 0)."""
        x, y = tx, ty
        for _ in range(_UNDISTORT_ITERS):
            xd, yd = self._distort_xy(x, y)
            rx, ry = tx - xd, ty - yd
            if not (_any(abs(rx) > _UNDISTORT_TOL) or _any(abs(ry) > _UNDISTORT_TOL)):
                break
            a, b, d = self._distortion_jacobian(x, y)
            det = a * d - b * b
            x, y = x + (d * rx - b * ry) / det, y + (a * ry - b * rx) / det
        xd, yd = self._distort_xy(x, y)
        a, b, d = self._distortion_jacobian(x, y)
        lim = 1e-9 / max(self.fx, self.fy)
        ok = (abs(tx - xd) < lim) & (abs(ty - yd) < lim) & (a * d - b * b > 0)
        if isinstance(ok, np.ndarray):
            return np.where(ok, x, np.nan), np.where(ok, y, np.nan)
        return (x, y) if ok else (math.nan, math.nan)  # (numbers stay numbers)

    # --- projection ------------------------------------------------------------------------

    def normalized_to_pixel(self, xy) -> np.ndarray:
        """Pixels (u, v) of undistorted normalized coordinates (x/z, y/z), applying distortion."""
        xy = _points(xy, 2, "xy")
        return self._to_pixel(xy[..., 0], xy[..., 1])

    def _to_pixel(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        if self.has_distortion:
            x, y = self._distort_xy(x, y)
        return _pair(self.fx * x + self.cx, self.fy * y + self.cy)

    def pixel_to_normalized(self, uv) -> np.ndarray:
        """Undistorted normalized coordinates (x/z, y/z) of pixels (u, v); inverse of the above."""
        uv = _points(uv, 2, "uv")
        xd = _pair((uv[..., 0] - self.cx) / self.fx, (uv[..., 1] - self.cy) / self.fy)
        return self.undistort_normalized(xd)

    def project(self, p_cam) -> np.ndarray:
        """Pixels (N, 2) of camera-frame points (N, 3), seed 003 eq. 5.1-5.5; NaN rows where z <= 0."""
        p = _points(p_cam, 3, "p_cam")
        z = p[..., 2]
        ok = z > 0
        zs = np.where(ok, z, 1.0)
        uv = self._to_pixel(p[..., 0] / zs, p[..., 1] / zs)
        return np.where(ok[..., None], uv, np.nan)

    def unproject(self, uv) -> np.ndarray:
        """Camera-frame rays (x, y, 1) (N, 3) through pixels (N, 2) (not unit length)."""
        xy = self.pixel_to_normalized(uv)
        return np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)

    def in_image(self, uv, margin: float = 0.0) -> np.ndarray:
        """Mask of pixels inside the image, at least ``margin`` px from its edges (NaN -> False)."""
        uv = _points(uv, 2, "uv")
        u, v = uv[..., 0], uv[..., 1]
        lo = -0.5 + margin
        return (
            (u >= lo)
            & (v >= lo)
            & (u <= self.width - 0.5 - margin)
            & (v <= self.height - 0.5 - margin)
        )


def ray_plane_intersection(origin, dirs, plane_point, plane_normal) -> tuple[np.ndarray, np.ndarray]:
    """Points ``origin + t * dirs`` on the plane, and ``t``; NaN where t <= 0 or the ray is parallel.

    ``origin`` (3,), ``dirs`` (N, 3), ``plane_point`` (3,), ``plane_normal`` (3,), any common frame.
    """
    o = _points(origin, 3, "origin")
    d = _points(dirs, 3, "dirs")
    p0 = _points(plane_point, 3, "plane_point")
    n = _points(plane_normal, 3, "plane_normal")
    if o.shape != (3,) or p0.shape != (3,) or n.shape != (3,):
        raise ValueError(
            f"origin, plane_point and plane_normal must have shape (3,), got {o.shape}, {p0.shape}, {n.shape}"
        )
    n_norm = np.linalg.norm(n)
    if not (np.isfinite(n_norm) and n_norm > 0):
        raise ValueError(f"plane_normal must be a finite non-zero vector, got {plane_normal}")
    n = n / n_norm
    denom = d @ n
    d_norm = np.linalg.norm(d, axis=-1)
    parallel = np.abs(denom) <= 1e-12 * d_norm
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(parallel, np.nan, ((p0 - o) @ n) / np.where(parallel, 1.0, denom))
    t = np.where(t > 0, t, np.nan)
    return o + t[..., None] * d, t


def ground_sample_distance(depth_m, f_px):
    """Ground sample distance [m/px] = depth / focal length, for a surface facing the camera."""
    f = np.asarray(f_px, dtype=float)
    depth = np.asarray(depth_m, dtype=float)
    if np.any(~(f > 0)) or np.any(~np.isfinite(f)):
        raise ValueError(f"f_px must be positive and finite, got {f_px}")
    if np.any(depth < 0):
        raise ValueError(f"depth_m must be >= 0, got {depth_m}")
    gsd = depth / f
    return gsd if gsd.ndim else float(gsd)
