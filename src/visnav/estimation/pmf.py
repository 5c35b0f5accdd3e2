"""Point-mass filter for the 2-D (north, east) position (seed 002 §5.8.4, eq. 5.24-5.31).

The density p(x | y_1:t) is kept on a uniform N x N grid of resolution delta (default 80 m at 1 m,
as in §5.9; up to 200 x 200 as in Fig. 5.14). Model (eq. 5.24-5.25):

    x_t = x_t-1 + u_t-1^odom + v_t-1,   v ~ N(0, sigma_v^2 I),     p(y_t | x_t, z_t) from registration.

Time update: the grid points are translated by the odometry displacement (eq. 5.31, so the values
need no interpolation), then the density is convolved with the process-noise kernel p_v (eq. 5.26).
The Gaussian kernel is separable, so the convolution is two 1-D passes (``cv2.sepFilter2D``), not the
N^2 sum the thesis warns about. Measurement update: multiply by the likelihood and normalize by
alpha_t (eq. 5.27-5.28). Outputs: the minimum-variance estimate (eq. 5.29) and covariance (eq. 5.30).

Grid array axes: [i, j] with i along north and j along east; point (i, j) is at
centre + ((i - c) delta, (j - c) delta), c = (N - 1) / 2. When the MV estimate wanders more than one
cell from the grid centre the array is shifted by whole cells (mass leaving the grid is dropped and the
rest renormalized), so the grid follows the vehicle.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["PointMassFilter", "gaussian_kernel"]


def gaussian_kernel(sigma_cells: float) -> np.ndarray:
    """Sampled, normalized 1-D Gaussian with taps out to 4 sigma (at least 3 taps)."""
    s = max(float(sigma_cells), 1e-6)
    r = max(1, int(math.ceil(4.0 * s)))
    x = np.arange(-r, r + 1, dtype=float)
    k = np.exp(-0.5 * (x / s) ** 2)
    return k / k.sum()


class PointMassFilter:
    def __init__(self, centre_ne, size_m: float = 80.0, resolution_m: float = 1.0, sigma0_m: float = 25.0):
        n = int(round(size_m / resolution_m))
        if not 8 <= n <= 400:
            raise ValueError(f"PMF grid must have 8..400 points per side, got size_m={size_m}, "
                             f"resolution_m={resolution_m} -> {n}")
        self.n = n
        self.delta = float(resolution_m)
        self.centre = np.asarray(centre_ne, float).copy()
        off = (np.arange(n) - (n - 1) / 2.0) * self.delta
        self._off = off
        d2 = off[:, None] ** 2 + off[None, :] ** 2
        self.p = np.exp(-0.5 * d2 / max(sigma0_m, 1e-3) ** 2)  # prior N(centre, sigma0^2 I) on the grid
        self._normalize()

    # ------------------------------------------------------------------ grid
    @property
    def size_m(self) -> float:
        return self.n * self.delta

    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        """North (N,) and east (N,) coordinates of the grid lines."""
        return self.centre[0] + self._off, self.centre[1] + self._off

    def _normalize(self) -> float:
        a = float(self.p.sum()) * self.delta**2
        if not (a > 0 and math.isfinite(a)):
            raise FloatingPointError("PMF density vanished (all grid weights are zero)")
        self.p /= a
        return a

    # ------------------------------------------------------------------ recursion
    def predict(self, u_ne, sigma_v_m: float) -> None:
        """Eq. 5.31 (translate the grid by the odometry displacement) then eq. 5.26 (convolve)."""
        u = np.asarray(u_ne, float)[:2]
        if not np.all(np.isfinite(u)):
            raise ValueError(f"PMF odometry displacement must be finite, got {u}")
        self.centre = self.centre + u
        s = float(sigma_v_m) / self.delta
        if s > 0.05:
            k = gaussian_kernel(s)
            self.p = cv2.sepFilter2D(self.p, cv2.CV_64F, k, k, borderType=cv2.BORDER_CONSTANT)
            np.maximum(self.p, 0.0, out=self.p)
        self._normalize()
        self._recentre()

    def update(self, likelihood: np.ndarray) -> float:
        """Eq. 5.27-5.28 with the likelihood on the grid ((N, N), >= 0); returns alpha_t."""
        L = np.asarray(likelihood, float)
        if L.shape != self.p.shape:
            raise ValueError(f"likelihood must have the grid's shape {self.p.shape}, got {L.shape}")
        if not np.all(np.isfinite(L)) or L.min() < 0:
            raise ValueError("likelihood must be finite and >= 0")
        prior = self.p
        self.p = prior * L
        try:
            a = self._normalize()
        except FloatingPointError:  # no overlap between prior and likelihood: keep the prior
            self.p = prior
            return 0.0
        self._recentre()
        return a

    def update_gaussian(self, z_ne, R) -> float:
        """Update with a Gaussian position measurement z ~ N(x, R) (for tests and aiding)."""
        N, E = np.meshgrid(*self.grid(), indexing="ij")
        d = np.stack([N - z_ne[0], E - z_ne[1]], -1)
        Ri = np.linalg.inv(np.asarray(R, float))
        m = np.einsum("...i,ij,...j->...", d, Ri, d)
        return self.update(np.exp(-0.5 * (m - m.min())))

    # ------------------------------------------------------------------ outputs
    def estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """MV estimate (eq. 5.29) and covariance (eq. 5.30)."""
        w = self.p * self.delta**2
        pn = w.sum(axis=1)  # marginal over east, indexed by north
        pe = w.sum(axis=0)
        mn, me = float(pn @ self._off), float(pe @ self._off)
        dn, de = self._off - mn, self._off - me
        Pnn = float(pn @ (dn * dn))
        Pee = float(pe @ (de * de))
        Pne = float(dn @ w @ de)
        return self.centre + np.array([mn, me]), np.array([[Pnn, Pne], [Pne, Pee]])

    def _recentre(self) -> None:
        mean, _ = self.estimate()
        k = np.round((mean - self.centre) / self.delta).astype(int)
        if not np.any(k):
            return
        n = self.n
        out = np.zeros_like(self.p)
        si, sj = k
        src_i = slice(max(si, 0), n + min(si, 0))
        dst_i = slice(max(-si, 0), n + min(-si, 0))
        src_j = slice(max(sj, 0), n + min(sj, 0))
        dst_j = slice(max(-sj, 0), n + min(-sj, 0))
        if src_i.start < src_i.stop and src_j.start < src_j.stop:
            out[dst_i, dst_j] = self.p[src_i, src_j]
        if out.sum() <= 0:
            return  # the estimate left the grid entirely: keep the grid where it is
        self.p = out
        self.centre = self.centre + k * self.delta
        self._normalize()
