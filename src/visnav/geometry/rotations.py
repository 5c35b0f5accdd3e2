"""Attitude: ZYX Euler angles, direction cosine matrices and angular rates (the one rotation module).

Convention (seed 002 §3.4): Euler angles are (roll φ, pitch θ, yaw ψ) in radians and
``C_b^n = Rz(ψ) Ry(θ) Rx(φ)`` maps body FRD vectors to NED (seed 002 eq. 3.1-3.2);
``C_n^b = (C_b^n)^T`` (eq. 3.3). Every function accepts a leading batch axis (``...``).

Each equation is written once, as a function of its entries (numbers or arrays alike): the one-vector
functions (``euler_to_dcm3``, ``cross3``) feed it numbers, the batch functions numpy arrays.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.kernels import dcm_to_euler3

__all__ = [
    "euler_to_dcm",
    "euler_to_dcm3",
    "euler_rate_matrix",
    "euler_to_dcm_and_rate_matrix",
    "cross",
    "dcm_to_euler",
    "body_rates_to_euler_rates",
    "euler_rates_to_body_rates",
    "skew",
    "cross3",
    "wrap_angle",
    "kabsch",
    "matrix3",
]

_GIMBAL_EPS = 1e-12
#: one matrix through ``geometry/kernels`` (the same formulas on floats, held to the batch path by the tests)
KERNELS = True


def _vec3(x, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {a.shape}")
    return a


def matrix3(rows) -> np.ndarray:
    """A (..., 3, 3) array of nine entries given row by row: numbers, or arrays of one batch shape."""
    shape = next((np.shape(x) for row in rows for x in row if np.ndim(x)), ())
    if not shape:
        return np.array(rows, dtype=float)
    out = np.empty(shape + (3, 3))
    for i, row in enumerate(rows):
        for j, x in enumerate(row):
            out[..., i, j] = x
    return out


def wrap_angle(a):
    """Wrap angle(s) in radians to the interval (-pi, pi] (a float stays a float: one number without numpy)."""
    a = float(a) if isinstance(a, float) else np.asarray(a, dtype=float)
    w = math.pi - (math.pi - a) % (2.0 * math.pi)
    w = w + 2.0 * math.pi * (w <= -math.pi)
    return w if isinstance(w, float) or w.ndim else float(w)


# ---------------------------------------------------------------- cross products
def _skew_rows(x, y, z):
    """[v x] with [v x] u = v x u."""
    return [[0.0, -z, y],
            [z, 0.0, -x],
            [-y, x, 0.0]]


def _cross(a0, a1, a2, b0, b1, b2):
    """a x b = [a x] b, component by component."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


def skew(v) -> np.ndarray:
    """Cross-product matrix: ``skew(v) @ u == np.cross(v, u)``; shape (..., 3, 3)."""
    v = _vec3(v, "v")
    if v.shape == (3,):
        return np.array(_skew_rows(*v.tolist()))
    return matrix3(_skew_rows(v[..., 0], v[..., 1], v[..., 2]))


def cross3(a, b) -> np.ndarray:
    """``a x b`` of two 3-vectors (arrays, tuples or lists) without ``np.cross``'s per-call set-up."""
    a0, a1, a2 = (a.tolist() if isinstance(a, np.ndarray) else a)
    b0, b1, b2 = (b.tolist() if isinstance(b, np.ndarray) else b)
    return np.array(_cross(a0, a1, a2, b0, b1, b2), dtype=float)


def cross(a, b) -> np.ndarray:
    """``a x b`` along the last axis, with broadcasting."""
    c = _cross(a[..., 0], a[..., 1], a[..., 2], b[..., 0], b[..., 1], b[..., 2])
    return np.stack(np.broadcast_arrays(*c), axis=-1)


