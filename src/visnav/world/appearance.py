"""The ground seen on another day: what changes between a geo-referenced orthophoto and a flight's view.

A reference orthophoto and a MAV's frame of the same place differ in more than brightness. What stands
up from the ground (tree crowns, shrubs, their shadows) changes its look with the sun's azimuth and
elevation, wind, season, and with the viewing direction: a 15 m tree seen from 70 m AGL at 20 m from
nadir leans 15 x 20 / 70 = 4.3 m away from it, more than a crown's radius (parallax; the satellite
image was taken from another direction again). What lies flat on the ground (a road's edges, field
boundaries, tracks, shore lines) looks the same from anywhere and persists through seasons.

``appearance_change`` models this on the image alone (no surface model; every number below is an
assumption, derived where it can be):

* *relief* is where the fine texture (finer than ``scale_px``, Gaussian sigma: 2 m, a crown) is strong
  and unoriented: ``relief_weight`` w = (1 - c) e^2 / (e^2 + level^2), c the structure-tensor coherence
  ((l1 - l2) / (l1 + l2))^2 over ``2 scale_px`` (1 on a straight edge, near 0 on isotropic texture), e
  the local rms of the fine texture, ``level`` = 10 grey levels (2.5 x the video noise: weaker texture is
  taken as flat ground: grass, bare fields, water). On the real maps w is ~0.6 in forest, ~0.25 on the
  fields and along the roads.
* the relief moves (parallax, shadows): by a smooth random field of rms ``shift_px`` x w, 2.5 m: the rms
  parallax of a 15 m tree over the 28 m square a registration correlates at 70 m AGL (rms distance from
  nadir 11.4 m x 15 / 70), correlated over 7 m (Gaussian sigma of the filtered noise, so points 5 m apart
  move 1.2 m against each other, as the parallax's 5 x 15 / 70 = 1.1 m);
* the fine texture keeps 1 - (1 - ``keep``) w of its correlation with the reference, the rest replaced
  by a band of the same spectrum and the same local power but random phase (it still gives edges, that
  correspond to nothing in the reference); ``keep`` = 0.3: the parallax of a 15 m tree stays below a
  2 m crown radius only within 9.3 m of nadir (2 x 70 / 15), a third of the 28 m square (pi 9.3^2 /
  28^2 = 0.35); sun, wind and season decorrelate the rest further.

``relief_level`` None gives the uniform model of round 2 (every place keeps ``keep``, nothing moves).
``ANOTHER_DAY`` holds the defaults used by the geo-location mission and the registrability map.
"""

from __future__ import annotations

import cv2
import numpy as np
from visnav.world.maps import GeoImage

__all__ = ["ANOTHER_DAY", "another_day", "appearance_change", "coherence", "relief_weight"]

#: the appearance change between the reference and a flight (module docstring): metres and grey levels
ANOTHER_DAY = {"scale_m": 2.0, "keep": 0.3, "relief_level": 10.0, "shift_m": 2.5, "corr_m": 7.0}


