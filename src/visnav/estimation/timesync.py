"""Camera-to-IMU clock offset by cross-correlating rotation rates.

The camera's rotation between consecutive frames comes from the images alone: KLT tracks
(``vision/klt.py``) -> RANSAC homography of the ground plane (``vision/homography.py``) -> the
plane-induced homography decomposed into rotation, translation and plane normal
(``cv2.decomposeHomographyMat``: H = K (R + t n^T / d) K^-1, Faugeras & Lustman 1988), of which the
solution whose normal is closest to the expected ground direction is kept. The rotation angle per
frame interval ``theta_i`` is then compared with the gyro's rotation over the same interval moved by a
candidate offset ``tau``: ``g_i(tau) = |Phi(t_{i+1} + tau) - Phi(t_i + tau)|`` with ``Phi`` the
integrated body rate. The offset is the ``tau`` that maximises the correlation coefficient of ``g`` and
``theta`` over all intervals (a grid at ``step_s``, refined by a parabola through the peak and its two
neighbours); its uncertainty is the spread of that peak over bootstrap resamples of the intervals.

Magnitudes are compared (not vectors), so the camera-to-body rotation need not be known. The method
needs rotation that *changes* over the flight: turns entered and left, roll or yaw manoeuvres; a
straight, steady flight gives a flat correlation (reported as a low ``peak``). Convention: the
returned offset is what must be added to camera stamps to put them on the IMU clock
(``t_imu = t_camera + offset``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from visnav.vision.homography import ransac_homography
from visnav.vision.klt import KltTracker


@dataclass(frozen=True)
class TimeOffset:
    offset_s: float  # t_imu = t_camera + offset_s
    sigma_s: float  # 1-sigma, bootstrap over the frame intervals
    peak: float  # correlation coefficient at the peak (near 1: well excited)
    intervals: int  # frame intervals with a rotation measurement
    taus: np.ndarray  # candidate offsets [s]
    rho: np.ndarray  # correlation coefficient per candidate


def frame_rotation_angles(times, images, K: np.ndarray, ground_dir_cam=(0.0, 0.0, 1.0), min_inliers: int = 12,
                          rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rotation angle [rad] of the camera between consecutive frames, from KLT + RANSAC homography.

    Returns ``(t_pairs, angles)``: (N-1, 2) start and end stamps of each interval and (N-1,) angles,
    NaN where too few tracks survived. ``ground_dir_cam``: the direction of the ground plane's normal
    seen from the camera (camera frame), used to pick among the homography's decompositions."""
    rng = rng if rng is not None else np.random.default_rng(0)
    K = np.asarray(K, float)
    down = np.asarray(ground_dir_cam, float)
    down = down / np.linalg.norm(down)
    klt = KltTracker(max_features=150, min_distance_px=10.0)
    t = np.asarray(times, float)
    angles = np.full(max(len(t) - 1, 0), np.nan)
    for i, img in enumerate(images):
        pairs = klt.track(img)
        if i == 0 or len(pairs.prev) < min_inliers:
            continue
        res = ransac_homography(pairs.prev, pairs.curr, sigma_px=1.0, rng=rng)
        if res.H is None or res.n_inliers < min_inliers:
            continue
        _, Rs, _, ns = cv2.decomposeHomographyMat(res.H / res.H[2, 2], K)
        best = int(np.argmax([abs(float(n.ravel() @ down)) for n in ns]))
        angles[i - 1] = float(np.linalg.norm(cv2.Rodrigues(Rs[best])[0]))
    return np.column_stack([t[:-1], t[1:]]), angles


def _integrated_rate(t_gyro: np.ndarray, gyro: np.ndarray) -> np.ndarray:
    """Phi(t): the body rate integrated by trapezoids, (N, 3)."""
    d = np.diff(t_gyro)[:, None] * 0.5 * (gyro[1:] + gyro[:-1])
    return np.vstack([np.zeros((1, 3)), np.cumsum(d, axis=0)])


def gyro_angles(t_gyro, gyro, t_pairs, taus) -> np.ndarray:
    """|Phi(t1 + tau) - Phi(t0 + tau)| for every candidate (rows) and interval (columns)."""
    t_gyro, gyro = np.asarray(t_gyro, float), np.asarray(gyro, float)
    phi = _integrated_rate(t_gyro, gyro)
    taus = np.asarray(taus, float)[:, None]
    out = np.zeros((taus.shape[0], len(t_pairs), 3))
    for j in range(3):
        a = np.interp(t_pairs[:, 0][None, :] + taus, t_gyro, phi[:, j])
        b = np.interp(t_pairs[:, 1][None, :] + taus, t_gyro, phi[:, j])
        out[..., j] = b - a
    return np.linalg.norm(out, axis=2)


def _weighted_corr(W: np.ndarray, g: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Correlation coefficient of each row of ``g`` (J, N) with ``c`` (N,) under weights ``W`` (B, N)."""
    sw = W.sum(axis=1, keepdims=True)
    mg, mc = (W @ g.T) / sw, (W @ c) [:, None] / sw
    cov = (W @ (g * c).T) / sw - mg * mc
    vg = (W @ (g * g).T) / sw - mg * mg
    vc = (W @ (c * c))[:, None] / sw - mc * mc
    return cov / np.sqrt(np.maximum(vg * vc, 1e-300))


def _peak(taus: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Sub-sample peak of each row by a parabola through the maximum and its neighbours."""
    j = np.clip(np.argmax(rho, axis=-1), 1, rho.shape[-1] - 2)
    r = np.arange(rho.shape[0])
    y0, y1, y2 = rho[r, j - 1], rho[r, j], rho[r, j + 1]
    den = y0 - 2 * y1 + y2
    delta = np.where(np.abs(den) > 1e-15, 0.5 * (y0 - y2) / np.where(den == 0, 1, den), 0.0)
    return taus[j] + np.clip(delta, -1, 1) * (taus[1] - taus[0])


def estimate_offset(t_gyro, gyro, t_pairs, cam_angles, max_offset_s: float = 0.25, step_s: float = 0.002,
                    bootstrap: int = 200, rng: np.random.Generator | None = None) -> TimeOffset:
    """The clock offset that best aligns the gyro's rotation with the camera's (module docstring)."""
    ok = np.isfinite(cam_angles)
    t_pairs, c = np.asarray(t_pairs, float)[ok], np.asarray(cam_angles, float)[ok]
    if len(c) < 10:
        raise ValueError(f"{len(c)} frame intervals with a rotation measurement; at least 10 are needed")
    taus = np.arange(-max_offset_s, max_offset_s + step_s / 2, step_s)
    g = gyro_angles(t_gyro, gyro, t_pairs, taus)
    rho = _weighted_corr(np.ones((1, len(c))), g, c)
    best = float(_peak(taus, rho)[0])
    rng = rng if rng is not None else np.random.default_rng(0)
    W = rng.multinomial(len(c), np.full(len(c), 1.0 / len(c)), size=bootstrap).astype(float)
    boot = _peak(taus, _weighted_corr(W, g, c))
    return TimeOffset(best, float(np.std(boot)), float(rho[0].max()), int(len(c)), taus, rho[0])
