"""Planar homography by the normalized DLT and RANSAC (seed 002 appendix B, Algorithms 2 and 3).

``normalized_dlt`` is Algorithm 2: both point sets are moved to their centroid and scaled to a mean
distance sqrt(2) from it (eq. B.8 system assembled on the normalized points), the solution is the
right singular vector of the smallest singular value, then denormalized, H = T'^-1 H~ T.

``ransac_homography`` is Algorithm 3 with the parameters of §B.3:

* threshold t: a correspondence is an inlier when its transfer error d^2 < F^-1_chi2,m=2(alpha) sigma^2
  (k^2 = 5.99 for alpha = 0.95, eq. B.10),
* consensus size T = (1 - eps) n, the iteration bound N = log(1 - p) / log(1 - (1 - eps)^4),
  both re-estimated from the largest consensus set found so far (adaptive N).

The minimal-sample hypotheses are solved in batches (an 8x8 linear system each, h33 = 1), so no
Python loop runs per hypothesis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

__all__ = ["normalize_points", "normalized_dlt", "transfer_error", "ransac_homography", "RansacResult",
           "chi2_threshold"]


def normalize_points(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) points -> (normalized points, 3x3 similarity T): centroid at 0, mean distance sqrt(2)."""
    x = np.asarray(x, float)
    c = x.mean(axis=0)
    d = np.sqrt(((x - c) ** 2).sum(axis=1)).mean()
    s = math.sqrt(2.0) / d if d > 0 else 1.0
    T = np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])
    return (x - c) * s, T


def _dlt_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The 2N x 9 matrix of eq. B.8 for b ~ H a (a, b: (..., N, 2)); returns (..., 2N, 9)."""
    x, y = a[..., 0], a[..., 1]
    u, v = b[..., 0], b[..., 1]
    o, z = np.ones_like(x), np.zeros_like(x)
    r1 = np.stack([z, z, z, -x, -y, -o, v * x, v * y, v], axis=-1)
    r2 = np.stack([x, y, o, z, z, z, -u * x, -u * y, -u], axis=-1)
    return np.concatenate([r1, r2], axis=-2)


def normalized_dlt(x1, x2) -> np.ndarray:
    """Algorithm 2: H with x2 ~ H x1 from N >= 4 correspondences ((N, 2) pixel arrays), ||H||_F = 1
    scaled so that H[2, 2] = 1 when that element is not ~0."""
    x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
    if x1.shape != x2.shape or x1.ndim != 2 or x1.shape[1] != 2 or x1.shape[0] < 4:
        raise ValueError(f"normalized_dlt needs two (N>=4, 2) point arrays, got {x1.shape} and {x2.shape}")
    n1, T1 = normalize_points(x1)
    n2, T2 = normalize_points(x2)
    A = _dlt_rows(n1, n2)
    _, _, Vt = np.linalg.svd(A, full_matrices=A.shape[0] < 9)  # 4 points: 8 rows, need the 9th vector
    Hn = Vt[-1].reshape(3, 3)
    H = np.linalg.solve(T2, Hn @ T1)
    return H / H[2, 2] if abs(H[2, 2]) > 1e-12 * np.abs(H).max() else H / np.linalg.norm(H)


def transfer_error(H: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """Squared transfer distance d^2 = |x2 - H x1|^2 [px^2]; H may be (K, 3, 3) -> (K, N)."""
    p = np.concatenate([x1, np.ones((len(x1), 1))], axis=1)
    q = p @ np.swapaxes(H, -1, -2)
    w = q[..., 2]
    w = np.where(np.abs(w) < 1e-12, 1e-12, w)
    d = q[..., :2] / w[..., None] - x2
    return (d * d).sum(axis=-1)


def _minimal_batch(x1: np.ndarray, x2: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Homographies (K, 3, 3) from K four-point samples (h33 = 1), and which ones are usable."""
    a, b = x1[idx], x2[idx]  # (K, 4, 2)
    # normalize each sample (conditioning of the 8x8 system)
    ca, cb = a.mean(axis=1, keepdims=True), b.mean(axis=1, keepdims=True)
    sa = math.sqrt(2) / np.maximum(np.sqrt(((a - ca) ** 2).sum(-1)).mean(-1), 1e-12)[:, None, None]
    sb = math.sqrt(2) / np.maximum(np.sqrt(((b - cb) ** 2).sum(-1)).mean(-1), 1e-12)[:, None, None]
    an, bn = (a - ca) * sa, (b - cb) * sb
    A = _dlt_rows(an, bn)  # (K, 8, 9)
    M, rhs = A[..., :8], -A[..., 8]
    det = np.linalg.det(M)
    ok = np.abs(det) > 1e-9
    M[~ok] = np.eye(8)
    h = np.linalg.solve(M, rhs[..., None])[..., 0]
    Hn = np.concatenate([h, np.ones((len(h), 1))], axis=1).reshape(-1, 3, 3)
    K = len(idx)
    T1 = np.zeros((K, 3, 3))
    T1[:, 0, 0] = T1[:, 1, 1] = sa[:, 0, 0]
    T1[:, :2, 2] = -sa[:, 0] * ca[:, 0]
    T1[:, 2, 2] = 1
    T2inv = np.zeros((K, 3, 3))
    T2inv[:, 0, 0] = T2inv[:, 1, 1] = 1 / sb[:, 0, 0]
    T2inv[:, :2, 2] = cb[:, 0]
    T2inv[:, 2, 2] = 1
    return T2inv @ Hn @ T1, ok


