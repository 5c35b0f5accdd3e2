"""The relative deck model of seed 003 (Holmes 2017), written for batches of sigma points.

State (12), everything in the vehicle (helicopter) body frame h, FRD:

    x = [ r_d/h (3),  e = (phi, theta, psi) (3),  v = dr/dt seen from h (3),  w_d = (p_d, q_d, r_d) (3) ]

* ``r``: position of the deck origin relative to the vehicle, h components (eq. 2.2);
* ``e``: the 3-2-1 Euler angles of T_h T_d^T, the rotation from the deck to the vehicle frame
  (eq. 2.8-2.12). In this package's convention ``euler_to_dcm(e) = C_h^d`` (vehicle -> deck) and
  ``C_d^h = T_h T_d^T = euler_to_dcm(e)^T``;
* ``v``: the derivative of r as seen from the rotating vehicle frame (eq. 2.5-2.6);
* ``w_d``: the deck's own body rates, deck frame (the [p_d q_d r_d] of eq. 2.14), modelled constant.

Optionally augmented (issue 30, not in the thesis) by ``b_a`` (3): the accelerometer's bias, body frame, a
random walk; the prediction then takes ``z_acc - b_a`` for the specific force. States 0-11 are the thesis'.
After them may come the calibration's "consider" parameters (``ConsiderLayout``, Schmidt-Kalman: constant,
their uncertainty carried and correlated with the states, never corrected): each light's survey error
``db_i`` (deck frame), the camera's misalignment ``dth`` (a small rotation of its axes, T_cam,true = R(dth) T_cam)
and its intrinsics' errors (focal factor ``eps``, principal point ``dc`` / f). With them the predicted light is

    s_i = R(dth) T_cam (r + C_d^h (b_i + db_i) - rho),   bearings = atan((1 + eps) s_xy / s_z + dc)

Prediction (eq. 3.1-3.5): zero deck acceleration, vehicle acceleration from the IMU,
``a_h = z_acc + T_g g`` (eq. 3.4 with the accelerometer's specific force convention), the angular
acceleration of the vehicle from the numerical derivative of the gyro rates:

    dv/dt = -a_h - dw/dt x r - 2 w x v - w x (w x r)                      (eq. 3.5)
    de/dt = E(e) (w - C_d^h w_d)                                           (eq. 3.2 / 2.14)

Measurements of light i at b_i (deck frame), camera at rho with rotation T_cam (body -> camera):

    s_i = T_cam (r + C_d^h b_i - rho)                                      (eq. 2.26)
    ds_i/dt = T_cam (v - Omega C_d^h b_i),  Omega = skew(w - C_d^h w_d)   (eq. 2.28-2.29)
    bearings = (atan(s_x/s_z), atan(s_y/s_z)),  rates = eq. 2.27

The thesis' camera axes are (x optical axis, y right, z down); ours are OpenCV's (x right, y down,
z optical axis), so its (s_x, s_y, s_z) is our (s_z, s_x, s_y). Eq. 2.28 as printed adds
``w_h x r`` to dr/dt: that is the inertial derivative; the camera turns with the vehicle and sees
the rotating-frame derivative, which is the state v itself, so the term is not added here
(checked against finite differences of eq. 2.26 in the tests).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np
from scipy.optimize import minimize_scalar

from visnav.geometry.rotations import (cross, euler_rate_matrix, euler_to_dcm, euler_to_dcm3, euler_to_dcm_and_rate_matrix,
                                       skew, wrap_angle)

N_STATE = 12
POS, ATT, VEL, RATE = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
BIAS = slice(12, 15)  # the accelerometer-bias augmentation (issue 30)
N_AUGMENTED = 15

# name -> (amplitude [m, m, m, rad, rad, rad], omega [rad/s], sigma_amplitude, sigma_omega)
SEA_STATES: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {
    "calm": (np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6)),
    # the lab Stewart platform (Fig. 5.5 style: a few cm, a few degrees, periods of 5-10 s)
    "stewart": (np.array([0.04, 0.04, 0.04, np.radians(6), np.radians(6), np.radians(3)]),
                np.array([0.7, 0.8, 1.0, 0.9, 0.7, 0.5]),
                np.array([0.01, 0.01, 0.01, np.radians(1), np.radians(1), np.radians(0.5)]),
                np.array([0.1, 0.1, 0.1, 0.1, 0.1, 0.05])),
    # a frigate in sea state 4 (full scale, for the process-noise sizing of eq. 3.7)
    "ship_ss4": (np.array([0.5, 0.4, 0.8, np.radians(5), np.radians(2), np.radians(1)]),
                 np.array([0.5, 0.5, 0.6, 0.5, 0.6, 0.4]),
                 np.array([0.1, 0.1, 0.2, np.radians(1), np.radians(0.5), np.radians(0.3)]),
                 np.array([0.05, 0.05, 0.05, 0.05, 0.05, 0.05])),
}


def ship_process_noise(sea_state: str, motion_scale: float = 1.0, accel_scale: float = 1.0,
                       dt: float = 0.01) -> np.ndarray:
    """Per-step variances (6,) of the deck's linear and angular accelerations for the filter's Q (eq. 3.7-3.8).

    The eq. 3.7 bound of the sea state ``sea_state`` (its amplitudes times ``motion_scale``) times
    ``accel_scale``, as white accelerations over the correlation time ``1 / omega`` discretised at
    ``dt``: ``bound^2 / (omega dt)``, floored at 1e-4 (calm: no deck motion).
    """
    if sea_state not in SEA_STATES:
        raise ValueError(f"unknown sea state {sea_state!r}; known: {', '.join(SEA_STATES)}")
    A, W, sA, sW = SEA_STATES[sea_state]
    bound = ship_acceleration_bound(A * motion_scale, W, sA * motion_scale, sW) * accel_scale
    return _white_acceleration_var(bound, W, dt)


def _white_acceleration_var(bound: np.ndarray, omega: np.ndarray, dt: float) -> np.ndarray:
    """Per-step variances of accelerations bounded by ``bound``, white over the correlation time 1 / ``omega``,
    discretised at ``dt``: bound^2 / (omega dt), floored at 1e-4 (calm: no deck motion)."""
    var = np.where(omega > 0, bound**2 / np.maximum(omega, 1e-6) / dt, 0.0)
    return np.maximum(var, 1e-4)


def ship_oscillator(sea_state: str, motion_scale: float = 1.0, accel_scale: float = 1.0,
                    dt: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """The deck's roll and pitch as oscillators about level (``process_model``'s ``deck_omega2``): their nominal
    frequencies squared (3,; yaw 0: it keeps the constant rate) and the per-step variances (3,) of the angular
    accelerations the oscillator leaves out, sized as eq. 3.7 sizes the whole: the frequency's +3 sigma bound, the
    restoring term's error ((w + 3 sigma_w)^2 - w^2) (A + 3 sigma_A), as white accelerations over 1 / w (yaw: eq.
    3.7's own bound), times ``accel_scale`` as ``ship_process_noise``'s."""
    A, W, sA, sW = SEA_STATES[sea_state]
    a, w, sa, sw = A[3:6] * motion_scale, W[3:6], sA[3:6] * motion_scale, sW[3:6]
    bound = ship_acceleration_bound(a, w, sa, sw)
    bound[:2] = ((w[:2] + 3.0 * sw[:2]) ** 2 - w[:2] ** 2) * (a[:2] + 3.0 * sa[:2])
    return np.r_[w[:2] ** 2, 0.0], _white_acceleration_var(bound * accel_scale, w, dt)


def deck_prior_variance(sea_state: str, motion_scale: float = 1.0, attitude_noise_deg: float = 0.0,
                        floor_deg: float = 1.0) -> np.ndarray:
    """Prior variances (5,) of the relative roll and pitch of a level-mean deck and of the deck's three body
    rates, from the sea state (eq. 3.14-3.15: A^2/2 and A^2 w^2/2, with the eq. 3.7 amplitude and frequency
    bounds A + 3 sigma_A, w + 3 sigma_w, times ``motion_scale``), the roll/pitch adding the autopilot's
    attitude noise. Floored at ``floor_deg`` (deg, deg/s): a calm deck still has a mounting tolerance.

    What the filter falls back to for the deck's attitude after an outage (``DeckNavigator``): the deck
    oscillates about level, so after a few seconds without a frame its attitude is known no better than
    its sea state says, while the constant-rate model would extrapolate the last rates without bound.
    """
    if sea_state not in SEA_STATES:
        raise ValueError(f"unknown sea state {sea_state!r}; known: {', '.join(SEA_STATES)}")
    A, W, sA, sW = SEA_STATES[sea_state]
    a = (A[3:6] + 3.0 * sA[3:6]) * motion_scale
    w = W[3:6] + 3.0 * sW[3:6]
    cov = np.diag(initial_covariance_sea_state(np.zeros(3), np.zeros(3), a, w))
    att, rate = cov[3:5] + np.radians(attitude_noise_deg) ** 2, cov[9:12]
    return np.maximum(np.r_[att, rate], np.radians(floor_deg) ** 2)


def sea_state_level_sigma(sea_state: str, motion_scale: float, attitude_noise_deg: float,
                          frame_interval_s: float) -> float:
    """The sigma per frame [rad] of the level pseudo-measurement over a moving deck (``DeckNavigator._level``): the
    deck oscillates about level with the tilt sigma of ``deck_prior_variance`` per axis, and its tilt stays
    correlated over 1 / w (w the sea state's slower roll / pitch frequency bound, as the prior's); fused on every
    frame, the N = 1 / (w dt) frames of one correlation time together say what one look at that tilt says:
    sigma sqrt(N). The Stewart preset at 30 frames/s: 6.4 deg x sqrt(30) = 35 deg."""
    var = deck_prior_variance(sea_state, motion_scale, attitude_noise_deg)
    _, W, _, sW = SEA_STATES[sea_state]
    w = float(np.min(W[3:5] + 3.0 * sW[3:5]))
    n = 1.0 / (w * frame_interval_s) if w > 0.0 and frame_interval_s > 0.0 else 1.0
    return float(np.sqrt(max(var[0], var[1]) * max(n, 1.0)))


def camera_rotation(depression: float, yaw: float) -> np.ndarray:
    """T_cam: body FRD -> OpenCV camera axes for an optical axis ``depression`` below x, turned by ``yaw``."""
    zc = np.array([np.cos(depression) * np.cos(yaw), np.cos(depression) * np.sin(yaw), np.sin(depression)])
    xc = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    return np.vstack([xc, np.cross(zc, xc), zc])


def euler_dcm_batch(e: np.ndarray, rate: bool = False):
    """C_h^d = euler_to_dcm(e) (eq. 2.8-2.12) for a batch (N, 3) -> (N, 3, 3); with ``rate`` also E(e) of
    eq. 2.13: ``(C, E)`` (geometry.rotations, the one rotation module)."""
    return euler_to_dcm_and_rate_matrix(e) if rate else euler_to_dcm(e)


@dataclass(frozen=True)
class ImuInput:
    """What drives one prediction: specific force and rates (body), their rate derivative, and
    gravity in the body frame from the autopilot's roll and pitch (the T_g g of eq. 3.4)."""

    accel: np.ndarray
    gyro: np.ndarray
    gyro_dot: np.ndarray
    gravity_body: np.ndarray


