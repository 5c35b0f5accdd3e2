"""Recursive least squares with a covariance and outlier gating (seed 002 §7.3.4, Figs. 7.9 / 7.11).

The thesis combines the target samples with "a recursive least square filter" and lets the false
matches in (they "do not have a major influence"). Model ``z_k = H_k x + v_k``, ``v_k ~ N(0, R_k)``.
Until the information matrix ``sum H^T R^-1 H`` has full rank the sums are accumulated; then ``x`` is
the batch solution of what has been seen, and from there on the standard covariance-form update

    S = H P H^T + R,   K = P H^T S^-1,   x <- x + K (z - H x),   P <- (I - K H) P (Joseph form)

so that without gating the estimate equals the batch weighted least-squares solution at every step
(tested to 1e-9). Beyond the thesis:

* chi-square gating: a sample whose innovation ``nu^T S^-1 nu`` exceeds the ``gate_prob`` quantile is
  rejected once ``min_samples`` have been accepted; when more rejections in a row than accepted
  samples (and at least ``reinit_after``) have come in, the estimate itself was started on false
  matches: it restarts from those samples (the ones within 3 robust sigmas of their median);
* ``P`` is the covariance of ``x`` for the stated ``R``; ``scale_covariance`` also multiplies it by the
  a-posteriori variance factor (weighted residual sum of squares / degrees of freedom), which makes it
  honest when ``R`` was a guess.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

__all__ = ["RecursiveLeastSquares", "batch_least_squares"]


def batch_least_squares(H_list, z_list, R_list=None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted batch solution (x, covariance) of stacked ``z = H x + v``."""
    n = np.atleast_2d(H_list[0]).shape[1]
    A = np.zeros((n, n))
    b = np.zeros(n)
    for k, (H, z) in enumerate(zip(H_list, z_list)):
        H = np.atleast_2d(np.asarray(H, float))
        z = np.atleast_1d(np.asarray(z, float))
        Ri = np.linalg.inv(np.atleast_2d(R_list[k])) if R_list is not None else np.eye(z.size)
        A += H.T @ Ri @ H
        b += H.T @ Ri @ z
    P = np.linalg.inv(A)
    return P @ b, P


class RecursiveLeastSquares:
    def __init__(self, n: int, gate_prob: float | None = 0.999, min_samples: int = 5, reinit_after: int = 4,
                 scale_covariance: bool = False) -> None:
        if n < 1:
            raise ValueError(f"n must be >= 1, got {n}")
        self.n = n
        self.gate = None if gate_prob is None else float(chi2.ppf(gate_prob, 1))  # per-dof, scaled below
        self.gate_prob = gate_prob
        self.min_samples, self.reinit_after = int(min_samples), int(reinit_after)
        self.scale_covariance = scale_covariance
        self.reset()

    def reset(self) -> None:
        self.x: np.ndarray | None = None
        self.P: np.ndarray | None = None
        self._A = np.zeros((self.n, self.n))
        self._b = np.zeros(self.n)
        self.accepted = self.rejected = 0
        self._wrss = 0.0
        self._m = 0  # scalar observations accepted
        self._recent_rejects: list[tuple] = []
        self.reinits = getattr(self, "reinits", 0)

    @property
    def initialized(self) -> bool:
        return self.x is not None

    def covariance(self) -> np.ndarray:
        if self.P is None:
            return np.full((self.n, self.n), np.nan)
        if self.scale_covariance and self._m > self.n:
            return self.P * (self._wrss / (self._m - self.n))
        return self.P.copy()

    def update(self, z, H=None, R=None) -> bool:
        """Add one sample; returns whether it was accepted."""
        z = np.atleast_1d(np.asarray(z, float))
        H = np.eye(self.n) if H is None else np.atleast_2d(np.asarray(H, float))
        R = np.eye(z.size) if R is None else np.atleast_2d(np.asarray(R, float))
        if H.shape != (z.size, self.n) or R.shape != (z.size, z.size):
            raise ValueError(f"shapes: z {z.shape}, H {H.shape}, R {R.shape} for n = {self.n}")
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(H)) and np.all(np.isfinite(R))):
            self.rejected += 1
            return False
        if self.x is None:
            Ri = np.linalg.inv(R)
            self._A += H.T @ Ri @ H
            self._b += H.T @ Ri @ z
            self.accepted += 1
            self._m += z.size
            if np.linalg.matrix_rank(self._A) == self.n:
                self.P = np.linalg.inv(self._A)
                self.x = self.P @ self._b
            return True
        nu = z - H @ self.x
        S = H @ self.P @ H.T + R
        d2 = float(nu @ np.linalg.solve(S, nu))
        if self.gate is not None and self.accepted >= self.min_samples:
            limit = float(chi2.ppf(self.gate_prob, z.size))
            if d2 > limit:
                self.rejected += 1
                self._recent_rejects.append((z, H, R))
                if len(self._recent_rejects) >= max(self.reinit_after, self.accepted + 1):
                    self._restart()
                return False
        self._recent_rejects.clear()
        K = self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ nu
        IKH = np.eye(self.n) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self._wrss += d2
        self._m += z.size
        self.accepted += 1
        return True

    def _restart(self) -> None:
        """The last ``reinit_after`` samples all disagreed with the estimate: start again from them."""
        recent, count = list(self._recent_rejects), self.reinits + 1
        self.reset()
        self.reinits = count
        if all(np.allclose(H, np.eye(self.n)) for _, H, _ in recent):
            med = np.median(np.array([z for z, _, _ in recent]), axis=0)
            spread = np.median(np.abs(np.array([z for z, _, _ in recent]) - med), axis=0) * 1.4826
            keep = [(z, H, R) for z, H, R in recent if np.all(np.abs(z - med) <= 3 * spread + 1e-9)]
        else:
            keep = recent
        for z, H, R in keep:
            self.update(z, H, R)
