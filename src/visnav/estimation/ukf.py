"""A general unscented Kalman filter with scaled sigma points (seed 003 §2.6, §3.1).

The filter keeps a mean ``x`` and covariance ``P`` and offers the two steps of seed 003 ch. 3 as
separate calls, so that a prediction can be triggered by each IMU sample and a correction by
each camera frame:

* :meth:`UnscentedKalmanFilter.predict` draws the 2n+1 scaled sigma points of (x, P) (van der
  Merwe's parameters ``alpha``, ``beta``, ``kappa``), passes them through the process model and
  recombines them (unscented transform) with the process noise ``Q`` added;
* :meth:`UnscentedKalmanFilter.update` draws sigma points of the current (x, P), passes them
  through the measurement model (whose size may change from call to call: the number of deck
  lights seen varies), and applies the Kalman gain.

Models act on *all* sigma points at once (``fx(sigmas (2n+1, n), dt, **kw) -> (2n+1, n)``,
``hx(sigmas, **kw) -> (2n+1, m)``): one numpy call per step instead of 2n+1 Python calls.
Hooks for states that do not add like vectors (angles): ``residual_x``, ``residual_z``
(difference of a batch of points and a mean), ``state_add`` (x + dx) and ``x_mean`` / ``z_mean``
(weighted mean of a batch). With the default hooks the filter reproduces filterpy's
``UnscentedKalmanFilter`` with ``MerweScaledSigmaPoints`` to rounding error (tested).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


def _sub(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a - b


def _add(x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    return x + dx


def _mean(sigmas: np.ndarray, wm: np.ndarray) -> np.ndarray:
    return wm @ sigmas


@dataclass
class SigmaWeights:
    """Scaled sigma-point weights (van der Merwe 2004): lambda = alpha^2 (n + kappa) - n."""

    n: int
    alpha: float = 1e-3
    beta: float = 2.0
    kappa: float = 0.0

    def __post_init__(self) -> None:
        n = self.n
        if n < 1:
            raise ValueError(f"state dimension must be >= 1, got {n}")
        self.lam = self.alpha**2 * (n + self.kappa) - n
        if n + self.lam <= 0:
            raise ValueError(f"n + lambda must be > 0 (alpha={self.alpha}, kappa={self.kappa})")
        c = 0.5 / (n + self.lam)
        self.wm = np.full(2 * n + 1, c)
        self.wc = np.full(2 * n + 1, c)
        self.wm[0] = self.lam / (n + self.lam)
        self.wc[0] = self.lam / (n + self.lam) + (1.0 - self.alpha**2 + self.beta)
        self.wc_col = self.wc[:, None]  # (the column the covariances are weighted with, made once)

    def points(self, x: np.ndarray, P: np.ndarray, state_add=_add) -> np.ndarray:
        """The 2n+1 sigma points: x, x + rows of U, x - rows of U with U^T U = (n + lambda) P."""
        n = self.n
        A = (self.lam + n) * P
        if not np.isfinite(A).all():
            raise np.linalg.LinAlgError("UKF covariance is not positive definite: it holds NaN or inf")
        try:
            U = np.linalg.cholesky(A).T  # upper factor, U^T U = A (as scipy.linalg.cholesky)
        except np.linalg.LinAlgError as exc:
            raise np.linalg.LinAlgError(f"UKF covariance is not positive definite: {exc}") from None
        d = np.empty((2 * n + 1, n), order="F")  # [0; U; -U], column-major as np.vstack made it of U = L^T
        d[0] = 0.0
        d[1:n + 1] = U
        np.negative(U, out=d[n + 1:])
        return state_add(x[None, :], d)  # (x broadcast over the rows)


class UnscentedKalmanFilter:
    """UKF with batch models; see the module docstring.

    Parameters
    ----------
    x0, P0 : initial mean (n,) and covariance (n, n)
    fx : process model, ``fx(sigmas, dt, **kw) -> sigmas`` (rows are states)
    hx : default measurement model, ``hx(sigmas, **kw) -> (rows, m)``; each update may pass its own
    """

    def __init__(self, x0, P0, fx: Callable, hx: Callable | None = None, alpha: float = 1e-3,
                 beta: float = 2.0, kappa: float = 0.0, residual_x: Callable = _sub,
                 residual_z: Callable = _sub, state_add: Callable = _add, x_mean: Callable = _mean,
                 z_mean: Callable = _mean):
        self.x = np.array(x0, dtype=float).ravel()
        n = self.x.size
        self.P = np.array(P0, dtype=float).reshape(n, n)
        self.weights = SigmaWeights(n, alpha, beta, kappa)
        self.fx, self.hx = fx, hx
        self.residual_x, self.residual_z = residual_x, residual_z
        self.state_add, self.x_mean, self.z_mean = state_add, x_mean, z_mean
        self.S: np.ndarray | None = None  # innovation covariance of the last update
        self.y: np.ndarray | None = None  # innovation of the last update
        self.nis = float("nan")

    @property
    def n(self) -> int:
        return self.x.size

    def sigma_points(self) -> np.ndarray:
        return self.weights.points(self.x, self.P, self.state_add)

    def unscented_transform(self, sigmas: np.ndarray, mean_fn, residual_fn, noise=None):
        w = self.weights
        m = mean_fn(sigmas, w.wm)
        d = residual_fn(sigmas, m)
        cov = (d * w.wc_col).T @ d
        if noise is not None:
            cov = cov + noise
        return m, cov, d

    def predict(self, dt: float, Q, fx: Callable | None = None, **fx_args) -> None:
        """Propagate (x, P) through the process model over ``dt`` and add the process noise Q."""
        f = fx or self.fx
        sig = f(self.sigma_points(), dt, **fx_args)
        self.x, P, _ = self.unscented_transform(sig, self.x_mean, self.residual_x, Q)
        self.P = 0.5 * (P + P.T)

    def predict_measurement(self, R=None, hx: Callable | None = None, sigmas: np.ndarray | None = None, **hx_args):
        """Predicted measurement mean, innovation covariance S (with R) and the pieces of the gain.
        ``sigmas``: the sigma points of the current (x, P) when the caller already has them."""
        h = hx or self.hx
        sig = self.sigma_points() if sigmas is None else sigmas
        zs = np.atleast_2d(h(sig, **hx_args))
        zp, S, dz = self.unscented_transform(zs, self.z_mean, self.residual_z, R)
        return zp, S, sig, dz

    def update(self, z, R, hx: Callable | None = None, max_nis: float | None = None, sigmas: np.ndarray | None = None,
               consider: slice | None = None, **hx_args) -> bool:
        """Correct (x, P) with measurement ``z`` of noise covariance ``R``. With ``max_nis`` an update whose
        normalised innovation squared is above it is not applied (x, P unchanged; ``S``, ``y``, ``nis`` are
        still those of the measurement): returns whether it was applied. ``sigmas``: the sigma points of the
        current (x, P) when the caller already has them (``sigma_points()``; not recomputed). ``consider``: states
        that are Schmidt-Kalman consider parameters: their gain rows are zero (never corrected, their variance
        kept) and the covariance takes the suboptimal gain's form P - K Pxz^T - Pxz K^T + K S K^T."""
        z = np.asarray(z, dtype=float).ravel()
        if z.size == 0:
            return False
        zp, S, sig, dz = self.predict_measurement(np.asarray(R, dtype=float), hx, sigmas, **hx_args)
        dx = self.residual_x(sig, self.x)
        Pxz = (dx * self.weights.wc_col).T @ dz
        y = self.residual_z(z[None, :], zp[None, :])[0]
        sol = np.linalg.solve(S, np.concatenate([Pxz.T, y[:, None]], axis=1))  # S^-1 [Pxz^T y]
        if max_nis is not None and float(y @ sol[:, -1]) > max_nis:
            self.S, self.y, self.nis = S, y, float(y @ sol[:, -1])
            return False
        K = sol[:, :-1].T  # K = Pxz S^-1 (S symmetric)
        if consider is not None:
            K[consider] = 0.0
        self.x = self.state_add(self.x[None, :], (K @ y)[None, :])[0]
        if consider is None:
            P = self.P - K @ S @ K.T
        else:
            KPzx = K @ Pxz.T
            P = self.P - KPzx - KPzx.T + K @ S @ K.T
        self.P = 0.5 * (P + P.T)
        self.S, self.y = S, y
        self.nis = float(y @ sol[:, -1])  # normalised innovation squared (chi2 with y.size dof)
        return True

    def update_states(self, z, R, idx, consider: slice | None = None) -> None:
        """Correct with a direct measurement ``z`` of the states ``idx`` (h(x) = H x, H selecting them; noise
        covariance ``R``): the Kalman filter's closed form, which the unscented transform of a linear h gives
        exactly, without drawing the sigma points: Pxz = P H^T, S = H P H^T + R, K = Pxz S^-1,
        x + K (z - H x), P - K Pxz^T - Pxz K^T + K S K^T (= P - K S K^T; with ``consider`` states' gain rows zero,
        as ``update``). ``S``, ``y`` and ``nis`` stay those of the last ``update``."""
        idx = np.asarray(idx)
        Pxz = self.P[:, idx]
        S = Pxz[idx] + np.asarray(R, dtype=float)
        y = np.asarray(z, dtype=float).ravel() - self.x[idx]
        K = np.linalg.solve(S, Pxz.T).T
        if consider is not None:
            K[consider] = 0.0
        self.x = self.state_add(self.x[None, :], (K @ y)[None, :])[0]
        KPzx = K @ Pxz.T
        P = self.P - KPzx - KPzx.T + K @ S @ K.T
        self.P = 0.5 * (P + P.T)
