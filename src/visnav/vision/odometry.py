"""Rotation-compensated visual odometry over flat ground (seed 002 §5.6, eq. 5.5-5.10).

Between two frames c1 -> c2 the ground plane induces the homography (eq. 5.5/5.8)

    H ~ K C_n^c2 (I - Delta n^T / d) C_c1^n K^-1,

with C_ci^n the camera -> NED rotation at frame i (from the navigation filter's attitude and the
mount), Delta = c2 - c1 the camera displacement in NED, n = (0, 0, 1) the flat-ground normal and d
the height of camera 1 above the ground (from the barometer). Eq. 5.9 solves it for the
displacement:

    RHS = d (C_n^c2^T K^-1 H* K C_c1^n^T - I) = -Delta n^T,    Delta_NE = -RHS[0:2, 2]  (eq. 5.10).

The thesis writes the displacement with the opposite sign convention (t = -Delta, H = ... (I + t n^T/d)).
Scale: the thesis divides H by its ninth element (H* = H / H33), exact only when the true-scale H has
H33 = 1 (no climb, camera exactly nadir). Here the scale lambda is taken from the two columns that the
flat-ground model says are e1 and e2: lambda = (M11 + M22) / 2 with M = C_n^c2^T K^-1 H K C_c1^n^T
(``scale="columns"``, default); ``scale="h33"`` is the thesis' normalization.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from visnav.vision.homography import ransac_homography
from visnav.vision.klt import KltTracker
from visnav.vision.homography import normalized_dlt

__all__ = ["displacement_from_homography", "VisualOdometry", "OdometryStep"]


def displacement_from_homography(H: np.ndarray, K: np.ndarray, C1_cn: np.ndarray, C2_cn: np.ndarray,
                                 d: float, scale: str = "columns") -> np.ndarray:
    """Eq. 5.9-5.10: NED displacement (3,) of the camera from frame 1 to frame 2.

    ``H`` maps frame-1 pixels to frame-2 pixels; ``C1_cn``, ``C2_cn`` are camera -> NED rotations;
    ``d`` the height of camera 1 above the flat ground [m]. The down component (``-RHS[2, 2]``) is
    returned too (meaningful only with ``scale="columns"``).
    """
    Kinv = np.linalg.inv(K)
    M = C2_cn @ Kinv @ H @ K @ C1_cn.T
    if scale == "h33":
        M = C2_cn @ Kinv @ (H / H[2, 2]) @ K @ C1_cn.T
    elif scale == "columns":
        M = M / (0.5 * (M[0, 0] + M[1, 1]))
    else:
        raise ValueError(f"scale must be 'columns' or 'h33', got {scale!r}")
    rhs = d * (M - np.eye(3))
    return -rhs[:, 2]


@dataclass
class OdometryStep:
    t: float
    ok: bool
    displacement: np.ndarray  # NED camera displacement since the previous processed frame [m] (NaN if not ok)
    n_tracked: int = 0
    n_inliers: int = 0
    n_outliers: int = 0
    reason: str = ""


class VisualOdometry:
    """KLT + RANSAC homography + eq. 5.9 per frame pair.

    ``step(t, image, C_cn, height)`` takes the camera -> NED rotation from the navigation filter at
    the frame's instant and the height of the camera above ground (barometer). A step with fewer
    than ``min_inliers`` RANSAC inliers is skipped (``ok=False`` with the reason), and the next
    step starts afresh from the current frame.
    """

    def __init__(self, K: np.ndarray, max_features: int = 50, sigma_px: float = 1.0, min_inliers: int = 8,
                 use_ransac: bool = True, rng: np.random.Generator | None = None, scale: str = "columns"):
        self.K = np.asarray(K, float)
        self.klt = KltTracker(max_features=max_features)
        self.sigma_px = sigma_px
        self.min_inliers = int(min_inliers)
        self.use_ransac = use_ransac
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.scale = scale
        self._prev: tuple[float, np.ndarray, float] | None = None  # t, C_cn, height of the last frame

    def restart(self) -> None:
        """Forget the previous frame (a camera gap): the next ``step`` measures nothing and starts again."""
        self._prev = None

    def step(self, t: float, image: np.ndarray, C_cn: np.ndarray, height: float) -> OdometryStep | None:
        pairs = self.klt.track(image)
        prev, self._prev = self._prev, (t, np.asarray(C_cn, float), float(height))
        if prev is None or pairs.n_detected == 0:
            return None  # first frame (or tracker restarted): nothing to compare with
        nan = np.full(3, np.nan)
        n = len(pairs.prev)
        if not (np.isfinite(height) and height > 0):
            return OdometryStep(t, False, nan, n, 0, 0, f"no valid height ({height})")
        if n < self.min_inliers:
            return OdometryStep(t, False, nan, n, 0, n, f"only {n} features tracked (< {self.min_inliers})")
        if self.use_ransac:
            res = ransac_homography(pairs.prev, pairs.curr, self.sigma_px, rng=self.rng)
            H, n_in = res.H, res.n_inliers
        else:
            H, n_in = normalized_dlt(pairs.prev, pairs.curr), n
        if H is None or n_in < self.min_inliers:
            return OdometryStep(t, False, nan, n, n_in, n - n_in,
                                f"only {n_in} RANSAC inliers of {n} (< {self.min_inliers})")
        disp = displacement_from_homography(H, self.K, prev[1], self._prev[1], prev[2], self.scale)
        return OdometryStep(t, bool(np.all(np.isfinite(disp))), disp, n, n_in, n - n_in)
