"""AHRS mode of the error-state filter: attitude from a raw IMU (+ magnetometer), no position aid.

Choice (issue #5 item 2): the same ``ErrorStateKF`` (15 states: gyro biases estimated) propagates
the raw IMU through the strapdown mechanization of eq. A.1; its roll/pitch aid is the gravity
vector (``update_gravity``): the accelerometer mean over ``window`` samples is used as a
measurement of ``C^T(-g) + b_a`` (sigma: ``gravity_sigma`` for unmodelled accelerations and the
white noise left in the mean) only while the vehicle is not accelerating, judged on the window
means: ``| |f| - g | < accel_tol`` and ``|w| < rate_tol``; its yaw aid is the
tilt-compensated magnetometer heading (``update_magnetometer``) with the declination given.
There is no velocity or position aid; ``earth_rotation`` is off (the Earth rate, 7e-5 rad/s, is
absorbed by the gyro bias states), so the drifting free-inertial velocity cannot feed back into
the attitude through the transport rate. Initial roll/pitch from the first ``init_s`` seconds of
accelerometer data, initial yaw from the magnetometer (0 without one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from visnav.estimation.eskf import EskfConfig, ErrorStateKF, heading_from_mag
from visnav.estimation.ins import NavState, euler_to_quat
from visnav.geometry.rotations import wrap_angle
from visnav.measurements import ImuSample

__all__ = ["AhrsConfig", "run_ahrs", "attitude_differences"]


@dataclass(frozen=True)
class AhrsConfig:
    accel_noise: float = 0.1  # [m/s^2/sqrt(Hz)]
    gyro_noise: float = 2e-3  # [rad/s/sqrt(Hz)]
    accel_bias_noise: float = 1e-3
    gyro_bias_noise: float = 5e-5
    window: int = 10  # IMU samples per gravity update
    gravity_sigma_mps2: float = 0.3  # gravity pseudo-measurement noise (vibration, small accel.)
    accel_tol_mps2: float = 0.5  # 'not accelerating' test on | |f| - g |
    rate_tol_radps: float = 0.5
    mag_sigma_deg: float = 3.0
    declination_deg: float = 0.0
    init_s: float = 0.5
    gravity_mps2: float = 9.80665


def _initial_euler(accel: np.ndarray, mag: np.ndarray | None, decl: float) -> np.ndarray:
    f = accel.mean(axis=0)
    roll = math.atan2(-f[1], -f[2])
    pitch = math.atan2(f[0], math.hypot(f[1], f[2]))
    yaw = heading_from_mag(mag, roll, pitch, decl) if mag is not None else 0.0
    return np.array([roll, pitch, yaw])


def run_ahrs(t, accel, gyro, mag_t=None, mag=None, cfg: AhrsConfig | None = None) -> dict:
    """Run the AHRS over IMU arrays (N,), (N,3), (N,3) and optional magnetometer (K,), (K,3).

    Returns ``t``, ``euler`` (N,3) [rad], ``sigma`` (N,3) attitude 1-sigma [rad], ``gyro_bias``
    (final, [rad/s]), ``stats`` (accepted / rejected per update kind), ``rejected_samples``.
    """
    cfg = cfg or AhrsConfig()
    t = np.asarray(t, dtype=float)
    accel = np.asarray(accel, dtype=float)
    gyro = np.asarray(gyro, dtype=float)
    if len(t) < cfg.window + 2:
        raise ValueError(f"AHRS needs at least {cfg.window + 2} IMU samples, got {len(t)}")
    decl = math.radians(cfg.declination_deg)
    has_mag = mag is not None and len(mag) > 0
    if has_mag:
        mag_t = np.asarray(mag_t, dtype=float)
        mag = np.asarray(mag, dtype=float)
    init = t <= t[0] + cfg.init_s
    e0 = _initial_euler(accel[init], mag[0] if has_mag else None, decl)
    kcfg = EskfConfig(accel_noise=cfg.accel_noise, gyro_noise=cfg.gyro_noise,
                      accel_bias_noise=cfg.accel_bias_noise, gyro_bias_noise=cfg.gyro_bias_noise,
                      gyro_bias=True, earth_rotation=False, gravity_mps2=cfg.gravity_mps2)
    P0 = np.r_[[1.0] * 3, [1.0] * 3, [math.radians(3.0)] * 2, [math.radians(10.0 if has_mag else 1.0)],
               [0.1] * 3, [math.radians(0.5)] * 3]
    kf = ErrorStateKF(NavState(float(t[0]), quat=euler_to_quat(e0)), P0, kcfg)
    n = len(t)
    euler = np.empty((n, 3))
    sigma = np.empty((n, 3))
    g = cfg.gravity_mps2
    rate = np.linalg.norm(gyro, axis=1)
    j = 0  # next magnetometer sample
    msig = math.radians(cfg.mag_sigma_deg)
    for k in range(n):
        kf.predict(ImuSample(t[k], accel[k], gyro[k]))
        if k >= cfg.window and k % cfg.window == 0:
            sl = slice(k - cfg.window + 1, k + 1)
            f_mean = accel[sl].mean(axis=0)
            if abs(float(np.linalg.norm(f_mean)) - g) < cfg.accel_tol_mps2 and rate[sl].mean() < cfg.rate_tol_radps:
                # measurement noise: unmodelled accelerations + the white noise left in the mean
                var_white = cfg.accel_noise**2 / max(float(t[k] - t[k - cfg.window]), 1e-9)
                kf.update_gravity(f_mean, math.sqrt(cfg.gravity_sigma_mps2**2 + var_white))
        if has_mag:
            while j < len(mag_t) and mag_t[j] <= t[k]:
                if np.all(np.isfinite(mag[j])):
                    kf.update_magnetometer(mag[j], msig, decl)
                j += 1
        euler[k] = kf.x.euler
        sigma[k] = kf.attitude_sigma
    return {"t": t, "euler": euler, "sigma": sigma, "gyro_bias": kf.x.gyro_bias.copy(),
            "accel_bias": kf.x.accel_bias.copy(),
            "stats": {k: (v.accepted, v.rejected) for k, v in kf.stats.items()},
            "rejected_samples": kf.rejected_samples}


def attitude_differences(t, euler, t_ref, euler_ref) -> dict:
    """Ours minus the reference at the reference instants inside our time span (ours interpolated
    linearly, yaw unwrapped first): per-axis differences [rad] and RMS [deg]."""
    t = np.asarray(t, dtype=float)
    t_ref = np.asarray(t_ref, dtype=float)
    inside = (t_ref >= t[0]) & (t_ref <= t[-1])
    if inside.sum() < 2:
        raise ValueError("reference attitude does not overlap the IMU time span")
    tr = t_ref[inside]
    e = np.asarray(euler, dtype=float).copy()
    e[:, 2] = np.unwrap(e[:, 2])
    ours = np.column_stack([np.interp(tr, t, e[:, i]) for i in range(3)])
    diff = wrap_angle(ours - np.asarray(euler_ref, dtype=float)[inside])
    rms = np.degrees(np.sqrt(np.mean(diff**2, axis=0)))
    return {"t": tr, "diff": diff, "roll_rms_diff_deg": float(rms[0]), "pitch_rms_diff_deg": float(rms[1]),
            "yaw_rms_diff_deg": float(rms[2])}