def process_model(sig: np.ndarray, dt: float, u: ImuInput, bias: bool | None = None,
                  deck_omega2: np.ndarray | None = None) -> np.ndarray:
    """Discrete eq. 3.1-3.5 for a batch of states (N, 12) or (N, 15) (with the accelerometer bias b_a, a random
    walk: kept): one explicit step of length ``dt``, every sigma point in one array expression (row vectors:
    ``x @ M.T`` is ``M x`` for each row). ``bias``: states 12-14 are the bias (None: when there are 15 states);
    any further states (consider parameters) are constant. ``deck_omega2`` (3,): the deck's roll and pitch as
    oscillators about level (the second-order ship of ch. 2 that the thesis' filter leaves out):
    dp_d/dt = -Omega_x^2 phi_d, dq_d/dt = -Omega_y^2 theta_d, the deck's tilt from gravity seen in the deck frame
    (C_h^d T_g g, the autopilot's roll and pitch); None: constant rates (eq. 3.1)."""
    r, e, v, wd = sig[:, POS], sig[:, ATT], sig[:, VEL], sig[:, RATE]
    W, Wdot = skew(u.gyro), skew(u.gyro_dot)
    aug = sig.shape[1] == N_AUGMENTED if bias is None else bias
    # the vehicle's inertial acceleration, h components (eq. 3.4), the bias estimate taken off the reading
    a_h = (u.accel - sig[:, BIAS] if aug else u.accel) + u.gravity_body
    vdot = -a_h - r @ (Wdot + W @ W).T - 2.0 * v @ W.T  # eq. 3.5: -a_h - wdot x r - w x (w x r) - 2 w x v
    C, E = euler_dcm_batch(e, rate=True)  # C_h^d, E(e)
    w_rel = u.gyro - np.einsum("nji,nj->ni", C, wd)  # w_h - C_d^h w_d (eq. 2.14)
    edot = np.einsum("nij,nj->ni", E, w_rel)  # eq. 3.2
    wd_next = wd
    if deck_omega2 is not None:
        g_d = np.einsum("nij,j->ni", C, u.gravity_body)  # gravity in the deck frame
        tilt = np.stack([np.arctan2(g_d[:, 1], g_d[:, 2]),
                         np.arctan2(-g_d[:, 0], np.hypot(g_d[:, 1], g_d[:, 2])), np.zeros(len(sig))], axis=1)
        wd_next = wd - dt * tilt * deck_omega2
    parts = [r + v * dt + 0.5 * vdot * dt * dt, e + edot * dt, v + vdot * dt, wd_next]
    return np.concatenate(parts + [sig[:, N_STATE:]] if sig.shape[1] > N_STATE else parts, axis=1)


