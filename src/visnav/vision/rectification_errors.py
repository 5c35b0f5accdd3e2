"""Error analysis of the vision radius, seed 004 §3.4 eq. 3.25 (Figs. 3.7-3.21, 7.3).

``Delta D_T = sum_k Delta x_k dD_T/dx_k`` over x = (h_AGL, Theta_C, phi_C, X_TGT, Y_TGT). The partial
derivatives are exact: the chain eq. 3.9-3.22 is evaluated once on forward-mode dual numbers
(value + gradient in the five inputs), so no step size is involved; the tests hold them against
central finite differences and against the closed form dD_T/dh = D_T / h (D_T is linear in h).
"""

from __future__ import annotations

import math

import numpy as np

from visnav.vision.rectification import CameraGeometry

VARIABLES = ("h", "tilt", "roll", "X", "Y")
#: one unit of each measurement error, as in Figs. 3.7-3.21: +1 m, 1 deg, 1 deg, 1 px, 1 px
UNIT_ERRORS = (1.0, math.radians(1.0), math.radians(1.0), 1.0, 1.0)


class _Dual:
    """Value ``v`` (array) and gradient ``g`` (5, *v.shape)."""

    __slots__ = ("v", "g")

    def __init__(self, v, g):
        self.v, self.g = v, g

    @staticmethod
    def lift(x):
        return x if isinstance(x, _Dual) else _Dual(np.asarray(x, float), 0.0)

    def __add__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v + o.v, self.g + o.g)

    __radd__ = __add__

    def __neg__(self):
        return _Dual(-self.v, -self.g)

    def __sub__(self, o):
        return self + (-_Dual.lift(o))

    def __rsub__(self, o):
        return _Dual.lift(o) + (-self)

    def __mul__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v * o.v, self.g * o.v + o.g * self.v)

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v / o.v, (self.g * o.v - o.g * self.v) / (o.v * o.v))

    def __rtruediv__(self, o):
        return _Dual.lift(o) / self


def _fn(x, f, df):
    if isinstance(x, _Dual):
        return _Dual(f(x.v), x.g * df(x.v))
    return f(x)


def _sin(x):
    return _fn(x, np.sin, np.cos)


def _cos(x):
    return _fn(x, np.cos, lambda v: -np.sin(v))


def _tan(x):
    return _fn(x, np.tan, lambda v: 1.0 / np.cos(v) ** 2)


def _sqrt(x):
    return _fn(x, np.sqrt, lambda v: 0.5 / np.sqrt(v))


def radius_chain(X, Y, h, tilt, roll, geom: CameraGeometry, method: str = "exact"):
    """D_T of eq. 3.9-3.21 written on plain operators (floats, arrays or duals)."""
    c, s = _cos(roll), _sin(roll)
    if method == "exact":
        Xr, Yr = c * X + s * Y, -s * X + c * Y
    else:
        Xr, Yr = (c - s) * X, (s + c) * Y
    eta = tilt + math.pi / 2  # eq. 3.13
    ni = h * _tan(eta * 0.5)  # eq. 3.14
    r = ni + h * (Yr * (2.0 * math.tan(geom.half_vfov) / geom.height))  # eq. 3.12, 3.15
    se = _sin(eta)
    D_Y = ni + r + r * r * se / (h - r * se)  # eq. 3.16-3.17
    L_Y = _sqrt(D_Y * D_Y + h * h)  # eq. 3.18
    if method == "exact":
        D_X = L_Y * (Xr * (1.0 / geom.fx)) / _sqrt(1.0 + (Yr * (1.0 / geom.fy)) * (Yr * (1.0 / geom.fy)))
    else:
        D_X = L_Y * _tan(Xr * (2.0 * geom.half_hfov / geom.width))  # eq. 3.19-3.20
    return _sqrt(D_X * D_X + D_Y * D_Y)  # eq. 3.21


def radius_partials(X, Y, h, tilt, roll, geom: CameraGeometry, method: str = "exact"):
    """(D_T, gradient) with gradient[k] = dD_T/d(VARIABLES[k]) (per m, rad, rad, px, px)."""
    args = np.broadcast_arrays(*(np.asarray(a, float) for a in (h, tilt, roll, X, Y)))
    shape = args[0].shape
    duals = []
    for k, a in enumerate(args):
        g = np.zeros((5,) + shape)
        g[k] = 1.0
        duals.append(_Dual(a, g))
    dh, dt, dr, dX, dY = duals
    with np.errstate(divide="ignore", invalid="ignore"):
        out = radius_chain(dX, dY, dh, dt, dr, geom, method)
    bad = ~np.isfinite(out.v) | (np.pi / 2 + args[1] + np.arctan(args[4] / geom.fy) >= np.pi / 2)
    return np.where(bad, np.nan, out.v), np.where(bad, np.nan, out.g)


def error_maps(geom: CameraGeometry, h: float = 100.0, tilt_deg: float = -30.0, roll_deg: float = 0.0,
               step_px: int = 8, method: str = "exact") -> dict[str, np.ndarray]:
    """Eq. 3.25 over the image: radius error [m] for one unit of each error (Figs. 3.7-3.21) and
    their sum ('total'); NaN above the horizon. Keys: 'X_px', 'Y_px' (grids), 'D_T', VARIABLES, 'total'."""
    xs = np.arange(-geom.width / 2, geom.width / 2 + 1e-9, step_px)
    ys = np.arange(-geom.height / 2, geom.height / 2 + 1e-9, step_px)
    X, Y = np.meshgrid(xs, ys)
    D, g = radius_partials(X, Y, h, math.radians(tilt_deg), math.radians(roll_deg), geom, method)
    out = {"X_px": X, "Y_px": Y, "D_T": D}
    total = np.zeros_like(D)
    for k, (name, unit) in enumerate(zip(VARIABLES, UNIT_ERRORS)):
        out[name] = g[k] * unit
        total = total + out[name]
    out["total"] = total
    return out