# ---------------------------------------------------------------- Euler angles <-> DCM
def _dcm_rows(cf, sf, ct, st, cp, sp):
    """Seed 002 eq. 3.2, C_b^n = Rz(ψ) Ry(θ) Rx(φ), from cos / sin of (φ, θ, ψ)."""
    return ((ct * cp, -cf * sp + sf * st * cp, sf * sp + cf * st * cp),
            (ct * sp, cf * cp + sf * st * sp, -sf * cp + cf * st * sp),
            (-st, sf * ct, cf * ct))


def _rate_rows(cf, sf, ct, tt):
    """Seed 002 eq. 3.7, E(e) with (φ', θ', ψ') = E (p, q, r), from cos / sin of φ and cos / tan of θ."""
    return [[1.0, sf * tt, cf * tt],
            [0.0, cf, -sf],
            [0.0, sf / ct, cf / ct]]


def _inverse_rate_rows(cf, sf, ct, st):
    """E(e)^-1 (the inverse of seed 002 eq. 3.7): (p, q, r) = E^-1 (φ', θ', ψ')."""
    return [[1.0, 0.0, -st],
            [0.0, cf, sf * ct],
            [0.0, -sf, cf * ct]]


def _check_finite_euler(e: np.ndarray) -> None:
    if not np.all(np.isfinite(e)):
        raise ValueError(f"euler must be finite, got {e}")


def euler_to_dcm3(phi: float, theta: float, psi: float) -> np.ndarray:
    """``euler_to_dcm`` of one (roll, pitch, yaw) given as three floats."""
    if not (math.isfinite(phi) and math.isfinite(theta) and math.isfinite(psi)):
        raise ValueError(f"euler must be finite, got {np.array([phi, theta, psi])}")
    return np.array(_dcm_rows(math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta),
                              math.cos(psi), math.sin(psi)))


def euler_to_dcm(euler) -> np.ndarray:
    """``C_b^n`` (body -> NED) from (roll, pitch, yaw) [rad], seed 002 eq. 3.2; shape (..., 3, 3)."""
    e = _vec3(euler, "euler")
    if e.shape == (3,):
        return euler_to_dcm3(*e.tolist())
    _check_finite_euler(e)
    c, s = np.cos(e), np.sin(e)
    return matrix3(_dcm_rows(c[..., 0], s[..., 0], c[..., 1], s[..., 1], c[..., 2], s[..., 2]))


def euler_rate_matrix(euler) -> np.ndarray:
    """E(e) with (phi_dot, theta_dot, psi_dot) = E(e) (p, q, r), seed 002 eq. 3.7 (seed 003 eq. 2.13); (..., 3, 3).

        E = [[1, sin(phi) tan(theta), cos(phi) tan(theta)],
             [0, cos(phi),            -sin(phi)          ],
             [0, sin(phi)/cos(theta), cos(phi)/cos(theta)]]
    """
    e = _vec3(euler, "euler")
    if e.shape == (3,):
        phi, theta, _ = e.tolist()
        return np.array(_rate_rows(math.cos(phi), math.sin(phi), math.cos(theta), math.tan(theta)))
    phi, theta = e[..., 0], e[..., 1]
    return matrix3(_rate_rows(np.cos(phi), np.sin(phi), np.cos(theta), np.tan(theta)))


def euler_to_dcm_and_rate_matrix(euler) -> tuple[np.ndarray, np.ndarray]:
    """``(euler_to_dcm(e), euler_rate_matrix(e))`` of a batch (..., 3) from one cos / sin of the angles."""
    e = _vec3(euler, "euler")
    c, s = np.cos(e), np.sin(e)
    cf, sf, ct, st = c[..., 0], s[..., 0], c[..., 1], s[..., 1]
    return (matrix3(_dcm_rows(cf, sf, ct, st, c[..., 2], s[..., 2])),
            matrix3(_rate_rows(cf, sf, ct, st / ct)))


