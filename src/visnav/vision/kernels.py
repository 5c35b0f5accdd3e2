"""One-point kernels of the CONDOR vision chain kept apart from the readable equations they reproduce (issue #31).

The chain (``distortion_lut.DistortionLUT.correct``, ``rectification.ground_range``) is written in numpy for
arrays of pixels; the navigator runs it on one pixel per frame, where numpy's per-call overhead is nearly all of
its cost. These evaluate the same equations on Python floats. They are not the model: a change is made in
``distortion_lut.py`` / ``rectification.py`` and then here; ``tests/vision/test_kernels.py`` holds them to the
readable path at 1e-12. ``vision.kernels.ENABLED = False`` sends one pixel down the readable path.
"""

from __future__ import annotations

import math
from bisect import bisect_right

#: one pixel through these kernels (False: the readable numpy path)
ENABLED = True


def bilinear1(gx: list, gy: list, tx: list, ty: list, a: float, b: float) -> tuple[float, float]:
    """``DistortionLUT._lookup`` of one point (a, b) on the grid ``gx`` x ``gy`` (lists) of both tables (nested
    lists): eq. 3.7's bilinear interpolation, the end cells extrapolated."""
    i = min(max(bisect_right(gx, a) - 1, 0), len(gx) - 2)
    j = min(max(bisect_right(gy, b) - 1, 0), len(gy) - 2)
    u, v = (a - gx[i]) / (gx[i + 1] - gx[i]), (b - gy[j]) / (gy[j + 1] - gy[j])
    return tuple(t[i][j] * (1 - u) * (1 - v) + t[i][j + 1] * (1 - u) * v + t[i + 1][j] * u * (1 - v)
                 + t[i + 1][j + 1] * u * v for t in (tx, ty))


def ground_range1(X: float, Y: float, h: float, tilt: float, roll: float, geom, method: str):
    """``rectification.ground_range`` (eq. 3.9-3.22) of one pixel: (D_T, L_T, D_X, D_Y), NaN where the ray does
    not meet the ground ahead."""
    c, s = math.cos(roll), math.sin(roll)
    Xr, Yr = (c * X + s * Y, -s * X + c * Y) if method == "exact" else ((c - s) * X, (s + c) * Y)  # eq. 3.9-3.10
    eta = math.pi / 2 + tilt  # eq. 3.12-3.18 (tilt_rectification)
    ni = h * math.tan(eta / 2.0)
    r = ni + h * (2.0 * Yr * math.tan(geom.half_vfov) / geom.height)
    se = math.sin(eta)
    den = h - r * se
    D_Y = ni + r + r * r * se / den if den > 0 and 0 <= eta < math.pi / 2 and h > 0 else math.nan
    L_Y = math.sqrt(D_Y * D_Y + h * h)
    if method == "exact":  # eq. 3.19-3.20 (pan_offset)
        D_X = L_Y * (Xr / geom.fx) / math.sqrt(1.0 + (Yr / geom.fy) ** 2)
    else:
        D_X = L_Y * math.tan(2.0 * geom.half_hfov * Xr / geom.width)
    D_T = math.sqrt(D_X * D_X + D_Y * D_Y)  # eq. 3.21-3.22
    return D_T, math.sqrt(D_T * D_T + h * h), D_X, D_Y
