"""Attitude: ZYX Euler angles, direction cosine matrices and angular rates.

Convention (seed 002 §3.4): Euler angles are (roll φ, pitch θ, yaw ψ) in radians and
``C_b^n = Rz(ψ) Ry(θ) Rx(φ)`` maps body FRD vectors to NED (seed 002 eq. 3.1-3.2);
``C_n^b = (C_b^n)^T`` (eq. 3.3). Every function accepts a leading batch axis (``...``).
"""

from __future__ import annotations

import math

import numpy as np

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
]

_GIMBAL_EPS = 1e-12


def _vec3(x, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {a.shape}")
    return a


def wrap_angle(a):
    """Wrap angle(s) in radians to the interval (-pi, pi]."""
    a = np.asarray(a, dtype=float)
    w = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    w = np.where(w <= -np.pi, w + 2.0 * np.pi, w)
    return w if w.ndim else float(w)


def skew(v) -> np.ndarray:
    """Cross-product matrix: ``skew(v) @ u == np.cross(v, u)``; shape (..., 3, 3)."""
    if isinstance(v, np.ndarray) and v.shape == (3,):  # fast path for the per-step filter algebra
        x, y, z = v.tolist()
        return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    v = _vec3(v, "v")
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [
            np.stack([z, -w, y], axis=-1),
            np.stack([w, z, -x], axis=-1),
            np.stack([-y, x, z], axis=-1),
        ],
        axis=-2,
    )


def cross3(a, b) -> np.ndarray:
    """``np.cross`` of two 3-vectors in scalar arithmetic: the same products and differences (so the
    same bits) without np.cross's per-call overhead (~10x on one pair of vectors)."""
    a0, a1, a2 = (a.tolist() if isinstance(a, np.ndarray) else a)
    b0, b1, b2 = (b.tolist() if isinstance(b, np.ndarray) else b)
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], dtype=float)


def euler_to_dcm3(phi: float, theta: float, psi: float) -> np.ndarray:
    """``euler_to_dcm`` of one (roll, pitch, yaw) given as three floats (its one-vector path)."""
    if not (math.isfinite(phi) and math.isfinite(theta) and math.isfinite(psi)):
        raise ValueError(f"euler must be finite, got {np.array([phi, theta, psi])}")
    cf, sf, ct, st = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    return np.array([
        [ct * cp, -cf * sp + sf * st * cp, sf * sp + cf * st * cp],
        [ct * sp, cf * cp + sf * st * sp, -sf * cp + cf * st * sp],
        [-st, sf * ct, cf * ct],
    ])


def euler_to_dcm(euler) -> np.ndarray:
    """``C_b^n`` (body -> NED) from (roll, pitch, yaw) [rad], seed 002 eq. 3.2; shape (..., 3, 3)."""
    e = _vec3(euler, "euler")
    if e.shape == (3,):  # fast path for the 100 Hz loops: eq. 3.2 written out
        return euler_to_dcm3(float(e[0]), float(e[1]), float(e[2]))
    if not np.all(np.isfinite(e)):
        raise ValueError(f"euler must be finite, got {e}")
    return _euler_matrix(np.cos(e), np.sin(e))


def _entries_to_matrices(entries: list, batch_shape: tuple) -> np.ndarray:
    """The nine entries (row by row, each of shape ``batch_shape``) as a C-contiguous (..., 3, 3) array."""
    return np.array(entries).reshape(9, -1).T.reshape(batch_shape + (3, 3))


