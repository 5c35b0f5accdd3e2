"""Position/velocity Kalman filter driven by the IMU (the flight computer's position filter).

State per NED axis: (position, velocity). Prediction integrates the IMU specific force rotated to
NED with the attitude solution (a = C_bn f + g e_z); updates take a position source (GPS or MPE),
GPS velocity, and the sonar height. The three axes are independent given the attitude, so the
filter keeps one 2x2 covariance per axis as three arrays (no 6x6 algebra on the 100 Hz path).

With ``accel_bias_noise > 0`` (issue #30) each axis carries a third state, the accelerometer bias ``b``
in NED (constant between updates, a random walk of ``accel_bias_noise`` m/s^2/sqrt(s)): the integrated
acceleration is ``a - b`` and the position / velocity updates estimate ``b``, so the dead-reckoning
after the last fix (PALACE's final metre) runs on a corrected acceleration, and the bias's uncertainty
is in the position covariance the protection level is built from. Per axis
``F = [[1, dt, -dt^2/2], [0, 1, -dt], [0, 0, 1]]``; the covariance is kept as the six arrays
``P00 P01 P02 P11 P12 P22``. Without it (the default) ``P02 = P12 = P22 = 0`` and ``b = 0`` stay so,
and the filter is the two-state one exactly.
"""

from __future__ import annotations

import numpy as np

G = 9.81


