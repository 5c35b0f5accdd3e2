"""Position/velocity Kalman filter driven by the IMU (the flight computer's position filter).

State per NED axis: (position, velocity). Prediction integrates the IMU specific force rotated to
NED with the attitude solution (a = C_bn f + g e_z); updates take a position source (GPS or MPE),
GPS velocity, and the sonar height. The three axes are independent given the attitude, so the
filter keeps one 2x2 covariance per axis as three arrays (no 6x6 algebra on the 100 Hz path).
"""

from __future__ import annotations

import numpy as np

G = 9.81


class PositionFilter:
    def __init__(self, accel_noise: float = 0.3, position=None, velocity=None, sigma_p: float = 1.0,
                 sigma_v: float = 0.5):
        self.q = float(accel_noise) ** 2
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
        self.initialized = True

    def predict(self, t: float, accel_ned: np.ndarray) -> None:
        if self.t is None:
            self.t = t
            return
        dt = t - self.t
        if dt <= 0:
            return
        self.t = t
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
        K0 = self.P00[ax] / S
        K1 = self.P01[ax] / S
        self.p[ax] += K0 * y
        self.v[ax] += K1 * y
        P01 = self.P01[ax].copy()
        self.P11[ax] -= K1 * P01
        self.P01[ax] = (1 - K0) * P01
        self.P00[ax] = (1 - K0) * self.P00[ax]
        return True

    def update_velocity(self, z, sigma) -> None:
        r = float(sigma) ** 2
        S = self.P11 + r
        y = np.asarray(z, float) - self.v
        self.last_nis, self.last_accepted = y * y / S, True
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
