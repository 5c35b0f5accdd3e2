"""Position/velocity Kalman filter driven by the IMU (the flight computer's position filter).

The PALACE flight computer runs a position filter beside its attitude filter (seed 000 §2.1.2-2.1.3,
Fig. 2.3); the thesis gives no equations for it, so it is written as the discrete Kalman filter of seed 002
App. A (the model eq. A.5-A.6, the KF recursion printed after eq. A.7) for the constant-acceleration model
below.

State per NED axis ``i``: ``x_i = (p, v)``, or with ``accel_bias_noise > 0`` (issue #30) ``x_i = (p, v, b)``
with ``b`` the accelerometer bias in NED (constant between updates, a random walk of ``accel_bias_noise``
m/s^2/sqrt(s)). The input is the IMU specific force rotated to NED with the attitude solution,
``a = C_bn f + g e_z`` (``accel_ned``); the integrated acceleration is ``a - b``:

    x_i <- F x_i + B a_i,     P_i <- F P_i F^T + Q                         (App. A prediction; eq. A.5: x = Phi x + w)
    F = [[1, dt, -dt^2/2], [0, 1, -dt], [0, 0, 1]],  B = (dt^2/2, dt, 0)
    Q = q [[dt^3/3, dt^2/2, 0], [dt^2/2, dt, 0], [0, 0, 0]] + diag(0, 0, q_b dt)     (white acceleration, q = sigma_a^2)

(without the bias the upper-left 2x2 blocks). Updates measure one state ``m`` of an axis (position: GPS, MPE,
sonar height; velocity: GPS), ``H = e_m^T``:

    S = H P_i H^T + r,  K = P_i H^T / S,  x_i <- x_i + K (z - H x_i),  P_i <- P_i - K H P_i    (App. A update, eq. A.6)

The three axes share the model: the filter's state is the stacked ``x = (p_NED, v_NED[, b_NED])`` of
3n values with ``F (x) I_3``, ``B (x) I_3``, ``Q (x) I_3`` (Kronecker products) and one (3n, 3n) covariance
``P``; an update of several axes is one vector update (``H`` = the rows of ``I_3n`` measured; ``S`` is
diagonal, the axes being independent given the attitude, so ``last_nis`` per axis is ``y_i^2 / S_ii``).
With the bias state the position / velocity updates estimate ``b``, so the dead reckoning after the last fix
(PALACE's final metre) runs on a corrected acceleration, and the bias's uncertainty is in the position
covariance the protection level is built from.
"""

from __future__ import annotations

import numpy as np

G = 9.81
_VELOCITY_ROWS = np.arange(3, 6)


