"""Range and bearing to a target on flat ground from one gimbal camera (seed 004 ch. 2-3).

Conventions (seed 004 §3.2, Fig. 3.2): image coordinates ``X``, ``Y`` [px] are measured from the
image centre, ``X`` to the right and ``Y`` **up**; camera tilt ``Theta_C`` [rad] is negative below
the horizon (the tables of ch. 4 list -14 ... -48 deg); camera roll ``phi_C`` [rad] is right side down
positive, about the optical axis. ``theta_H``, ``theta_V`` are the HALF fields of view, so that
eq. 3.1 / 3.12 map the image edge ``S_x / 2`` to ``theta_H``.

Two pipelines:

* ``method="thesis"``: as printed in seed 004: the roll line of eq. 3.9-3.10 as extracted
  (``X' = (cos phi - sin phi) X``, ``Y' = (sin phi + cos phi) Y``), tilt rectification eq. 3.12-3.18,
  the pan angle linear in the pixel (eq. 3.20, written ``2 theta_H X / S_x`` so that it agrees with
  eq. 3.1 at the edge) and ``D_X = L_Y tan|theta_X|`` (eq. 3.19).
* ``method="exact"``: the roll as a proper 2-D rotation (what eq. 3.9-3.10 mean), the same tilt
  rectification (it is exact, see :func:`tilt_rectification`) and the pan offset of a pinhole ray,
  ``tan theta_X = (X / f_x) / sqrt(1 + (Y / f_y)^2)``, which is what eq. 3.19 approximates.

The tilt rectification of eq. 3.13-3.17 is Misulia's tilt-displacement construction (seed 004 ref.
[14]) on a photo scaled to focal length ``h_AGL``: with ``eta`` the angle of the optical axis from the
nadir, the isocentre lies ``h tan(eta/2)`` from the nadir point, the target ``r = n'i + h tan(theta_Y)``
from the isocentre, and the tilt displacement is ``d = r^2 sin(eta) / (h - r sin(eta))`` (eq. 3.16
multiplied through by ``sin eta``, which keeps it finite straight down). Its sum eq. 3.17 equals
``h tan(eta + theta_Y)`` exactly (checked in the tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from visnav.vision import kernels

__all__ = ["CameraGeometry", "RangeEstimate", "altimeter_correction", "roll_correct", "tilt_rectification",
           "ground_range", "estimate_range", "vision_bearing"]


@dataclass(frozen=True)
class CameraGeometry:
    """Resolution ``S_x`` x ``S_y`` [px] and HALF fields of view ``theta_H``, ``theta_V`` [rad]."""

    width: int
    height: int
    half_hfov: float
    half_vfov: float

    def __post_init__(self) -> None:
        if not (self.width > 0 and self.height > 0):
            raise ValueError(f"image size must be positive, got {self.width} x {self.height}")
        for name in ("half_hfov", "half_vfov"):
            v = getattr(self, name)
            if not (0.0 < v < math.pi / 2):
                raise ValueError(f"{name} must be in (0, pi/2) rad, got {v!r}")

    @classmethod
    def from_focal(cls, width: int, height: int, fx: float, fy: float) -> "CameraGeometry":
        return cls(width, height, math.atan(width / (2.0 * fx)), math.atan(height / (2.0 * fy)))

    @property
    def fx(self) -> float:
        """Focal length [px] implied by eq. 3.1: ``S_x / (2 tan theta_H)``."""
        return self.width / (2.0 * math.tan(self.half_hfov))

    @property
    def fy(self) -> float:
        return self.height / (2.0 * math.tan(self.half_vfov))


def altimeter_correction(h_bar, t_outside_c, c0: float = 0.004, c1: float = 0.00005):
    """Temperature-corrected barometric height AGL, seed 004 eq. 2.1:
    ``h = h_bar (1 - (c0 + (15 - t_O) c1) h_bar)`` with the printed c0 = 0.004, c1 = 0.00005 (which
    would take 40 % off at 100 m; the simulation's altimeter uses a tenth of both, docs/condor.md)."""
    if not (isinstance(h_bar, float) and isinstance(t_outside_c, (float, int))):  # (numbers stay numbers)
        h_bar, t_outside_c = np.asarray(h_bar, float), np.asarray(t_outside_c, float)
    h = h_bar * (1.0 - (c0 + (15.0 - t_outside_c) * c1) * h_bar)  # eq. 2.1
    return h if isinstance(h, float) or h.ndim else float(h)


def roll_correct(X, Y, roll, method: str = "exact"):
    """Image coordinates as a zero-roll camera would see them (eq. 3.9-3.10).

    ``exact``: a camera rolled right side down by ``phi`` sees a level-camera point (x, y) at
    ``R(phi) (x, y)`` (Y up), so the correction is the rotation by ``-phi``:
    ``X' = cos(phi) X + sin(phi) Y``, ``Y' = -sin(phi) X + cos(phi) Y``.
    ``thesis``: the garbled line as extracted, ``X' = (cos phi - sin phi) X``, ``Y' = (sin phi + cos phi) Y``.
    """
    c, s = np.cos(roll), np.sin(roll)
    if method == "exact":
        return c * X + s * Y, -s * X + c * Y
    if method == "thesis":
        return (c - s) * X, (s + c) * Y
    raise ValueError(f"method must be 'exact' or 'thesis', got {method!r}")


def tilt_rectification(Y, tilt, h, geom: CameraGeometry):
    """(D_Y, L_Y) of eq. 3.12-3.18 [m]; NaN where the ray does not meet the ground ahead.

    ``theta_Y = atan(2 Y tan(theta_V) / S_y)`` (3.12), ``eta = 90 deg + Theta_C`` (3.13, the optical
    axis' angle from the nadir; the print's ``90 - Theta_C`` takes the tilt as a positive depression),
    ``n'i = h tan(eta / 2)`` (3.14), ``r = n'i + h tan(theta_Y)`` (3.15),
    ``d = r^2 sin(eta) / (h - r sin(eta))`` (3.16), ``D_Y = n'i + r + d`` (3.17), ``L_Y = sqrt(D_Y^2 + h^2)`` (3.18).
    """
    eta = np.pi / 2 + np.asarray(tilt, float)
    tan_y = 2.0 * np.asarray(Y, float) * math.tan(geom.half_vfov) / geom.height
    ni = h * np.tan(eta / 2.0)
    r = ni + h * tan_y
    se = np.sin(eta)
    den = h - r * se
    with np.errstate(divide="ignore", invalid="ignore"):
        d = r * r * se / den
        D_Y = ni + r + d
    # the ray must point below the horizon: eta + theta_Y < 90 deg  <=>  den > 0 (and eta in [0, 90))
    ok = (den > 0) & (eta >= 0) & (eta < np.pi / 2) & (np.asarray(h) > 0)
    D_Y = np.where(ok, D_Y, np.nan)
    return D_Y, np.sqrt(D_Y * D_Y + h * h)


def pan_offset(X, Y, L_Y, geom: CameraGeometry, method: str = "exact"):
    """D_X of eq. 3.19 [m] (sign of X kept: positive to the right of the camera's heading).

    ``thesis``: ``theta_X = 2 theta_H X / S_x`` (eq. 3.20), ``D_X = L_Y tan(theta_X)``;
    ``exact``: ``tan theta_X = (X / f_x) / sqrt(1 + (Y / f_y)^2)`` (the angle of the pinhole ray out of
    the vertical plane through the optical axis), ``D_X = L_Y tan(theta_X)``.
    """
    if method == "thesis":
        return L_Y * np.tan(2.0 * geom.half_hfov * np.asarray(X, float) / geom.width)
    if method == "exact":
        return L_Y * (np.asarray(X, float) / geom.fx) / np.sqrt(1.0 + (np.asarray(Y, float) / geom.fy) ** 2)
    raise ValueError(f"method must be 'exact' or 'thesis', got {method!r}")


def ground_range(X, Y, h, tilt, roll, geom: CameraGeometry, method: str = "exact"):
    """Vectorised chain eq. 3.9-3.22: returns (D_T, L_T, D_X, D_Y) [m], NaN where there is no ground
    intersection (tilt at/above the horizon, ray above it, h <= 0)."""
    Xr, Yr = roll_correct(np.asarray(X, float), np.asarray(Y, float), roll, method)
    h = np.asarray(h, float)
    D_Y, L_Y = tilt_rectification(Yr, tilt, np.where(h > 0, h, np.nan), geom)
    D_X = pan_offset(Xr, Yr, L_Y, geom, method)
    D_T = np.sqrt(D_X * D_X + D_Y * D_Y)  # eq. 3.21
    L_T = np.sqrt(D_T * D_T + h * h)  # eq. 3.22
    return D_T, L_T, D_X, D_Y


def vision_bearing(D_X, D_Y, gimbal_yaw=0.0, sideslip=0.0):
    """Bearing of the target from the camera heading (eq. 3.23, ``atan2`` form) and the bearing
    from the right wing eq. 3.24: ``Psi_B = Psi_VB + Psi_G + beta``. Returns (Psi_VB, Psi_B) [rad]."""
    psi_vb = np.arctan2(D_X, D_Y)
    return psi_vb, psi_vb + gimbal_yaw + sideslip


@dataclass(frozen=True)
class RangeEstimate:
    """One vision radius; ``valid`` False with a ``reason`` instead of a NaN."""

    valid: bool
    ground_range: float = 0.0
    slant_range: float = 0.0
    bearing: float = 0.0  # Psi_VB, eq. 3.23
    reason: str = ""


def estimate_range(X: float, Y: float, h: float, tilt: float, roll: float, geom: CameraGeometry,
                   method: str = "exact") -> RangeEstimate:
    """Scalar front end for the controller: checks the inputs, never returns NaN."""
    vals = {"X": X, "Y": Y, "altitude": h, "tilt": tilt, "roll": roll}
    for k, v in vals.items():
        if v is None or not math.isfinite(float(v)):
            return RangeEstimate(False, reason=f"no estimate: {k} is not finite ({v!r})")
    if h <= 0:
        return RangeEstimate(False, reason=f"no estimate: altitude {h:.2f} m <= 0")
    if tilt >= 0:
        return RangeEstimate(False, reason=f"no estimate: tilt {math.degrees(tilt):.1f} deg at or above the horizon")
    if tilt < -math.pi / 2 - 1e-9:
        return RangeEstimate(False, reason=f"no estimate: tilt {math.degrees(tilt):.1f} deg beyond straight down")
    if abs(X) > geom.width / 2 or abs(Y) > geom.height / 2:
        return RangeEstimate(False, reason=f"no estimate: target ({X:.0f}, {Y:.0f}) px outside the image")
    if method not in ("exact", "thesis"):
        raise ValueError(f"method must be 'exact' or 'thesis', got {method!r}")
    chain = kernels.ground_range1 if kernels.ENABLED else ground_range  # (one pixel: floats, vision/kernels)
    D_T, L_T, D_X, D_Y = chain(float(X), float(Y), float(h), float(tilt), float(roll), geom, method)
    if not (math.isfinite(D_T) and math.isfinite(L_T)):
        return RangeEstimate(False, reason="no estimate: target ray at or above the horizon")
    return RangeEstimate(True, float(D_T), float(L_T), float(vision_bearing(D_X, D_Y)[0]))
