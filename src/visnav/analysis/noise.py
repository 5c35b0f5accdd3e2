"""MPE noise against range (seed 000 eq. 3.3, Figs. 3.4, 4.5-4.7).

The tracker reports integer pixels: the error of one coordinate is uniform over a pixel, so the
position error across the line of sight has σ = R/(f√12) (eq. 3.3). The laser adds its own noise
along the line of sight, σ_L(R) = (σ0 + k R)·surface factor (Fig. 3.4). Looking down at δ below
the horizon, the horizontal MPE error is, per axis,

* across track (image x):  σ_y = R/(f√12)                       (the laser does not enter),
* along track (image y):   σ_x = √((R sin δ/(f√12))² + (σ_L cos δ)²),

for the ``thesis`` range model (R is the depth along the axis: the pixel error is perpendicular to
the line of sight); with ``plane`` (the range fixes the height and the ray slides along the ground)
the along-track pixel share is R/(f√12)/sin δ instead (the laser's stays σ_L cos δ: the offset is
linear in R). ``closed_form`` takes every share from the estimator's own derivatives.
``mpe_error_series`` runs the real estimator open loop on quantised pixels and noisy ranges, so
the slope of its σ against R can be set beside 1/(f√12).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from visnav.estimation.mpe import MonocularPositionEstimator, quantisation_sigma
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount

__all__ = ["NoiseResult", "closed_form", "mpe_error_series", "noise_slope", "quantisation_sigma"]


@dataclass(frozen=True)
class NoiseResult:
    """σ of the MPE error per range: along track (x), across track (y), horizontal total."""

    range_m: np.ndarray
    sigma_along_m: np.ndarray
    sigma_across_m: np.ndarray

    @property
    def sigma_horizontal_m(self) -> np.ndarray:
        return np.hypot(self.sigma_along_m, self.sigma_across_m)


def _pose(height_m: float, depression_deg: float) -> np.ndarray:
    """Vehicle position (level, heading north, camera at the reference point) whose optical axis
    meets the ground at the origin."""
    return np.array([-height_m / math.tan(math.radians(depression_deg)), 0.0, -height_m])


def _laser_sigma(range_m: float, sigma0_m: float, sigma_per_m: float, factor: float) -> float:
    return (sigma0_m + sigma_per_m * range_m) * factor


def closed_form(range_m, focal_px: float, depression_deg: float = 60.0, sigma0_m: float = 0.01,
                sigma_per_m: float = 0.002, surface_factor: float = 1.5, model: str = "plane",
                mount: FixedMount | None = None, camera: PinholeCamera | None = None) -> NoiseResult:
    """σ per axis at each range: a pixel error of σ = 1/√12 px (eq. 3.3) in u and in v and the
    laser's σ_L (Fig. 3.4), each carried to the ground by the estimator's own derivatives (central
    differences at the image centre, level attitude), added in quadrature. Across track this is
    R/(f√12) exactly; along track the pixel share is R/(f√12)·sin δ for the ``thesis`` model
    (the error is perpendicular to the line of sight) and R/(f√12)/sin δ for ``plane`` (the
    height is held, the ray slides along the ground)."""
    cam = camera or PinholeCamera.ideal(640, 480, focal_px)
    mnt = mount or FixedMount.depressed(depression_deg)
    r = np.atleast_1d(np.asarray(range_m, float))
    if np.any(~np.isfinite(r)) or np.any(r <= 0):
        raise ValueError(f"ranges must be > 0 m, got {range_m}")
    along, across = np.empty_like(r), np.empty_like(r)
    uv = np.array([cam.cx, cam.cy])
    mpe = MonocularPositionEstimator(cam, mnt, model=model)
    C = np.eye(3)
    for i, R in enumerate(r):
        dR = 1e-3 * R
        dr = (mpe.camera_offset(uv, R + dR, C) - mpe.camera_offset(uv, R - dR, C)) / (2 * dR)
        du = (mpe.camera_offset(uv + [0.5, 0], R, C) - mpe.camera_offset(uv - [0.5, 0], R, C))
        dv = (mpe.camera_offset(uv + [0, 0.5], R, C) - mpe.camera_offset(uv - [0, 0.5], R, C))
        sl, sq = _laser_sigma(R, sigma0_m, sigma_per_m, surface_factor), 1.0 / math.sqrt(12.0)
        along[i] = math.sqrt((sq * du[0]) ** 2 + (sq * dv[0]) ** 2 + (sl * dr[0]) ** 2)
        across[i] = math.sqrt((sq * du[1]) ** 2 + (sq * dv[1]) ** 2 + (sl * dr[1]) ** 2)
    return NoiseResult(r, along, across)


def mpe_error_series(ranges, focal_px: float = 1073.0, depression_deg: float = 60.0, n: int = 2000,
                     sigma0_m: float = 0.01, sigma_per_m: float = 0.002, surface_factor: float = 1.5,
                     model: str = "plane", seed: int = 0) -> tuple[NoiseResult, list[np.ndarray]]:
    """Open-loop MPE at each slant range: the vehicle hovers level while its true position wanders
    (uniformly over a few pixels' worth of ground, so the sub-pixel phase of the tracked point is
    uniform); the tracker reports the projected pixel rounded to integers (Alg. 2 finds integer
    peaks) and the laser its range plus Gaussian noise of Fig. 3.4. Returns the σ of the error
    (estimate − truth, horizontal axes) per range and the error series themselves ((n, 3) each)."""
    rs = np.atleast_1d(np.asarray(ranges, float))
    if np.any(~np.isfinite(rs)) or np.any(rs <= 0):
        raise ValueError(f"ranges must be > 0 m, got {ranges}")
    if n < 10:
        raise ValueError(f"n must be >= 10, got {n}")
    rng = np.random.default_rng(seed)
    cam = PinholeCamera.ideal(640, 480, focal_px)
    mnt = FixedMount.depressed(depression_deg)
    d = math.radians(depression_deg)
    point = np.zeros((1, 3))
    along, across, series = [], [], []
    for R in rs:
        pos0, C = _pose(R * math.sin(d), depression_deg), np.eye(3)
        mpe = MonocularPositionEstimator(cam, mnt, model=model)
        cam_pos0, C_cn = mnt.camera_pose(pos0, C)
        r0 = -cam_pos0[2] / C_cn[2, 2]  # the range along the optical axis
        uv0 = cam.project(mnt.world_to_camera(point, pos0, C))[0]
        mpe.initialize(uv0, r0, C, pos0)  # exact initialisation: what follows is the noise only
        span = 3.0 * R / focal_px  # a few pixels of ground
        err = np.empty((n, 3))
        for k in range(n):
            p = pos0 + np.array([rng.uniform(-span, span), rng.uniform(-span, span), 0.0])
            uv = np.round(cam.project(mnt.world_to_camera(point, p, C))[0])
            cp, Cc = mnt.camera_pose(p, C)
            r = -cp[2] / Cc[2, 2] + _laser_sigma(R, sigma0_m, sigma_per_m, surface_factor) * rng.standard_normal()
            err[k] = mpe.estimate(0.0, uv, r, C).position - p
        series.append(err)
        along.append(float(np.std(err[:, 0])))
        across.append(float(np.std(err[:, 1])))
    return NoiseResult(rs, np.array(along), np.array(across)), series


def noise_slope(range_m, sigma_m) -> tuple[float, float]:
    """(slope, intercept) of the least-squares line σ = a + b·R (finite points only)."""
    r, s = np.asarray(range_m, float), np.asarray(sigma_m, float)
    ok = np.isfinite(r) & np.isfinite(s)
    if ok.sum() < 2 or np.ptp(r[ok]) <= 0:
        raise ValueError("need at least two distinct finite ranges to fit a slope")
    b, a = np.polyfit(r[ok], s[ok], 1)
    return float(b), float(a)