def ship_acceleration_bound(amplitude, omega, sigma_amplitude=0.0, sigma_omega=0.0) -> np.ndarray:
    """Peak acceleration of a sinusoid of uncertain amplitude and frequency, eq. 3.7."""
    a = np.asarray(amplitude, float) + 3.0 * np.asarray(sigma_amplitude, float)
    w = np.asarray(omega, float) + 3.0 * np.asarray(sigma_omega, float)
    return a * w * w


_I3 = np.eye(3)


def process_noise(x: np.ndarray, dt: float, u: ImuInput, imu_cov: np.ndarray, ship_cov: np.ndarray) -> np.ndarray:
    """Q = F_z Sigma_imu F_z^T + F_ship Sigma_ship F_ship^T (eq. 3.8) at the mean ``x``.

    ``F_z`` is the Jacobian of one step of eq. 3.5/3.2 with respect to the accelerometer and gyro
    readings (6), ``F_ship`` the one with respect to the deck's linear (deck frame) and angular
    accelerations (6) that the zero-acceleration model leaves out. ``imu_cov`` (6, 6) is the
    per-sample covariance of (accel, gyro); ``ship_cov`` (6, 6) that of the deck accelerations.
    The numerical derivative of the rates is not differentiated: its noise telescopes over steps.
    """
    r, e, v, w = x[POS], x[ATT], x[VEL], u.gyro
    C, E = euler_to_dcm(e), euler_rate_matrix(e)  # C_h^d, E(e) (eq. 2.13)
    # d vdot / d w of eq. 3.5: -2 w x v gives 2 [v]x, -w x (w x r) = -(w (w.r) - r (w.w)) gives 2 r w^T - (w.r) I - w r^T
    dvdw = 2.0 * skew(v) + 2.0 * r[:, None] * w - np.dot(w, r) * _I3 - w[:, None] * r
    dt2 = 0.5 * dt * dt
    Fz = np.zeros((N_STATE, 6))  # columns: accelerometer (3), gyro (3)
    Fz[POS, :3], Fz[POS, 3:] = -dt2 * _I3, dt2 * dvdw
    Fz[ATT, 3:] = dt * E
    Fz[VEL, :3], Fz[VEL, 3:] = -dt * _I3, dt * dvdw
    Fs = np.zeros((N_STATE, 6))  # columns: deck linear acceleration (deck frame, 3), deck angular acceleration (3)
    Fs[POS, :3] = dt2 * C.T
    Fs[ATT, 3:] = -dt2 * E @ C.T
    Fs[VEL, :3] = dt * C.T
    Fs[RATE, 3:] = dt * _I3
    return Fz @ imu_cov @ Fz.T + Fs @ ship_cov @ Fs.T


