"""The deck navigator: IMU-driven predictions and bearing corrections of the relative deck UKF (seed 003 ch. 3).

* :meth:`DeckNavigator.imu` predicts over the time since the previous IMU sample (eq. 3.1-3.5) with
  the process noise of eq. 3.8; the angular acceleration is the numerical derivative of the gyro
  rates (unfiltered by default: its noise telescopes in the velocity, while a low-pass lag biases
  the Euler term during manoeuvres). Samples out of order or with NaN are dropped and counted.
* :meth:`DeckNavigator.camera` associates the frame's bearings with the expected lights
  (eq. 3.11-3.12, bearings only, the covariance of each light's predicted bearings from the
  unscented transform plus R) and corrects with the matched bearings and, for blobs matched to the
  previous frame, their bearing rates (eq. 3.10; new blobs' rates are discarded, §3.1.2). Rows with
  NaN are dropped; an empty frame changes nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from visnav.estimation import deck as dm
from visnav.estimation.association import associate
from visnav.estimation.ukf import UnscentedKalmanFilter


@dataclass
class DeckNavStats:
    imu_samples: int = 0
    imu_dropped: int = 0
    frames: int = 0
    empty_frames: int = 0
    blobs: int = 0
    blobs_rejected: int = 0
    lights_used_last: int = 0


class DeckNavigator:
    def __init__(self, lights: np.ndarray, cam: dm.CameraGeometry, x0, P0, imu_cov: np.ndarray,
                 ship_cov: np.ndarray, bearing_sigma: float, rate_sigma: float, gate: float = 13.8,
                 alpha: float = 0.1, beta: float = 2.0, kappa: float = 0.0, gyro_dot_tau: float = 0.0):
        self.lights = np.asarray(lights, float)
        self.cam = cam
        self.ukf = UnscentedKalmanFilter(x0, P0, dm.process_model, alpha=alpha, beta=beta, kappa=kappa,
                                         residual_x=dm.residual_x, state_add=dm.state_add)
        self.imu_cov, self.ship_cov = imu_cov, ship_cov
        self.bearing_var, self.rate_var = bearing_sigma**2, rate_sigma**2
        self.gate = gate
        self.gyro_dot_tau = gyro_dot_tau
        self.stats = DeckNavStats()
        self._t: float | None = None
        self._gyro: np.ndarray | None = None
        self._gyro_dot = np.zeros(3)
        self.last_gyro = np.zeros(3)
        self.last_nis, self.last_dof = float("nan"), 0
        self.last_bearing_rms = float("nan")  # RMS bearing innovation of the last update [rad]

    def reset(self, x0, P0) -> None:
        """Restart the filter (the thesis' operator resets it during manual flight, Fig. 5.7)."""
        self.ukf.x = np.array(x0, float)
        self.ukf.P = np.array(P0, float)

    @property
    def x(self) -> np.ndarray:
        return self.ukf.x

    @property
    def P(self) -> np.ndarray:
        return self.ukf.P

    def covariance(self) -> np.ndarray:
        """Covariance of the estimate including the gyro's white noise in the velocity (what NEES should use).

        The numerical angular acceleration telescopes in the velocity (``sum (w_k - w_k-1) x r``), so the
        estimate carries ``-n x r`` with ``n`` the newest gyro sample's noise: a white error that the
        process noise cannot hold (it does not accumulate) and that ``P`` therefore lacks. It adds
        ``[r]x Sigma_gyro [r]x^T`` to the velocity block (``v = (v + w x r) - w x r``, d/dw = ``[r]x``).
        """
        r = self.ukf.x[0:3]
        S = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        P = self.ukf.P.copy()
        P[6:9, 6:9] += S @ self.imu_cov[3:6, 3:6] @ S.T
        return P

    def imu(self, t: float, accel, gyro, gravity_body) -> bool:
        """Predict to ``t`` with one IMU sample; False (and counted) when the sample is dropped."""
        accel, gyro, gb = (np.asarray(a, float) for a in (accel, gyro, gravity_body))
        if not (np.isfinite(t) and np.all(np.isfinite(accel)) and np.all(np.isfinite(gyro)) and np.all(np.isfinite(gb))):
            self.stats.imu_dropped += 1
            return False
        if self._t is None:
            self._t, self._gyro, self.last_gyro = t, gyro, gyro
            self.stats.imu_samples += 1
            return True
        dt = t - self._t
        if dt <= 0:
            self.stats.imu_dropped += 1
            return False
        raw = (gyro - self._gyro) / dt
        a = dt / (self.gyro_dot_tau + dt)
        self._gyro_dot = self._gyro_dot + a * (raw - self._gyro_dot)
        u = dm.ImuInput(accel=accel, gyro=gyro, gyro_dot=self._gyro_dot, gravity_body=gb)
        Q = dm.process_noise(self.ukf.x, dt, u, self.imu_cov, self.ship_cov)
        self.ukf.predict(dt, Q, u=u)
        self._t, self._gyro, self.last_gyro = t, gyro, gyro
        self.stats.imu_samples += 1
        return True

    def expected_bearings(self):
        """Predicted bearings (L, 2) of every light and their covariances (L, 2, 2) with R."""
        L = len(self.lights)
        R = np.eye(2 * L) * self.bearing_var
        zp, S, _, _ = self.ukf.predict_measurement(R, dm.bearings_only, lights=self.lights, cam=self.cam)
        blocks = np.stack([S[2 * j:2 * j + 2, 2 * j:2 * j + 2] for j in range(L)])
        return zp.reshape(L, 2), blocks

    def camera(self, bearings, rates) -> int:
        """Correct with one frame's bearings (M, 2) and rates (M, 2); returns the number of lights used."""
        self.stats.frames += 1
        b = np.asarray(bearings, float).reshape(-1, 2)
        r = np.asarray(rates, float).reshape(-1, 2)
        if r.shape != b.shape:
            raise ValueError(f"bearings {b.shape} and rates {r.shape} differ in shape")
        ok = np.all(np.isfinite(b), axis=1)
        b, r = b[ok], r[ok]
        self.stats.blobs += int(ok.sum())
        if len(b) == 0:
            self.stats.empty_frames += 1
            self.stats.lights_used_last = 0
            return 0
        zp, S = self.expected_bearings()
        assign = associate(b, zp, S, self.gate)
        self.stats.blobs_rejected += int(np.sum(assign < 0))
        m = np.nonzero(assign >= 0)[0]
        if m.size == 0:
            self.stats.lights_used_last = 0
            return 0
        m = m[np.argsort(assign[m])]
        idx = assign[m]
        has_rate = np.all(np.isfinite(r[m]), axis=1)
        ridx = idx[has_rate]
        z = np.concatenate([b[m].ravel(), r[m][has_rate].ravel()])
        R = np.diag(np.r_[np.full(2 * idx.size, self.bearing_var), np.full(2 * ridx.size, self.rate_var)])
        self.ukf.update(z, R, hx=dm.measurement_model, lights=self.lights, cam=self.cam, gyro=self.last_gyro,
                        idx=idx, rate_idx=ridx)
        self.stats.lights_used_last = int(idx.size)
        self.last_nis, self.last_dof = self.ukf.nis, int(z.size)
        yb = self.ukf.y[:2 * idx.size]
        self.last_bearing_rms = float(np.sqrt(np.mean(yb * yb)))
        return int(idx.size)