def dcm_to_euler(C) -> np.ndarray:
    """(roll, pitch, yaw) [rad] from ``C_b^n``, inverse of seed 002 eq. 3.2; yaw in (-pi, pi].

    Pitch is in [-pi/2, pi/2]; at gimbal lock (pitch = +-pi/2) roll is set to 0.
    """
    C = np.asarray(C, dtype=float)
    if KERNELS and C.shape == (3, 3):
        return np.array(dcm_to_euler3(C.tolist()))
    if C.ndim < 2 or C.shape[-2:] != (3, 3):
        raise ValueError(f"C must have shape (..., 3, 3), got shape {C.shape}")
    # Read the angles off eq. 3.2: C31 = -sinθ, C32 = sinφ cosθ, C33 = cosφ cosθ,
    # C21 = cosθ sinψ, C11 = cosθ cosψ.
    euler = np.empty(C.shape[:-1])
    euler[..., 1] = -np.arcsin(C[..., 2, 0].clip(-1.0, 1.0))  # pitch
    locked = np.hypot(C[..., 2, 1], C[..., 2, 2]) < 1e-9
    euler[..., 0] = np.where(locked, 0.0, np.arctan2(C[..., 2, 1], C[..., 2, 2]))  # roll
    # At gimbal lock only yaw -+ roll is defined: take it from the second row / column.
    yaw = np.where(locked, np.arctan2(-C[..., 0, 1], C[..., 1, 1]), np.arctan2(C[..., 1, 0], C[..., 0, 0]))
    euler[..., 2] = np.where(yaw <= -np.pi, np.pi, yaw)  # atan2 is in [-pi, pi]: -pi reads as pi
    return euler


# ---------------------------------------------------------------- angular rates
def body_rates_to_euler_rates(euler, pqr) -> np.ndarray:
    """Euler angle rates (φ̇, θ̇, ψ̇) = E(e) (p, q, r), seed 002 eq. 3.7."""
    e = _vec3(euler, "euler")
    w = _vec3(pqr, "pqr")
    if e.shape == w.shape == (3,):  # one vector: E's entries on floats
        phi, theta, _ = e.tolist()
        if abs(math.cos(theta)) < _GIMBAL_EPS:
            raise ValueError(f"euler pitch is +-pi/2 (gimbal lock), Euler rates undefined: euler={e}")
        p, q, r = w.tolist()
        E = _rate_rows(math.cos(phi), math.sin(phi), math.cos(theta), math.tan(theta))
        return np.array([a * p + b * q + c * r for a, b, c in E])
    if np.any(np.abs(np.cos(e[..., 1])) < _GIMBAL_EPS):
        raise ValueError(f"euler pitch is +-pi/2 (gimbal lock), Euler rates undefined: euler={e}")
    return (euler_rate_matrix(e) @ w[..., None])[..., 0]


def euler_rates_to_body_rates(euler, euler_dot) -> np.ndarray:
    """Body rates (p, q, r) = E(e)^-1 (φ̇, θ̇, ψ̇), the inverse of seed 002 eq. 3.7."""
    e = _vec3(euler, "euler")
    d = _vec3(euler_dot, "euler_dot")
    if e.shape == (3,):
        phi, theta, _ = e.tolist()
        E_inv = np.array(_inverse_rate_rows(math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)))
    else:
        phi, theta = e[..., 0], e[..., 1]
        E_inv = matrix3(_inverse_rate_rows(np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)))
    return (E_inv @ d[..., None])[..., 0]


def kabsch(a: np.ndarray, b: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """R minimising sum w |b - R a|^2 (Kabsch 1976; Arun, Huang & Blostein 1987): H = sum w a b^T = U S V^T,
    R = V diag(1, 1, det(V U^T)) U^T."""
    w = np.ones(len(a)) if w is None else np.asarray(w, float)
    H = (np.asarray(a, float) * w[:, None]).T @ np.asarray(b, float)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, 1.0 if np.linalg.det(Vt.T @ U.T) >= 0 else -1.0])
    return Vt.T @ D @ U.T
