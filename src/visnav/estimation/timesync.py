"""Camera/gyro calibration from a flight: the clock offset and the camera-to-IMU rotation.

Inputs: the gyro (t, body rates) and the camera's rotation between consecutive frames as rotation
vectors in the camera frame (``vision/frame_rotation.py``: feature tracks, undistorted, essential
matrix or rotation-only model). No images here: this module only compares rotations.

1. Coarse clock offset, rotation-invariant. The rotation angle per frame interval ``theta_i = |phi_i|``
   is compared with the gyro's rotation over the same interval moved by a candidate offset ``tau``:
   ``g_i(tau) = |Phi(t_{i+1} + tau) - Phi(t_i + tau)|``, ``Phi`` the integrated body rate. The offset is
   the ``tau`` maximising the correlation coefficient of ``g`` and ``theta`` (a grid at ``step_s``,
   refined by a parabola through the peak and its two neighbours). Needs no camera-to-IMU rotation.
2. Hand-eye rotation. For a rigid camera-IMU pair, the camera's motion and the body's over the same
   interval are the same rotation seen in two frames: ``psi_i = R phi_i + b dt_i`` with ``psi`` the
   integrated gyro (at the offset of 1), ``R = R_imu_cam`` (camera -> IMU/body) and ``b`` the gyro bias.
   ``R`` is the orthogonal Procrustes solution (Kabsch) alternated with the least-squares bias; its
   uncertainty is the spread of bootstrap resamples of the intervals (RMS angle of ``R_boot R^T``).
3. Refinement of the offset with the vectors: the residual ``sum |psi_i(tau) - R phi_i - b dt_i|^2``
   is minimised over ``tau`` near the coarse peak (parabola through the minimum), 2 and 3 repeated
   once; sigma by bootstrap of the intervals.

Convention: ``t_imu = t_camera + offset``. The method needs rotation that *changes*: a flight with
turns entered and left; a steady flight gives a flat correlation (a low ``peak``) and an ill-posed
hand-eye rotation (a large ``rotation_sigma_deg``; an axis never excited is not observable).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from visnav.geometry.rotations import kabsch

__all__ = ["TimeOffset", "CameraImuCalibration", "estimate_offset", "gyro_angles", "gyro_rotvecs",
           "hand_eye_rotation", "calibrate_camera_imu", "wide_offset", "rotation_angle_deg", "kabsch"]


@dataclass(frozen=True)
class TimeOffset:
    offset_s: float  # t_imu = t_camera + offset_s
    sigma_s: float  # 1-sigma, bootstrap over the frame intervals
    peak: float  # correlation coefficient at the peak (near 1: well excited)
    intervals: int  # frame intervals with a rotation measurement
    taus: np.ndarray  # candidate offsets [s]
    rho: np.ndarray  # correlation coefficient per candidate


@dataclass
class CameraImuCalibration:
    offset_s: float  # refined, t_imu = t_camera + offset_s
    offset_sigma_s: float
    coarse: TimeOffset  # the magnitude cross-correlation (step 1)
    R_imu_cam: np.ndarray  # camera -> IMU rotation (hand-eye)
    rotation_sigma_deg: float
    gyro_bias: np.ndarray  # [rad/s], from the hand-eye fit
    residual_deg: float  # RMS of |psi - R phi - b dt| per interval [deg]
    excitation_deg: np.ndarray  # RMS rotation per interval about each IMU axis [deg]
    intervals: int
    rotation_error_deg: float | None = None  # angle between R_imu_cam and the declared one
    extra: dict = field(default_factory=dict)
    taus: np.ndarray | None = None  # step 1's candidate offsets [s]
    residual_ss: np.ndarray | None = None  # step 1's residual sum of squares per candidate [rad^2]


def rotation_angle_deg(R: np.ndarray) -> float:
    """Angle of a rotation matrix [deg] (trace formula, clipped)."""
    return float(np.degrees(math.acos(float(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))))


def _integrated_rate(t_gyro: np.ndarray, gyro: np.ndarray) -> np.ndarray:
    """Phi(t): the body rate integrated by trapezoids, (N, 3)."""
    d = np.diff(t_gyro)[:, None] * 0.5 * (gyro[1:] + gyro[:-1])
    return np.vstack([np.zeros((1, 3)), np.cumsum(d, axis=0)])


def _phi_at(t_gyro, phi, t) -> np.ndarray:
    return np.stack([np.interp(t, t_gyro, phi[:, j]) for j in range(3)], axis=-1)


def gyro_rotvecs(t_gyro, gyro, t_pairs, tau: float = 0.0) -> np.ndarray:
    """The integrated body rate over each interval moved by ``tau``, (N, 3) [rad] (small-angle: the
    rotation vector of a frame interval, to second order in the rate change within it)."""
    t_gyro, gyro = np.asarray(t_gyro, float), np.asarray(gyro, float)
    phi = _integrated_rate(t_gyro, gyro)
    tp = np.asarray(t_pairs, float)
    return _phi_at(t_gyro, phi, tp[:, 1] + tau) - _phi_at(t_gyro, phi, tp[:, 0] + tau)


def gyro_angles(t_gyro, gyro, t_pairs, taus) -> np.ndarray:
    """|Phi(t1 + tau) - Phi(t0 + tau)| for every candidate (rows) and interval (columns)."""
    t_gyro, gyro = np.asarray(t_gyro, float), np.asarray(gyro, float)
    phi = _integrated_rate(t_gyro, gyro)
    taus = np.asarray(taus, float)[:, None]
    tp = np.asarray(t_pairs, float)
    out = _phi_at(t_gyro, phi, tp[:, 1][None, :] + taus) - _phi_at(t_gyro, phi, tp[:, 0][None, :] + taus)
    return np.linalg.norm(out, axis=2)


def _weighted_corr(W: np.ndarray, g: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Correlation coefficient of each row of ``g`` (J, N) with ``c`` (N,) under weights ``W`` (B, N)."""
    sw = W.sum(axis=1, keepdims=True)
    mg, mc = (W @ g.T) / sw, (W @ c)[:, None] / sw
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