@dataclass(frozen=True)
class ConsiderLayout:
    """Where the calibration's consider parameters sit in the state: from ``start``, the survey errors of the
    ``n_lights`` lights (3 each, deck frame, m), the camera misalignment (3, rad, camera axes), the focal factor's
    error (1), the principal point's error over the focal length (2) and the camera's time offset (1, s: a frame
    shows the scene this long before its stamp, its bearings are those of then: b(t - tau) = b(t) - tau db/dt)."""

    start: int
    n_lights: int

    @property
    def lights(self) -> slice:
        return slice(self.start, self.start + 3 * self.n_lights)

    @property
    def misalignment(self) -> slice:
        k = self.start + 3 * self.n_lights
        return slice(k, k + 3)

    @property
    def focal(self) -> int:
        return self.start + 3 * self.n_lights + 3

    @property
    def principal_point(self) -> slice:
        k = self.start + 3 * self.n_lights + 4
        return slice(k, k + 2)

    @property
    def time_offset(self) -> int:
        return self.start + 3 * self.n_lights + 6

    @property
    def size(self) -> int:
        return 3 * self.n_lights + 7


@dataclass(frozen=True)
class CameraGeometry:
    """Camera pose in the vehicle frame: position ``rho`` (FRD, m) and rotation body -> camera; with ``consider``
    the states carry the calibration's errors (the measurement functions take them from each sigma point)."""

    rho: np.ndarray
    T_cam: np.ndarray  # 3x3, OpenCV camera axes
    consider: ConsiderLayout | None = None