@lru_cache(maxsize=64)
def _chi2_ppf(alpha: float, dof: int) -> float:
    return float(chi2.ppf(alpha, dof))  # scipy.stats' ppf costs ~0.1 ms per call: once per alpha


def chi2_threshold(sigma_px: float, alpha: float = 0.95) -> float:
    """t^2 = F^-1_chi2(m=2)(alpha) sigma^2 (§B.3: 5.99 sigma^2 for alpha = 0.95) [px^2]."""
    return _chi2_ppf(float(alpha), 2) * float(sigma_px) ** 2


@dataclass
class RansacResult:
    H: np.ndarray | None
    inliers: np.ndarray  # bool (N,)
    iterations: int
    threshold_px2: float

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


def ransac_homography(x1, x2, sigma_px: float = 1.0, alpha: float = 0.95, p: float = 0.99,
                      max_iterations: int = 2000, rng: np.random.Generator | None = None,
                      batch: int = 64) -> RansacResult:
    """Algorithm 3: robust H with x2 ~ H x1. Returns H re-estimated (normalized DLT) on the largest
    consensus set, that set, the hypotheses tried and the chi-square threshold t^2 used."""
    x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
    n = len(x1)
    t2 = chi2_threshold(sigma_px, alpha)
    if n < 4:
        return RansacResult(None, np.zeros(n, bool), 0, t2)
    rng = rng if rng is not None else np.random.default_rng(0)
    best = np.zeros(n, bool)
    best_n = 0
    N = max_iterations
    it = 0
    while it < min(N, max_iterations):
        k = min(batch, max_iterations - it)
        idx = np.argsort(rng.random((k, n)), axis=1)[:, :4]
        Hs, ok = _minimal_batch(x1, x2, idx)
        it += k
        err = transfer_error(Hs, x1, x2)  # (k, n)
        inl = (err < t2) & ok[:, None]
        counts = inl.sum(axis=1)
        j = int(np.argmax(counts))
        if counts[j] > best_n:
            best_n, best = int(counts[j]), inl[j].copy()
            eps = 1.0 - best_n / n  # outlier fraction believed now
            if eps <= 0:
                N = it
            else:
                w4 = (1.0 - eps) ** 4
                N = int(math.ceil(math.log(1 - p) / math.log(1 - w4))) if w4 < 1 else it
        if best_n >= n:  # T = (1 - eps) n reached with eps = 0
            break
    if best_n < 4:
        return RansacResult(None, best, it, t2)
    H = normalized_dlt(x1[best], x2[best])
    # one re-classification with the re-estimated model (and a final re-fit)
    inl = transfer_error(H, x1, x2) < t2
    if inl.sum() >= 4 and not np.array_equal(inl, best):
        H = normalized_dlt(x1[inl], x2[inl])
        best = inl
    return RansacResult(H, best, it, t2)