class PositionFilter:
    def __init__(self, accel_noise: float = 0.3, position=None, velocity=None, sigma_p: float = 1.0,
                 sigma_v: float = 0.5, accel_bias_noise: float = 0.0, sigma_b: float = 0.0):
        self.q = float(accel_noise) ** 2
        self.qb = float(accel_bias_noise) ** 2  # bias random walk [m^2/s^5]; 0: no bias state
        n = 3 if self.qb > 0 else 2  # states per axis: (p, v, b) or (p, v)
        self.x = np.zeros(3 * n)  # (p_NED, v_NED[, b_NED])
        if position is not None:
            self.x[0:3] = np.asarray(position, float)
        if velocity is not None:
            self.x[3:6] = np.asarray(velocity, float)
        self.P = np.diag(np.repeat([sigma_p**2, sigma_v**2, float(sigma_b) ** 2][:n], 3))  # sigma_b: at a (re)start
        self._I = np.eye(3 * n)
        self.t: float | None = None
        self.accel = np.zeros(3)  # the last kinematic acceleration the filter integrated, a - b (NED)
        self.initialized = position is not None
        # the last update's per-axis normalised innovation squared y^2 / S (the axes it used) and whether
        # its gate accepted it: the navigators' integrity monitors read them
        self.last_nis = np.zeros(0)
        self.last_accepted = True
        self._step_model: tuple = (None,)

    @property
    def p(self) -> np.ndarray:
        return self.x[0:3]

    @property
    def v(self) -> np.ndarray:
        return self.x[3:6]

    @property
    def b(self) -> np.ndarray:
        """The accelerometer bias estimate in NED (zero without the bias state)."""
        return self.x[6:9] if self.has_bias else np.zeros(3)

    @property
    def has_bias(self) -> bool:
        return self.qb > 0

    def reset(self, t: float, position, velocity, sigma_p: float = 0.05, sigma_v: float = 0.05) -> None:
        """A re-start at a known position and velocity. The bias estimate and its variance carry over (the IMU
        did not change); its covariance with the new position and velocity is zero."""
        self.t = t
        self.x = self.x.copy()  # (what a caller holds of the old state stays as it was)
        self.x[0:3], self.x[3:6] = np.asarray(position, float), np.asarray(velocity, float)
        self.P[:6, :] = 0.0
        self.P[:, :6] = 0.0
        self.P[0:6, 0:6] = np.diag(np.repeat([sigma_p**2, sigma_v**2], 3))
        self.initialized = True

    def predict(self, t: float, accel_ned: np.ndarray) -> None:
        """The prediction over ``dt = t - self.t`` with the NED acceleration ``accel_ned`` held over it."""
        if self.t is None:
            self.t = t
            return
        dt = t - self.t
        if dt <= 0:
            return
        self.t = t
        F, B, Q = self._model(dt)
        a = np.asarray(accel_ned, float)
        self.accel = a - self.x[6:9] if self.has_bias else a
        self.x = F @ self.x + B @ a
        self.P = F @ self.P @ F.T + Q

    def _model(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """F, B, Q of the module docstring (Kronecker products with I_3) for a step ``dt``, kept for the next
        step of the same ``dt`` (the IMU's)."""
        if self._step_model[0] != dt:
            n, q, h = self.x.size // 3, self.q, 0.5 * dt * dt
            F = np.array([[1.0, dt, -h], [0.0, 1.0, -dt], [0.0, 0.0, 1.0]])[:n, :n]
            B = np.array([[h], [dt], [0.0]])[:n]
            Q = np.array([[q * dt**3 / 3, q * h, 0.0], [q * h, q * dt, 0.0], [0.0, 0.0, self.qb * dt]])[:n, :n]
            I3 = np.eye(3)
            self._step_model = (dt, np.kron(F, I3), np.kron(B, I3), np.kron(Q, I3))
        return self._step_model[1:]

    def _update(self, rows: np.ndarray, z: np.ndarray, r, gate: float | None = None) -> bool:
        """The update: ``z`` measures the states ``rows`` of ``x`` (``H`` = those rows of the identity) with variances
        ``r``; nothing changes when an axis' ``y_i^2 / S_ii`` is above ``gate^2``."""
        H = self._I[rows]
        PHt = self.P @ H.T
        s = np.diag(H @ PHt) + r  # S = H P H^T + R is diagonal: the axes are independent
        y = z - H @ self.x
        self.last_nis = y * y / s
        self.last_accepted = not (gate is not None and np.any(self.last_nis > gate * gate))
        if not self.last_accepted:
            return False
        K = PHt / s  # P H^T S^-1
        self.x = self.x + K @ y
        self.P = self.P - K @ PHt.T  # K H P
        return True

    def update_position(self, z, sigma, axes=(0, 1, 2), gate: float | None = None) -> bool:
        """Update the given axes with a position measurement (``z``: 3 values or one per axis, 1 sigma ``sigma``);
        returns False (and changes nothing) if an axis' innovation is beyond ``gate`` sigmas."""
        ax = np.asarray(axes)
        z = np.asarray(z, float)
        return self._update(ax, z[ax] if z.size == 3 else z, np.asarray(sigma, float) ** 2, gate)

    def update_velocity(self, z, sigma) -> None:
        """Update all three axes with a velocity measurement of 1 sigma ``sigma`` (never gated)."""
        self._update(_VELOCITY_ROWS, np.asarray(z, float), float(sigma) ** 2)

    def axis_covariance(self, i: int) -> np.ndarray:
        """(n, n) covariance of axis ``i``'s (p, v[, b])."""
        k = np.arange(i, self.x.size, 3)
        return self.P[np.ix_(k, k)]

    def covariance(self) -> np.ndarray:
        """(6, 6) covariance of (position, velocity)."""
        return self.P[:6, :6].copy()


def accel_ned(C_bn: np.ndarray, specific_force: np.ndarray) -> np.ndarray:
    """Kinematic acceleration in NED from a body specific force: a = C_bn f + g e_z."""
    a = C_bn @ specific_force
    a[2] += G
    return a