class PositionFilter:
    def __init__(self, accel_noise: float = 0.3, position=None, velocity=None, sigma_p: float = 1.0,
                 sigma_v: float = 0.5, accel_bias_noise: float = 0.0, sigma_b: float = 0.0):
        self.q = float(accel_noise) ** 2
        self.qb = float(accel_bias_noise) ** 2  # bias random walk [m^2/s^5]; 0: no bias state
        self.sigma_b = float(sigma_b) if self.qb > 0 else 0.0  # the bias's 1 sigma at a (re)start [m/s^2]
        self.b = np.zeros(3)
        self.P02 = np.zeros(3)
        self.P12 = np.zeros(3)
        self.P22 = np.full(3, self.sigma_b**2)
        self.p = np.zeros(3) if position is None else np.asarray(position, float).copy()
        self.v = np.zeros(3) if velocity is None else np.asarray(velocity, float).copy()
        self.P00 = np.full(3, sigma_p**2)
        self.P01 = np.zeros(3)
        self.P11 = np.full(3, sigma_v**2)
        self.t: float | None = None
        self.accel = np.zeros(3)  # the last kinematic acceleration the filter integrated (NED)
        self.initialized = position is not None
        # the last update's per-axis normalised innovation squared y^2 / S (the axes it used) and whether
        # its gate accepted it: the navigators' integrity monitors read them
        self.last_nis = np.zeros(0)
        self.last_accepted = True

    def reset(self, t: float, position, velocity, sigma_p: float = 0.05, sigma_v: float = 0.05) -> None:
        self.t = t
        self.p = np.asarray(position, float).copy()
        self.v = np.asarray(velocity, float).copy()
        self.P00[:] = sigma_p**2
        self.P01[:] = 0.0
        self.P11[:] = sigma_v**2
        # the bias estimate carries over a re-start (the IMU did not change); its covariance with the
        # new position / velocity is zero
        self.P02[:] = 0.0
        self.P12[:] = 0.0
        self.initialized = True

    @property
    def has_bias(self) -> bool:
        return self.qb > 0

    def predict(self, t: float, accel_ned: np.ndarray) -> None:
        if self.t is None:
            self.t = t
            return
        dt = t - self.t
        if dt <= 0:
            return
        self.t = t
        if self.qb > 0:
            self._predict_biased(dt, accel_ned)
            return
        self.accel = accel_ned
        # the 100 Hz path, per axis in scalar math (the same operations as the array form:
        # p += v dt + a dt^2 / 2, v += a dt, P += F P F^T - P + Q of the constant-acceleration model)
        a, p, v = accel_ned.tolist(), self.p, self.v
        q, dt2 = self.q, dt * dt
        q0, q1, q2 = q * dt**3 / 3, q * dt * dt / 2, q * dt
        P00, P01, P11 = self.P00, self.P01, self.P11
        for i in range(3):
            vi, pi01, pi11 = float(v[i]), float(P01[i]), float(P11[i])
            p[i] += vi * dt + 0.5 * a[i] * dt * dt
            v[i] = vi + a[i] * dt
            P00[i] += 2 * dt * pi01 + dt2 * pi11 + q0
            P01[i] = pi01 + (dt * pi11 + q1)
            P11[i] = pi11 + q2

    def _predict_biased(self, dt: float, accel_ned: np.ndarray) -> None:
        """The three-state step per axis: a = accel - b; P <- F P F^T + Q (F in the module docstring)."""
        self.accel = accel_ned - self.b
        a, p, v = self.accel.tolist(), self.p, self.v
        q, h = self.q, 0.5 * dt * dt
        q0, q1, q2, qb = q * dt**3 / 3, q * dt * dt / 2, q * dt, self.qb * dt
        P00, P01, P02, P11, P12, P22 = self.P00, self.P01, self.P02, self.P11, self.P12, self.P22
        for i in range(3):
            p00, p01, p02 = float(P00[i]), float(P01[i]), float(P02[i])
            p11, p12, p22 = float(P11[i]), float(P12[i]), float(P22[i])
            p[i] += float(v[i]) * dt + a[i] * h
            v[i] += a[i] * dt
            # rows of F P: r0 = (P0. + dt P1. - h P2.), r1 = (P1. - dt P2.), r2 = P2.
            r00, r01, r02 = p00 + dt * p01 - h * p02, p01 + dt * p11 - h * p12, p02 + dt * p12 - h * p22
            r11, r12 = p11 - dt * p12, p12 - dt * p22
            P00[i] = r00 + dt * r01 - h * r02 + q0
            P01[i] = r01 - dt * r02 + q1
            P02[i] = r02
            P11[i] = r11 - dt * r12 + q2
            P12[i] = r12
            P22[i] = p22 + qb

    def _gain_update(self, ax, y, S, row) -> None:
        """x += K y, P -= K row on ``ax``: ``row`` = (P0m, P1m, P2m), the measured state m's row of P
        (H = e_m, K = row / S)."""
        r0, r1, r2 = row
        K0, K1, K2 = r0 / S, r1 / S, r2 / S
        self.p[ax] += K0 * y
        self.v[ax] += K1 * y
        if self.qb > 0:
            self.b[ax] += K2 * y
            self.P22[ax] -= K2 * r2
            self.P12[ax] -= K1 * r2
            self.P02[ax] -= K0 * r2
        self.P11[ax] -= K1 * r1
        self.P01[ax] -= K0 * r1
        self.P00[ax] -= K0 * r0

    def update_position(self, z, sigma, axes=(0, 1, 2), gate: float | None = None) -> bool:
        """Update the given axes with a position measurement; returns False if gated out."""
        ax = np.asarray(axes)
        z = np.asarray(z, float)[ax] if np.size(z) == 3 else np.asarray(z, float)
        r = np.broadcast_to(np.asarray(sigma, float) ** 2, ax.shape)
        S = self.P00[ax] + r
        y = z - self.p[ax]
        self.last_nis = y * y / S
        self.last_accepted = not (gate is not None and np.any(self.last_nis > gate * gate))
        if not self.last_accepted:
            return False
        if self.qb == 0:  # the two-state filter's own operations (its numbers unchanged)
            K0 = self.P00[ax] / S
            K1 = self.P01[ax] / S
            self.p[ax] += K0 * y
            self.v[ax] += K1 * y
            P01 = self.P01[ax].copy()
            self.P11[ax] -= K1 * P01
            self.P01[ax] = (1 - K0) * P01
            self.P00[ax] = (1 - K0) * self.P00[ax]
            return True
        row = (self.P00[ax].copy(), self.P01[ax].copy(), self.P02[ax].copy())  # H = (1, 0, 0): P's row 0
        self._gain_update(ax, y, S, row)
        return True

    def update_velocity(self, z, sigma) -> None:
        r = float(sigma) ** 2
        S = self.P11 + r
        y = np.asarray(z, float) - self.v
        self.last_nis, self.last_accepted = y * y / S, True
        if self.qb > 0:
            row = (self.P01.copy(), self.P11.copy(), self.P12.copy())  # H = (0, 1, 0): P's row 1
            self._gain_update(slice(None), y, S, row)
            return
        K0 = self.P01 / S
        K1 = self.P11 / S
        self.p += K0 * y
        self.v += K1 * y
        P11 = self.P11.copy()
        self.P00 -= K0 * self.P01
        self.P01 = self.P01 * (1 - K1)
        self.P11 = P11 * (1 - K1)

    def covariance(self) -> np.ndarray:
        C = np.zeros((6, 6))
        d = C.reshape(-1)  # the diagonals as strided views: (i, i), (i, i + 3), (i + 3, i), (i + 3, i + 3)
        d[0:15:7] = self.P00
        d[3:18:7] = self.P01
        d[18:33:7] = self.P01
        d[21:36:7] = self.P11
        return C


def accel_ned(C_bn: np.ndarray, specific_force: np.ndarray) -> np.ndarray:
    """Kinematic acceleration in NED from a body specific force: a = C_bn f + g e_z."""
    a = C_bn @ specific_force
    a[2] += G
    return a