def _bootstrap_weights(n: int, b: int, rng) -> np.ndarray:
    return rng.multinomial(n, np.full(n, 1.0 / n), size=b).astype(float)


def estimate_offset(t_gyro, gyro, t_pairs, cam_angles, max_offset_s: float = 0.25, step_s: float = 0.002,
                    bootstrap: int = 200, rng: np.random.Generator | None = None) -> TimeOffset:
    """Step 1 of the module docstring: the offset from rotation magnitudes alone."""
    ok = np.isfinite(cam_angles)
    t_pairs, c = np.asarray(t_pairs, float)[ok], np.asarray(cam_angles, float)[ok]
    if len(c) < 10:
        raise ValueError(f"{len(c)} frame intervals with a rotation measurement; at least 10 are needed")
    taus = np.arange(-max_offset_s, max_offset_s + step_s / 2, step_s)
    g = gyro_angles(t_gyro, gyro, t_pairs, taus)
    rho = _weighted_corr(np.ones((1, len(c))), g, c)
    best = float(_peak(taus, rho)[0])
    rng = rng if rng is not None else np.random.default_rng(0)
    boot = _peak(taus, _weighted_corr(_bootstrap_weights(len(c), bootstrap, rng), g, c))
    return TimeOffset(best, float(np.std(boot)), float(rho[0].max()), int(len(c)), taus, rho[0])