def light_vectors(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry):
    """s_i (eq. 2.26) in camera axes (N, L, 3), the lights C_d^h b_i (N, L, 3) and C_h^d (N, 3, 3) for
    every state and light (the rates of eq. 2.28 are formed from these in ``bearings_and_rates``). With consider
    parameters: the lights b_i + db_i and s_i turned by the misalignment (small angle: s + dth x s)."""
    r, e = sig[:, POS], sig[:, ATT]
    C = euler_dcm_batch(e)  # C_h^d
    k = cam.consider
    if k is None:
        b_h = np.einsum("nji,lj->nli", C, lights)  # C_d^h b_i
    else:
        b = lights[None, :, :] + sig[:, k.lights].reshape(len(sig), k.n_lights, 3)
        b_h = np.einsum("nji,nlj->nli", C, b)  # C_d^h (b_i + db_i)
    p = r[:, None, :] + b_h - cam.rho
    s = p @ cam.T_cam.T
    if k is not None:
        s = s + cross(sig[:, None, k.misalignment], s)  # R(dth) s
    return s, b_h, C


def _intrinsics(sig: np.ndarray, cam: CameraGeometry):
    """(1 + eps) (N, 1, 1) and dc / f (N, 1, 2) of each sigma point; None without consider parameters."""
    k = cam.consider
    if k is None:
        return None
    return 1.0 + sig[:, k.focal][:, None, None], sig[:, None, k.principal_point]


def bearings_and_rates(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry, gyro: np.ndarray, vectors=None):
    """Predicted bearings (eq. 2.25) and bearing rates (eq. 2.27) of every light: (N, L, 2) each.
    ``vectors``: ``light_vectors(sig, lights, cam)`` when the caller has it already."""
    s, b_h, C = light_vectors(sig, lights, cam) if vectors is None else vectors
    w_rel = gyro - np.einsum("nji,nj->ni", C, sig[:, RATE])  # eq. 2.29: w_h - C_d^h w_d
    sdot = (sig[:, None, VEL] - cross(w_rel[:, None, :], b_h)) @ cam.T_cam.T  # eq. 2.28
    if cam.consider is not None:
        sdot = sdot + cross(sig[:, None, cam.consider.misalignment], sdot)  # R(dth) sdot
    s_xy, s_z = s[..., :2], s[..., 2:3]  # (our camera axes: the thesis' s_x is our s_z, see the module notes)
    intr = _intrinsics(sig, cam)
    if intr is None:
        bear = np.arctan(s_xy / s_z)  # eq. 2.25
        rate = (sdot[..., :2] * s_z - s_xy * sdot[..., 2:3]) / (s_xy * s_xy + s_z * s_z)  # eq. 2.27: d/dt atan(s_xy/s_z)
        return bear, rate
    f, dc = intr
    u = f * s_xy / s_z + dc  # the normalised image coordinate the nominal intrinsics give
    udot = f * (sdot[..., :2] * s_z - s_xy * sdot[..., 2:3]) / (s_z * s_z)
    rate = udot / (1.0 + u * u)  # eq. 2.27 through the intrinsics' errors
    return np.arctan(u) - sig[:, cam.consider.time_offset][:, None, None] * rate, rate  # eq. 2.25 at t - tau


