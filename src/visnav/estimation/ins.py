"""Strapdown INS mechanization in NED with quaternion attitude (seed 002 App. A, eq. A.1).

    r'  = v                                              (position, local NED [m])
    v'  = C_b^n f^b - (2 w_ie^n + w_en^n) x v + g^n       (velocity, NED [m/s])
    C'  = C_b^n [W_ib^b x] - [w_in^n x] C_b^n              (attitude; here as a quaternion)

Quaternions are Hamilton, scalar first ``(w, x, y, z)``, and rotate body FRD vectors into NED
(the same convention as PX4's ``vehicle_attitude.q`` and as ``C_b^n`` of geometry/rotations.py).

Position is kept as local NED metres from a reference point at geodetic latitude ``lat0`` and
height ``h0`` (the thesis states the position error in latitude/longitude/height; one metre north
is ``1/(R_N + h)`` rad of latitude). The current latitude, used by the Earth-rate and transport-rate
terms and by the gravity model, is ``lat0 + p_N / (R_N + h)``. Both rates are kept in the
structure; for a helicopter flying 1 km they are ~7e-5 rad/s and ~1e-6 rad/s. ``earth_rotation=False``
switches both off (a flat non-rotating Earth: the frame of synthetic test trajectories).

Integration per IMU interval (second order in dt): the attitude is advanced by the exact
exponential of the rotation vector ``(w_ib^b - C_n^b w_in^n) dt``; the velocity uses the specific
force rotated with the mid-interval attitude; the position the trapezoid of the velocities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from visnav.estimation.kernels import ins_propagate_flat
from visnav.geometry.rotations import cross3, dcm_to_euler, euler_to_dcm, matrix3
from visnav.scalar import finite

__all__ = [
    "OMEGA_EARTH",
    "NavState",
    "StrapdownINS",
    "earth_rates",
    "gravity_ned",
    "quat_mult",
    "quat_conj",
    "quat_to_dcm",
    "dcm_to_quat",
    "quat_from_rotvec",
    "quat_to_euler",
    "euler_to_quat",
    "radii_of_curvature",
    "integrate_gyro",
]

OMEGA_EARTH = 7.292115e-5  # WGS-84 Earth rotation rate [rad/s]
_A = 6378137.0  # WGS-84 semi-major axis [m]
_E2 = 6.69437999014e-3  # WGS-84 first eccentricity squared
_GE = 9.7803253359  # normal gravity at the equator [m/s^2]
_K = 1.931852652458e-3  # Somigliana constant
_FLAT = 1.0 / 298.257223563
_M = 0.00344978650684  # w^2 a^2 b / GM


# ---------------------------------------------------------------- quaternions
def _hamilton(pw, px, py, pz, qw, qx, qy, qz):
    """p ⊗ q, the Hamilton product of two scalar-first quaternions, component by component."""
    return (pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw)


def quat_mult(p, q) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of (..., 4) scalar-first quaternions."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if p.shape == (4,) and q.shape == (4,):  # one product (the per-sample loops): from the floats
        return np.array(_hamilton(*p.tolist(), *q.tolist()))
    return np.stack(np.broadcast_arrays(*_hamilton(*np.moveaxis(p, -1, 0), *np.moveaxis(q, -1, 0))), axis=-1)


def quat_conj(q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _quat_exp(x, y, z):
    """Exact exponential map of the rotation vector θ = (x, y, z): q = (cos(|θ|/2), sin(|θ|/2) θ / |θ|)."""
    a = np.sqrt(x * x + y * y + z * z)  # |θ|
    k = np.sin(0.5 * a) / (a + (a == 0.0))  # sin(|θ|/2) / |θ| (at θ = 0 any finite k: θ is zero)
    return np.cos(0.5 * a), k * x, k * y, k * z


def quat_from_rotvec(rv) -> np.ndarray:
    """Exact exponential map: rotation vector (..., 3) [rad] -> unit quaternion (..., 4)."""
    rv = np.asarray(rv, dtype=float)
    if rv.shape == (3,):  # one vector (the per-sample loops): from the floats
        return np.array(_quat_exp(*rv.tolist()))
    return np.stack(np.broadcast_arrays(*_quat_exp(*np.moveaxis(rv, -1, 0))), axis=-1)


def _quat_dcm_rows(w, x, y, z):
    """C_b^n of the quaternion (w, x, y, z) / |q| (so normalised here)."""
    s = 2.0 / (w * w + x * x + y * y + z * z)
    return [[1 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)],
            [s * (x * y + w * z), 1 - s * (x * x + z * z), s * (y * z - w * x)],
            [s * (x * z - w * y), s * (y * z + w * x), 1 - s * (x * x + y * y)]]


def quat_to_dcm(q) -> np.ndarray:
    """``C_b^n`` (..., 3, 3) from unit quaternion(s) (..., 4) (normalised here)."""
    q = np.asarray(q, dtype=float)
    if q.shape == (4,):  # one quaternion (the per-sample loops): from the floats
        if not float(q @ q) > 0.0:
            raise ValueError(f"quaternion must be non-zero and finite, got {q.tolist()}")
        return np.array(_quat_dcm_rows(*q.tolist()))
    return matrix3(_quat_dcm_rows(*np.moveaxis(q, -1, 0)))


def dcm_to_quat(C) -> np.ndarray:
    """Unit quaternion (w >= 0) from ``C_b^n`` (..., 3, 3)."""
    from scipy.spatial.transform import Rotation

    C = np.asarray(C, dtype=float)
    xyzw = Rotation.from_matrix(C.reshape(-1, 3, 3)).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=-1)
    q = np.where(q[:, :1] < 0, -q, q)
    return q.reshape(C.shape[:-2] + (4,))


def rotvec_from_dcm(C) -> np.ndarray:
    """Logarithm of one rotation matrix (3, 3): its rotation vector [rad] (|.| <= pi).

    The quaternion by Shepperd's choice of the largest of the trace and the diagonal (well conditioned
    at every angle), normalised (a product of rotations off orthogonality by rounding), turned to
    w >= 0, then ``2 atan2(|v|, w) v / |v|`` (``2 v / w`` at a zero angle). Agrees with scipy's
    ``Rotation.from_matrix(C).as_rotvec()`` to rounding (tests/estimation)."""
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = np.asarray(C, dtype=float).tolist()
    tr = c00 + c11 + c22
    if tr >= c00 and tr >= c11 and tr >= c22:
        w = math.sqrt(1.0 + tr)
        x, y, z, w = (c21 - c12) / w, (c02 - c20) / w, (c10 - c01) / w, w
    elif c00 >= c11 and c00 >= c22:
        x = math.sqrt(1.0 + c00 - c11 - c22)
        x, y, z, w = x, (c01 + c10) / x, (c02 + c20) / x, (c21 - c12) / x
    elif c11 >= c22:
        y = math.sqrt(1.0 - c00 + c11 - c22)
        x, y, z, w = (c01 + c10) / y, y, (c12 + c21) / y, (c02 - c20) / y
    else:
        z = math.sqrt(1.0 - c00 - c11 + c22)
        x, y, z, w = (c02 + c20) / z, (c12 + c21) / z, z, (c10 - c01) / z
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    n = math.sqrt(x * x + y * y + z * z + w * w)  # (the common factor 2 of Shepperd's formulas cancels)
    x, y, z, w = x / n, y / n, z / n, w / n
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 / w if s < 1e-12 else 2.0 * math.atan2(s, w) / s
    return np.array([k * x, k * y, k * z])


def quat_to_euler(q) -> np.ndarray:
    """(roll, pitch, yaw) [rad] of quaternion(s), ZYX as in geometry/rotations.py."""
    return dcm_to_euler(quat_to_dcm(q))


def euler_to_quat(euler) -> np.ndarray:
    return dcm_to_quat(euler_to_dcm(euler))


def integrate_gyro(q0, gyro, dt) -> np.ndarray:
    """Attitude history from body rates alone (no Earth rate): (N+1, 4) quaternions.

    The per-sample increments ``exp(w_k dt_k)`` are computed vectorised; only their ordered
    product is sequential.
    """
    gyro = np.asarray(gyro, dtype=float)
    dt = np.broadcast_to(np.asarray(dt, dtype=float), gyro.shape[:1])
    dq = quat_from_rotvec(gyro * dt[:, None])
    out = np.empty((len(gyro) + 1, 4))
    out[0] = q0
    for k in range(len(gyro)):
        out[k + 1] = quat_mult(out[k], dq[k])
    return out


# ---------------------------------------------------------------- Earth model
def radii_of_curvature(lat: float) -> tuple[float, float]:
    """Meridian (R_N) and transverse (R_E) radii of curvature of WGS-84 [m]."""
    s2 = math.sin(lat) ** 2
    d = 1.0 - _E2 * s2
    return _A * (1.0 - _E2) / d**1.5, _A / math.sqrt(d)


def gravity_ned(lat: float, h: float) -> np.ndarray:
    """Plumb-bob gravity (gravitation + centrifugal) in NED [m/s^2]: Somigliana normal gravity
    with the second-order free-air correction (WGS-84); only the down component is kept."""
    s2 = math.sin(lat) ** 2
    g0 = _GE * (1.0 + _K * s2) / math.sqrt(1.0 - _E2 * s2)
    g = g0 * (1.0 - 2.0 / _A * (1.0 + _FLAT + _M - 2.0 * _FLAT * s2) * h + 3.0 / _A**2 * h * h)
    return np.array([0.0, 0.0, g])


def earth_rates(lat: float, h: float, v_ned) -> tuple[np.ndarray, np.ndarray]:
    """Earth rate ``w_ie^n`` and transport rate ``w_en^n`` in NED [rad/s] (eq. A.1 terms)."""
    rn, re = radii_of_curvature(lat)
    vn, ve = float(v_ned[0]), float(v_ned[1])
    w_ie = OMEGA_EARTH * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    w_en = np.array([ve / (re + h), -vn / (rn + h), -ve * math.tan(lat) / (re + h)])
    return w_ie, w_en


# ---------------------------------------------------------------- state and mechanization
@dataclass
class NavState:
    """Nominal navigation state of the INS (all SI; biases in body FRD)."""

    t: float
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))  # local NED [m]
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))  # NED [m/s]
    quat: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))  # body->NED
    accel_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))  # [m/s^2]
    gyro_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))  # [rad/s]

    @property
    def dcm(self) -> np.ndarray:
        return quat_to_dcm(self.quat)

    @property
    def euler(self) -> np.ndarray:
        return quat_to_euler(self.quat)

    def copy(self) -> "NavState":
        return NavState(self.t, self.position.copy(), self.velocity.copy(), self.quat.copy(),
                        self.accel_bias.copy(), self.gyro_bias.copy())


def _check_finite(x, what: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (3,) or not finite(a):
        raise ValueError(f"{what} must be 3 finite numbers, got {x!r}")
    return a


class StrapdownINS:
    """Eq. A.1 integrated over IMU intervals; see the module docstring.

    ``lat0_deg``/``h0_m``: geodetic latitude and height of the local NED origin.
    ``earth_rotation``: keep the Earth-rate and transport-rate terms (True) or drop both.
    ``gravity``: None -> WGS-84 normal gravity at the current latitude and height; a number ->
    a constant ``[0, 0, g]`` (handy for flat-Earth synthetic data).
    """

    def __init__(self, lat0_deg: float = 58.4, h0_m: float = 0.0, earth_rotation: bool = True,
                 gravity: float | None = None):
        if not -90.0 < lat0_deg < 90.0:
            raise ValueError(f"lat0_deg must be in (-90, 90), got {lat0_deg}")
        self.lat0 = math.radians(lat0_deg)
        self.h0 = float(h0_m)
        self.earth_rotation = bool(earth_rotation)
        self.gravity = gravity
        # constant gravity: the vector once (read-only: propagate only adds it)
        self._g_const = None if gravity is None else np.array([0.0, 0.0, float(gravity)])
        if self._g_const is not None:
            self._g_const.flags.writeable = False
        #: flat Earth, constant gravity: ``propagate`` through ``estimation/kernels.ins_propagate_flat`` (the same
        #: steps on floats, held to the readable path at 1e-12 by tests/estimation/test_kernels.py)
        self.kernel = True

    # geodetic position of a local NED point
    def lat_h(self, position) -> tuple[float, float]:
        h = self.h0 - float(position[2])
        rn, _ = radii_of_curvature(self.lat0)
        return self.lat0 + float(position[0]) / (rn + h), h

    def gravity_at(self, position) -> np.ndarray:
        if self.gravity is not None:
            return np.array([0.0, 0.0, float(self.gravity)])
        lat, h = self.lat_h(position)
        return gravity_ned(lat, h)

    def rates_at(self, position, velocity) -> tuple[np.ndarray, np.ndarray]:
        """(w_ie^n, w_en^n); zeros when ``earth_rotation`` is off."""
        if not self.earth_rotation:
            z = np.zeros(3)
            return z, z.copy()
        lat, h = self.lat_h(position)
        return earth_rates(lat, h, velocity)

    def propagate(self, s: NavState, accel, gyro, dt: float) -> NavState:
        """Advance ``s`` by ``dt`` with bias-uncorrected IMU readings (specific force FRD
        [m/s^2], body rates [rad/s]) held over the interval; returns a new state."""
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"IMU interval dt must be positive and finite, got {dt}")
        f = _check_finite(accel, "accel") - s.accel_bias
        w = _check_finite(gyro, "gyro") - s.gyro_bias
        if self.kernel and not self.earth_rotation and self._g_const is not None:
            q, v, p = ins_propagate_flat(s.quat.tolist(), s.velocity.tolist(), s.position.tolist(), f.tolist(),
                                         w.tolist(), self._g_const.tolist(), dt)
            return NavState(s.t + dt, np.array(p), np.array(v), np.array(q), s.accel_bias.copy(), s.gyro_bias.copy())
        if self.earth_rotation:
            w_ie, w_en = self.rates_at(s.position, s.velocity)
            # attitude: C' = C [w_ib x] - [w_in x] C, i.e. the body increment w_ib - C^T w_in
            w_nb = w - quat_to_dcm(s.quat).T @ (w_ie + w_en)
            coriolis = cross3(2.0 * w_ie + w_en, s.velocity)
        else:  # flat non-rotating Earth: both rates are zero
            w_nb, coriolis = w, 0.0
        q_mid = quat_mult(s.quat, quat_from_rotvec(w_nb * (0.5 * dt)))
        q_new = quat_mult(s.quat, quat_from_rotvec(w_nb * dt))
        q_new /= np.linalg.norm(q_new)
        # velocity: specific force through the mid-interval attitude, Coriolis, gravity (eq. A.1)
        g = self._g_const if self._g_const is not None else self.gravity_at(s.position)
        v_new = s.velocity + (quat_to_dcm(q_mid) @ f - coriolis + g) * dt
        p_new = s.position + 0.5 * (s.velocity + v_new) * dt
        return NavState(s.t + dt, p_new, v_new, q_new, s.accel_bias.copy(), s.gyro_bias.copy())

    def run(self, s0: NavState, t, accel, gyro) -> dict[str, np.ndarray]:
        """Free inertial run over sample arrays (N,), (N,3), (N,3): over [t_k, t_{k+1}] the mean
        of samples k and k+1 is used (trapezoid). Returns (N,) / (N,3) / (N,4) arrays at the
        sample instants."""
        t = np.asarray(t, dtype=float)
        accel = np.asarray(accel, dtype=float)
        gyro = np.asarray(gyro, dtype=float)
        n = len(t)
        out = {"t": t, "position": np.empty((n, 3)), "velocity": np.empty((n, 3)),
               "quat": np.empty((n, 4))}
        s = s0.copy()
        s.t = float(t[0])
        for k in range(n):
            if k:
                s = self.propagate(s, 0.5 * (accel[k - 1] + accel[k]), 0.5 * (gyro[k - 1] + gyro[k]),
                                   t[k] - t[k - 1])
            out["position"][k], out["velocity"][k], out["quat"][k] = s.position, s.velocity, s.quat
        out["euler"] = quat_to_euler(out["quat"])
        return out