def hand_eye_rotation(cam_rotvec, imu_rotvec, dt, w=None, iters: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Step 2: ``psi = R phi + b dt`` for R (camera -> IMU) and the gyro bias b, by alternating Kabsch and
    the weighted mean of the residual rate."""
    phi, psi, dt = np.asarray(cam_rotvec, float), np.asarray(imu_rotvec, float), np.asarray(dt, float)
    w = np.ones(len(phi)) if w is None else np.asarray(w, float)
    b = np.zeros(3)
    for _ in range(iters):
        R = kabsch(phi, psi - b * dt[:, None], w)
        b = (w[:, None] * (psi - phi @ R.T)).sum(0) / max(float((w * dt).sum()), 1e-12)
    return R, b


def _residual_ss(t_gyro, gyro, tp, phi, R, b, taus, W) -> np.ndarray:
    """Weighted residual sum of squares for every candidate offset (rows) and weight set (W rows)."""
    phi_int = _integrated_rate(t_gyro, gyro)
    dt = tp[:, 1] - tp[:, 0]
    pred = phi @ R.T + b * dt[:, None]
    out = np.empty((W.shape[0], len(taus)))
    for k, tau in enumerate(taus):
        psi = _phi_at(t_gyro, phi_int, tp[:, 1] + tau) - _phi_at(t_gyro, phi_int, tp[:, 0] + tau)
        e2 = ((psi - pred) ** 2).sum(1)
        out[:, k] = W @ e2
    return out


def _scan(t_gyro, phi_int, tp, phi, dt, taus) -> np.ndarray:
    """Hand-eye residual sum of squares per candidate offset (R and b fitted per candidate)."""
    ss = np.empty(len(taus))
    for k, tau in enumerate(taus):
        psi = _phi_at(t_gyro, phi_int, tp[:, 1] + tau) - _phi_at(t_gyro, phi_int, tp[:, 0] + tau)
        R, b = hand_eye_rotation(phi, psi, dt, iters=4)
        ss[k] = float(((psi - phi @ R.T - b * dt[:, None]) ** 2).sum())
    return ss


def wide_offset(t_gyro, gyro, t_pairs, cam_rotvec, step_s: float = 0.01) -> float:
    """Frames on their own clock: the offset over every lag that puts all frames inside the gyro's span
    (step 1 of the module docstring on a coarse grid); the start for ``calibrate_camera_imu(center_s=)``."""
    t_gyro, gyro = np.asarray(t_gyro, float), np.asarray(gyro, float)
    ok = np.all(np.isfinite(cam_rotvec), axis=1)
    tp, phi = np.asarray(t_pairs, float)[ok], np.asarray(cam_rotvec, float)[ok]
    if len(tp) < 10:
        raise ValueError(f"{len(tp)} frame intervals with a camera rotation; at least 10 are needed")
    lo, hi = t_gyro[0] - tp[0, 0], t_gyro[-1] - tp[-1, 1]
    if hi < lo:
        raise ValueError(f"the frames span {tp[-1, 1] - tp[0, 0]:.1f} s, more than the gyro's "
                         f"{t_gyro[-1] - t_gyro[0]:.1f} s")
    taus = np.arange(lo, hi + step_s / 2, step_s)
    ss = _scan(t_gyro, _integrated_rate(t_gyro, gyro), tp, phi, tp[:, 1] - tp[:, 0], taus)
    return float(taus[int(np.argmin(ss))])


def calibrate_camera_imu(t_gyro, gyro, t_pairs, cam_rotvec, R_declared: np.ndarray | None = None,
                         max_offset_s: float = 0.25, step_s: float = 0.002, bootstrap: int = 200,
                         rng: np.random.Generator | None = None, center_s: float = 0.0) -> CameraImuCalibration:
    """Steps 1-3 of the module docstring, offsets searched in ``center_s ± max_offset_s``. ``R_declared``: the
    camera -> IMU rotation the recording declares (its error is reported)."""
    rng = rng if rng is not None else np.random.default_rng(0)
    t_gyro, gyro = np.asarray(t_gyro, float), np.asarray(gyro, float)
    phi_all = np.asarray(cam_rotvec, float)
    ok = np.all(np.isfinite(phi_all), axis=1)
    tp, phi = np.asarray(t_pairs, float)[ok], phi_all[ok]
    inside = (tp[:, 0] + center_s - max_offset_s >= t_gyro[0]) & (tp[:, 1] + center_s + max_offset_s <= t_gyro[-1])
    tp, phi = tp[inside], phi[inside]
    if len(tp) < 10:
        raise ValueError(f"{len(tp)} frame intervals with a camera rotation inside the gyro's span; at least 10 "
                         "are needed")
    dt = tp[:, 1] - tp[:, 0]
    # step 1: every candidate offset with its own hand-eye fit (R and b free: no rotation assumed)
    taus = center_s + np.arange(-max_offset_s, max_offset_s + step_s / 2, step_s)
    ss = _scan(t_gyro, _integrated_rate(t_gyro, gyro), tp, phi, dt, taus)
    tau = float(_peak(taus, -ss[None, :])[0])
    R, b = hand_eye_rotation(phi, gyro_rotvecs(t_gyro, gyro, tp, tau), dt)
    # the magnitudes' correlation (the gyro bias removed): how well the rotation rates agree, rotation-free
    coarse = estimate_offset(t_gyro, gyro - b, tp + center_s, np.linalg.norm(phi, axis=1), max_offset_s, step_s,
                             bootstrap, rng)
    coarse = TimeOffset(coarse.offset_s + center_s, coarse.sigma_s, coarse.peak, coarse.intervals,
                        coarse.taus + center_s, coarse.rho)
    half = max(4 * step_s, 0.01)
    sig = float("nan")
    for _ in range(2):  # step 3: the offset refined at the fitted R, b; sigma by bootstrap of the intervals
        taus_f = np.arange(tau - half, tau + half + step_s / 4, step_s / 4)
        W = np.vstack([np.ones(len(tp)), _bootstrap_weights(len(tp), bootstrap, rng)])
        peaks = _peak(taus_f, -_residual_ss(t_gyro, gyro, tp, phi, R, b, taus_f, W))
        tau, sig = float(peaks[0]), float(np.std(peaks[1:]))
        R, b = hand_eye_rotation(phi, gyro_rotvecs(t_gyro, gyro, tp, tau), dt)
    psi = gyro_rotvecs(t_gyro, gyro, tp, tau)
    R, b = hand_eye_rotation(phi, psi, dt)
    res = psi - phi @ R.T - b * dt[:, None]
    angles = []
    for w in _bootstrap_weights(len(tp), bootstrap, rng):
        Rb, _ = hand_eye_rotation(phi, psi, dt, w, iters=4)
        angles.append(rotation_angle_deg(Rb @ R.T))
    err = rotation_angle_deg(R @ np.asarray(R_declared, float).T) if R_declared is not None else None
    exc = np.degrees(np.sqrt(np.mean((phi @ R.T) ** 2, axis=0)))
    return CameraImuCalibration(tau, sig, coarse, R, float(np.sqrt(np.mean(np.square(angles)))), b,
                                float(np.degrees(np.sqrt(np.mean((res**2).sum(1))))), exc, int(len(tp)), err,
                                taus=taus, residual_ss=ss)