def measurement_model(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry, gyro: np.ndarray,
                      idx: np.ndarray, rate_idx: np.ndarray, vectors=None, rates_at=None) -> np.ndarray:
    """Stacked measurement (eq. 3.10): bearings of lights ``idx``, then rates of lights ``rate_idx``
    (``vectors``: ``light_vectors(sig, lights, cam)`` when the caller has it already). ``rates_at``: the states
    the rates are seen at, from the sigma points (``sig -> sig'``), when not the bearings' own: a tracker's
    rates are backward differences over the frame interval, the rates of its midpoint (``DeckNavigator``), with
    ``gyro`` the vehicle's rate there."""
    if rates_at is not None and np.size(rate_idx) and cam.consider is None:
        # (the frame's bearings alone: its rates would be thrown away; the consider model's time offset needs them)
        bear = bearings_only(sig, lights, cam, vectors).reshape(len(sig), -1, 2)
        rate = bearings_and_rates(rates_at(sig), lights, cam, gyro)[1]
    else:
        bear, rate = bearings_and_rates(sig, lights, cam, gyro, vectors)
        if rates_at is not None and np.size(rate_idx):
            rate = bearings_and_rates(rates_at(sig), lights, cam, gyro)[1]
    return np.concatenate([bear[:, idx, :].reshape(len(sig), -1), rate[:, rate_idx, :].reshape(len(sig), -1)], axis=1)


def bearings_only(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry, vectors=None) -> np.ndarray:
    """Bearings of every light (N, 2L), for data association (``vectors`` as ``measurement_model``)."""
    s, _, _ = light_vectors(sig, lights, cam) if vectors is None else vectors
    intr = _intrinsics(sig, cam)
    u = s[..., :2] / s[..., 2:3] if intr is None else intr[0] * s[..., :2] / s[..., 2:3] + intr[1]
    return np.arctan(u).reshape(len(sig), -1)  # eq. 2.25


def survey_pose_covariance(x: np.ndarray, lights: np.ndarray, cam: CameraGeometry, idx: np.ndarray,
                           sigma_survey: float, step: float = 1e-6) -> np.ndarray | None:
    """The error in the pose (r, e) that a constant survey error of ``sigma_survey`` per axis of each light
    ``idx`` leaves in a least-squares fit of their bearings: the consider covariance of the fit, linearised at the
    state ``x`` (eq. 2.25-2.26),

        Sigma = sigma_s^2 A G G^T A^T,   A = (H^T H)^-1 H^T,   H = dz / d(r, e),   G = dz / db,

    where a light moved by db_i moves its bearings as the deck moved by C_d^h db_i, so dz_i/db_i = (dz_i/dr) C_d^h
    and, the survey isotropic, G G^T = blockdiag((dz_i/dr) (dz_i/dr)^T). It depends on where the lights are seen
    from: at 1.4 m, 45 deg down, the 1 cm survey of eq. 5.10's layout tilts the fit by 6 deg per axis (least-squares
    fits over 300 draws: the same), where the plane through the lights (sqrt(2 / S) sigma_s) gives 4 deg; at moving
    seed 7's approach poses (1.0-1.3 m, the vehicle pitched) 9-29 deg (the fits: 10-17). H by central differences.
    Returns (6, 6), or None when the lights do not fix the pose (fewer than 3)."""
    idx = np.asarray(idx)
    if idx.size < 3:
        return None
    d = np.zeros((12, len(x)))
    d[np.arange(6), np.arange(6)] = step
    d[6 + np.arange(6), np.arange(6)] = -step
    z = bearings_only(x[None] + d, np.asarray(lights, float)[idx], cam)
    H = (z[:6] - z[6:]).T / (2.0 * step)  # (2M, 6)
    M = H[:, :3].reshape(idx.size, 2, 3)  # dz_i / dr
    AT = np.linalg.solve(H.T @ H, H.T).T.reshape(idx.size, 2, 6)  # A = (H^T H)^-1 H^T, per light
    AM = np.einsum("ijk,ijl->ikl", AT, M)  # A_i (dz_i / dr): (M, 6, 3)
    return sigma_survey**2 * np.einsum("ikl,ijl->kj", AM, AM)  # sum_i A_i G_i G_i^T A_i^T


def deck_in_level(e: np.ndarray, roll: float, pitch: float) -> np.ndarray:
    """The deck's attitude in the heading-free level frame, C_d^0 = C_h^0 C_d^h (deck axes -> level axes): C_h^0
    from the autopilot's roll and pitch, C_d^h = euler_to_dcm(e)^T from the relative Euler angles (eq. 2.8-2.12).
    Its last column is the deck's z axis: acos of its third entry is the deck's tilt from level."""
    return euler_to_dcm3(float(roll), float(pitch), 0.0) @ euler_to_dcm(e).T