def coherence(img: np.ndarray, sigma_px: float) -> np.ndarray:
    """Structure-tensor coherence ((l1 - l2) / (l1 + l2))^2 in [0, 1], averaged over ``sigma_px``
    (Gaussian); 0 where the image is flat."""
    f = cv2.GaussianBlur(np.asarray(img, np.float32), (0, 0), 1.0)
    gx = cv2.Sobel(f, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(f, cv2.CV_32F, 0, 1, ksize=3)
    jxx = cv2.GaussianBlur(gx * gx, (0, 0), sigma_px)
    jyy = cv2.GaussianBlur(gy * gy, (0, 0), sigma_px)
    jxy = cv2.GaussianBlur(gx * gy, (0, 0), sigma_px)
    tr = jxx + jyy
    diff = np.sqrt((jxx - jyy) ** 2 + 4.0 * jxy * jxy)
    return np.where(tr > 1e-3, (diff / np.maximum(tr, 1e-3)) ** 2, 0.0).clip(0.0, 1.0).astype(np.float32)


def relief_weight(img: np.ndarray, scale_px: float, level: float) -> np.ndarray:
    """How much each place looks like relief (crowns, shrubs and their shadows) rather than flat ground,
    in [0, 1]: unoriented (1 - coherence at ``2 scale_px``) and strong (``e^2 / (e^2 + level^2)``, e the
    local rms of the texture finer than ``scale_px``) fine texture."""
    f = np.asarray(img, np.float32)
    band = f - cv2.GaussianBlur(f, (0, 0), scale_px)
    e2 = cv2.GaussianBlur(band * band, (0, 0), 2.0 * scale_px)
    return ((1.0 - coherence(f, 2.0 * scale_px)) * e2 / (e2 + float(level) ** 2)).astype(np.float32)


def displace(img: np.ndarray, shift_px: float, corr_px: float, rng: np.random.Generator,
             weight: np.ndarray) -> np.ndarray:
    """``img`` resampled at x + weight(x) d(x): d a smooth random field (two Gaussian-filtered white noises
    of Gaussian sigma ``corr_px``) of rms magnitude ``shift_px``."""
    h, w = img.shape
    d = [cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), corr_px) for _ in range(2)]
    g = np.asarray(weight, np.float32) * (shift_px / (float(np.sqrt(np.mean(d[0] ** 2 + d[1] ** 2))) + 1e-12))
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    return cv2.remap(np.asarray(img, np.float32), xx + g * d[0], yy + g * d[1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REFLECT)


def appearance_change(img: np.ndarray, scale_px: float, rng: np.random.Generator, keep: float = 0.0,
                      relief_level: float | None = None, shift_px: float = 0.0,
                      shift_corr_px: float = 0.0) -> np.ndarray:
    """``img`` (uint8) as seen on another day (module docstring). ``scale_px`` <= 0: unchanged.
    ``relief_level`` None: the fine texture of every place keeps ``keep`` of its correlation (the uniform
    model); else only the relief (``relief_weight`` w) changes: the fine texture keeps 1 - (1 - keep) w,
    and with ``shift_px`` > 0 the relief first moves by a smooth random field of that rms times w
    (parallax and shadows), correlated over ``shift_corr_px``."""
    if scale_px <= 0:
        return img
    if not (0.0 <= keep <= 1.0):
        raise ValueError(f"keep must be in [0, 1], got {keep}")
    if relief_level is None and shift_px > 0:
        raise ValueError("shift_px needs relief_level (only the relief moves)")
    f = np.asarray(img, np.float32)
    w = relief_weight(f, scale_px, relief_level) if relief_level is not None else None
    if w is not None and shift_px > 0:
        f = displace(f, shift_px, max(shift_corr_px, 1.0), rng, w)
    low = cv2.GaussianBlur(f, (0, 0), scale_px)
    band = f - low
    power = np.sqrt(cv2.GaussianBlur(band * band, (0, 0), 2.0 * scale_px))
    F = np.fft.rfft2(band)
    phase = np.exp(2j * np.pi * rng.uniform(0.0, 1.0, F.shape))
    noise = np.fft.irfft2(np.abs(F) * phase, s=band.shape).astype(np.float32)
    noise /= np.sqrt(cv2.GaussianBlur(noise * noise, (0, 0), 2.0 * scale_px)) + 1e-6
    k = float(keep) if w is None else 1.0 - (1.0 - keep) * w
    return np.clip(low + k * band + np.sqrt(np.maximum(1.0 - k * k, 0.0)) * power * noise, 0, 255).astype(np.uint8)


def another_day(geo, rng: np.random.Generator, scale_m: float = ANOTHER_DAY["scale_m"],
                keep: float = ANOTHER_DAY["keep"], relief_level: float | None = ANOTHER_DAY["relief_level"],
                shift_m: float = ANOTHER_DAY["shift_m"], corr_m: float = ANOTHER_DAY["corr_m"]):
    """A GeoImage's ground on another day (same geo-reference); ``scale_m`` <= 0: ``geo`` itself."""
    if scale_m <= 0:
        return geo

    r = geo.resolution_m
    out = GeoImage(appearance_change(geo.image, scale_m / r, rng, keep, relief_level, shift_m / r, corr_m / r),
                   geo.north0, geo.east0, r, name=geo.name)
    out.origin_geodetic = geo.origin_geodetic
    return out