def _euler_matrix(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Seed 002 eq. 3.2, C_b^n = Rz(psi) Ry(theta) Rx(phi), from the cosines and sines (..., 3) of (phi, theta, psi)."""
    cf, ct, cp = c[..., 0], c[..., 1], c[..., 2]
    sf, st, sp = s[..., 0], s[..., 1], s[..., 2]
    return _entries_to_matrices([ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp,
                                 ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp,
                                 -st, sf * ct, cf * ct], c.shape[:-1])


def _euler_rate_matrix(c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Seed 002 eq. 3.7, E(e) (body rates -> Euler angle rates), from the cosines and sines (..., 3) of the angles."""
    cf, sf, ct, st = c[..., 0], s[..., 0], c[..., 1], s[..., 1]
    one, zero = np.ones_like(cf), np.zeros_like(cf)
    return _entries_to_matrices([one, sf * st / ct, cf * st / ct,
                                 zero, cf, -sf,
                                 zero, sf / ct, cf / ct], c.shape[:-1])


def euler_rate_matrix(euler) -> np.ndarray:
    """E(e) with (phi_dot, theta_dot, psi_dot) = E(e) (p, q, r), seed 002 eq. 3.7 (seed 003 eq. 2.13); (..., 3, 3).

        E = [[1, sin(phi) tan(theta), cos(phi) tan(theta)],
             [0, cos(phi),            -sin(phi)          ],
             [0, sin(phi)/cos(theta), cos(phi)/cos(theta)]]
    """
    e = _vec3(euler, "euler")
    if e.shape == (3,):  # one vector (the filters' per-step Jacobians): the same matrix from math's functions
        sf, cf, ct, tt = math.sin(e[0]), math.cos(e[0]), math.cos(e[1]), math.tan(e[1])
        return np.array([[1.0, sf * tt, cf * tt], [0.0, cf, -sf], [0.0, sf / ct, cf / ct]])
    return _euler_rate_matrix(np.cos(e), np.sin(e))


def euler_to_dcm_and_rate_matrix(euler) -> tuple[np.ndarray, np.ndarray]:
    """``(euler_to_dcm(e), euler_rate_matrix(e))`` of a batch (..., 3) from one cos / sin of the angles."""
    e = _vec3(euler, "euler")
    c, s = np.cos(e), np.sin(e)
    return _euler_matrix(c, s), _euler_rate_matrix(c, s)


def cross(a, b) -> np.ndarray:
    """``a x b`` along the last axis, with broadcasting (``np.cross`` without its per-call overhead on small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def dcm_to_euler(C) -> np.ndarray:
    """(roll, pitch, yaw) [rad] from ``C_b^n``, inverse of seed 002 eq. 3.2; yaw in (-pi, pi].

    Pitch is in [-pi/2, pi/2]; at gimbal lock (pitch = +-pi/2) roll is set to 0.
    """
    C = np.asarray(C, dtype=float)
    if C.shape == (3, 3):  # one matrix (the 100 Hz loops): the same formulas in scalar math, same bits
        (c00, c01, _), (c10, c11, _), (c20, c21, c22) = C.tolist()
        pitch = -math.asin(min(max(c20, -1.0), 1.0))
        if float(np.hypot(c21, c22)) < 1e-9:
            roll, yaw = 0.0, math.atan2(-c01, c11)
        else:
            roll, yaw = math.atan2(c21, c22), math.atan2(c10, c00)
        yaw = math.pi - (math.pi - yaw) % (2.0 * math.pi)  # wrap_angle's arithmetic
        return np.array([roll, pitch, yaw + 2.0 * math.pi if yaw <= -math.pi else yaw])
    if C.ndim < 2 or C.shape[-2:] != (3, 3):
        raise ValueError(f"C must have shape (..., 3, 3), got shape {C.shape}")
    # Read the angles off eq. 3.2: C31 = -sinθ, C32 = sinφ cosθ, C33 = cosφ cosθ,
    # C21 = cosθ sinψ, C11 = cosθ cosψ.
    pitch = -np.arcsin(np.clip(C[..., 2, 0], -1.0, 1.0))
    locked = np.hypot(C[..., 2, 1], C[..., 2, 2]) < 1e-9
    roll = np.where(locked, 0.0, np.arctan2(C[..., 2, 1], C[..., 2, 2]))
    # At gimbal lock only yaw -+ roll is defined: take it from the second row / column.
    yaw_locked = np.arctan2(-C[..., 0, 1], C[..., 1, 1])
    yaw = np.where(locked, yaw_locked, np.arctan2(C[..., 1, 0], C[..., 0, 0]))
    return np.stack([roll, pitch, wrap_angle(yaw)], axis=-1)


def _check_pitch(cos_theta: np.ndarray, euler: np.ndarray) -> None:
    if np.any(np.abs(cos_theta) < _GIMBAL_EPS):
        raise ValueError(f"euler pitch is +-pi/2 (gimbal lock), Euler rates undefined: euler={euler}")


def body_rates_to_euler_rates(euler, pqr) -> np.ndarray:
    """Euler angle rates (φ̇, θ̇, ψ̇) from body rates (p, q, r), seed 002 eq. 3.7."""
    e = _vec3(euler, "euler")
    w = _vec3(pqr, "pqr")
    phi, theta = e[..., 0], e[..., 1]
    sphi, cphi, cth = np.sin(phi), np.cos(phi), np.cos(theta)
    _check_pitch(cth, e)
    tth = np.tan(theta)
    p, q, r = w[..., 0], w[..., 1], w[..., 2]
    phi_dot = p + q * sphi * tth + r * cphi * tth
    theta_dot = q * cphi - r * sphi
    psi_dot = (q * sphi + r * cphi) / cth
    return np.stack(np.broadcast_arrays(phi_dot, theta_dot, psi_dot), axis=-1)


def euler_rates_to_body_rates(euler, euler_dot) -> np.ndarray:
    """Body rates (p, q, r) from Euler angle rates, the inverse of seed 002 eq. 3.7."""
    e = _vec3(euler, "euler")
    d = _vec3(euler_dot, "euler_dot")
    if e.shape == (3,) and d.shape == (3,):  # one vector: the same arithmetic in scalar math, same bits
        phi, theta, _ = e.tolist()
        phi_dot, theta_dot, psi_dot = d.tolist()
        sphi, cphi, sth, cth = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
        return np.array([phi_dot - psi_dot * sth, theta_dot * cphi + psi_dot * sphi * cth,
                         -theta_dot * sphi + psi_dot * cphi * cth])
    phi, theta = e[..., 0], e[..., 1]
    sphi, cphi = np.sin(phi), np.cos(phi)
    sth, cth = np.sin(theta), np.cos(theta)
    phi_dot, theta_dot, psi_dot = d[..., 0], d[..., 1], d[..., 2]
    p = phi_dot - psi_dot * sth
    q = theta_dot * cphi + psi_dot * sphi * cth
    r = -theta_dot * sphi + psi_dot * cphi * cth
    return np.stack(np.broadcast_arrays(p, q, r), axis=-1)


def kabsch(a: np.ndarray, b: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """R minimising sum w |b - R a|^2 (Kabsch 1976; Arun, Huang & Blostein 1987): H = sum w a b^T = U S V^T,
    R = V diag(1, 1, det(V U^T)) U^T."""
    w = np.ones(len(a)) if w is None else np.asarray(w, float)
    H = (np.asarray(a, float) * w[:, None]).T @ np.asarray(b, float)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, 1.0 if np.linalg.det(Vt.T @ U.T) >= 0 else -1.0])
    return Vt.T @ D @ U.T