def position_from_bearings(bearings: np.ndarray, idx: np.ndarray, e: np.ndarray, lights: np.ndarray,
                           cam: CameraGeometry, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """The deck's position r given the relative attitude ``e``: eq. 2.25-2.26 solved for r by least squares.

    Bearing i (of light ``idx[i]``) says s_i = T_cam (r + C_d^h b_i - rho) lies along d_i = T_cam^T (tan, tan, 1)
    (eq. 2.25 inverted), so r satisfies d_i x r = -d_i x (C_d^h b_i - rho): two independent equations per light,
    linear in r (with the attitude known the range follows from the lights' spread in the image, which is what
    the UKF's fit can trade against a wrong attitude). Each equation's residual is a distance across the ray
    [m]; with a bearing sigma ``sigma`` [rad] and the light's range l_i it is weighted by 1 / (sigma l_i), the
    ranges taken from a first unweighted solve. Returns (r, its covariance (3, 3)); needs two lights or more.
    """
    b = np.asarray(bearings, float).reshape(-1, 2)
    Ct = euler_to_dcm(np.asarray(e, float)).T  # C_d^h
    q = np.asarray(lights, float)[np.asarray(idx)] @ Ct.T - cam.rho  # C_d^h b_i - rho, (M, 3)
    d = np.column_stack([np.tan(b), np.ones(len(b))]) @ cam.T_cam  # T_cam^T (tan, tan, 1), body axes
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    A = -skew(d)  # (M, 3, 3): [d]_x r = -[d]_x q  (skew(d) @ x = d x x)
    y = np.einsum("mij,mj->mi", skew(d), q)
    A, y = A.reshape(-1, 3), y.reshape(-1)
    r = np.linalg.lstsq(A, y, rcond=None)[0]
    w = np.repeat(1.0 / (sigma * np.maximum(np.linalg.norm(r + q, axis=1), 1e-3)), 3)
    N = (A * w[:, None]).T @ (A * w[:, None])
    r = np.linalg.solve(N, (A * w[:, None]).T @ (y * w))
    return r, np.linalg.inv(N)


def locate_lights(bearings: np.ndarray, e: np.ndarray, lights: np.ndarray, cam: CameraGeometry, sigma: float):
    """Which light each of M >= 3 blobs is, and the deck's position, with the relative attitude ``e`` known: every
    assignment of the blobs to distinct lights (at most 4!/(4-M)! = 24) solved by ``position_from_bearings``, the
    one whose solved position reprojects closest (eq. 2.25-2.26, the deck in front of the camera) kept.
    Returns (idx (M,), r (3,), its covariance, RMS bearing residual [rad]) or None."""
    b = np.asarray(bearings, float).reshape(-1, 2)
    if len(b) < 3 or len(b) > len(lights):
        return None
    best = None
    for perm in permutations(range(len(lights)), len(b)):
        idx = np.asarray(perm)
        r, C = position_from_bearings(b, idx, e, lights, cam, sigma)
        rms = _reprojection_rms(b, idx, r, e, lights, cam)
        if rms is None:
            continue
        if best is None or rms < best[3]:
            best = (idx, r, C, rms)
    return best


def _reprojection_rms(b: np.ndarray, idx: np.ndarray, r: np.ndarray, e: np.ndarray, lights: np.ndarray,
                      cam: CameraGeometry) -> float | None:
    """RMS of the bearings (eq. 2.25) of lights ``idx`` at (r, e) against ``b`` [rad]; None when one lies behind
    the camera."""
    x = np.zeros(N_STATE)
    x[POS], x[ATT] = r, e
    vec = light_vectors(x[None], lights[idx], cam)
    if np.any(vec[0][0, :, 2] <= 0.0):
        return None
    return float(np.sqrt(np.mean((bearings_only(x[None], lights[idx], cam, vec)[0] - b.ravel()) ** 2)))


def locate_level_deck(bearings: np.ndarray, roll: float, pitch: float, lights: np.ndarray, cam: CameraGeometry,
                      sigma: float, prior: tuple[float, float] | None = None, step_deg: float = 10.0):
    """A level deck seen from an unknown relative yaw: its relative roll and pitch are the vehicle's own (the
    level deck of ``deck_in_level``), so the lights fix (r, psi). ``locate_lights`` at every ``step_deg`` of psi;
    the candidates compared by their cost sum(residual^2) / sigma^2 (eq. 2.25, ``sigma`` per bearing component)
    plus, with a ``prior`` (psi0, sigma_psi), ((psi - psi0) / sigma_psi)^2: the maximum a posteriori yaw. The
    best is refined within one step by a bounded scalar search with its assignment kept. The prior matters
    because the layout of eq. 5.10 seen obliquely nearly repeats itself turned by 180 deg (the pair on the y axis
    moved 7 cm along x): with a 1 cm survey and 1 deg of camera misalignment one frame can fit the turned pose
    as well as the true one. Returns (psi, idx (M,), r (3,), r's covariance, RMS bearing residual [rad]) or None."""
    b = np.asarray(bearings, float).reshape(-1, 2)

    def cost(psi: float, rms: float) -> float:
        c = b.size * (rms / sigma) ** 2
        return c if prior is None else c + (wrap_angle(psi - prior[0]) / prior[1]) ** 2

    best = None
    for psi in np.radians(np.arange(-180.0, 180.0, step_deg)).tolist():
        found = locate_lights(b, np.array([roll, pitch, psi]), lights, cam, sigma)
        if found is not None:
            c = cost(psi, found[3])
            if best is None or c < best[0]:
                best = (c, psi, *found)
    if best is None:
        return None
    idx, h = best[2], np.radians(step_deg)

    def refine(psi: float) -> float:
        e = np.array([roll, pitch, psi])
        r, _ = position_from_bearings(b, idx, e, lights, cam, sigma)
        rms = _reprojection_rms(b, idx, r, e, lights, cam)
        return np.inf if rms is None else cost(psi, rms)

    res = minimize_scalar(refine, bounds=(best[1] - h, best[1] + h), method="bounded", options={"xatol": 1e-5})
    psi = wrap_angle(float(res.x) if res.success and res.fun < best[0] else best[1])
    e = np.array([roll, pitch, psi])
    r, C = position_from_bearings(b, idx, e, lights, cam, sigma)
    return psi, idx, r, C, _reprojection_rms(b, idx, r, e, lights, cam)


def wrap_state(sig: np.ndarray) -> np.ndarray:
    """Keep the relative Euler angles' roll and yaw in (-pi, pi]."""
    return _wrap_in_place(np.array(sig, dtype=float, copy=True))


def _wrap_in_place(out: np.ndarray) -> np.ndarray:
    out[..., 3:6:2] = np.mod(out[..., 3:6:2] + np.pi, 2 * np.pi) - np.pi  # indices 3 and 5, a view
    return out


def residual_x(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = a - b
    d[..., 3:6] = np.mod(d[..., 3:6] + np.pi, 2 * np.pi) - np.pi
    return d


def state_add(x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    return _wrap_in_place(np.asarray(x + dx, dtype=float))  # (wrap_state on the fresh sum: no second copy)


def initial_state_static(position=(1.0, 0.0, 1.0), sigma_pos_m: float = 0.5, sigma_att_rad: float = np.radians(20),
                         sigma_vel_mps: float = 0.05, sigma_rate_rad_s: float = np.radians(2)):
    """Initial estimate and covariance of the static-deck flights, eq. 5.12-5.17."""
    x0 = np.zeros(N_STATE)
    x0[POS] = position  # eq. 5.12: 1 m ahead of and 1 m below the vehicle
    P0 = np.diag(np.repeat([sigma_pos_m**2, sigma_att_rad**2, sigma_vel_mps**2, sigma_rate_rad_s**2], 3))
    return x0, P0


def initial_covariance_sea_state(amplitude_lin, omega_lin, amplitude_ang, omega_ang) -> np.ndarray:
    """Initial covariance from the sea state (eq. 3.14-3.15): A^2/2 and A^2 w^2/2 per axis."""
    al, wl = np.asarray(amplitude_lin, float), np.asarray(omega_lin, float)
    aa, wa = np.asarray(amplitude_ang, float), np.asarray(omega_ang, float)
    return np.diag(np.concatenate([al**2 / 2, aa**2 / 2, al**2 * wl**2 / 2, aa**2 * wa**2 / 2]))
