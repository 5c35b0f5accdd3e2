"""The relative deck model of seed 003 (Holmes 2017), written for batches of sigma points.

State (12), everything in the vehicle (helicopter) body frame h, FRD:

    x = [ r_d/h (3),  e = (phi, theta, psi) (3),  v = dr/dt seen from h (3),  w_d = (p_d, q_d, r_d) (3) ]

* ``r``: position of the deck origin relative to the vehicle, h components (eq. 2.2);
* ``e``: the 3-2-1 Euler angles of T_h T_d^T, the rotation from the deck to the vehicle frame
  (eq. 2.8-2.12). In this package's convention ``euler_to_dcm(e) = C_h^d`` (vehicle -> deck) and
  ``C_d^h = T_h T_d^T = euler_to_dcm(e)^T``;
* ``v``: the derivative of r as seen from the rotating vehicle frame (eq. 2.5-2.6);
* ``w_d``: the deck's own body rates, deck frame (the [p_d q_d r_d] of eq. 2.14), modelled constant.

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

import math
from dataclasses import dataclass

import numpy as np

from visnav.geometry.rotations import skew

N_STATE = 12
POS, ATT, VEL, RATE = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)

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
    var = np.where(W > 0, bound**2 / np.maximum(W, 1e-6) / dt, 0.0)
    return np.maximum(var, 1e-4)


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


def camera_rotation(depression: float, yaw: float) -> np.ndarray:
    """T_cam: body FRD -> OpenCV camera axes for an optical axis ``depression`` below x, turned by ``yaw``."""
    zc = np.array([np.cos(depression) * np.cos(yaw), np.cos(depression) * np.sin(yaw), np.sin(depression)])
    xc = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    return np.vstack([xc, np.cross(zc, xc), zc])


def euler_dcm_batch(e: np.ndarray, rate: bool = False):
    """``C_b^n = Rz(psi) Ry(theta) Rx(phi)`` for a batch of Euler angles (N, 3) -> (N, 3, 3); with ``rate`` also
    E(e) of eq. 2.13 (body rates -> Euler angle rates, (N, 3, 3)) from the same cos / sin values: ``(C, E)``."""
    c, s = np.cos(e), np.sin(e)  # one call each for the three angles (the batches are small)
    cf, ct, cp = c[:, 0], c[:, 1], c[:, 2]
    sf, st, sp = s[:, 0], s[:, 1], s[:, 2]
    C = np.empty((e.shape[0], 3, 3))
    stcp, stsp = st * cp, st * sp
    C[:, 0, 0] = ct * cp
    C[:, 0, 1] = sf * stcp - cf * sp
    C[:, 0, 2] = sf * sp + cf * stcp
    C[:, 1, 0] = ct * sp
    C[:, 1, 1] = cf * cp + sf * stsp
    C[:, 1, 2] = cf * stsp - sf * cp
    C[:, 2, 0] = -st
    C[:, 2, 1] = sf * ct
    C[:, 2, 2] = cf * ct
    if not rate:
        return C
    # (numpy's cos / sin of a column equal those of the whole batch, element by element: the same values the
    # separate euler_rate_matrix form took; tests/estimation/test_deck_model.py compares them)
    tt = np.tan(e[:, 1])
    E = np.zeros((e.shape[0], 3, 3))
    E[:, 0, 0] = 1.0
    E[:, 0, 1] = sf * tt
    E[:, 0, 2] = cf * tt
    E[:, 1, 1] = cf
    E[:, 1, 2] = -sf
    E[:, 2, 1] = sf / ct
    E[:, 2, 2] = cf / ct
    return C, E


def euler_rate_matrix(e: np.ndarray) -> np.ndarray:
    """E(e) of eq. 2.13 (body rates -> Euler angle rates) for a batch (N, 3) -> (N, 3, 3)."""
    return euler_dcm_batch(e, rate=True)[1]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b along the last axis with broadcasting (numpy's cross is slow for small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


@dataclass(frozen=True)
class ImuInput:
    """What drives one prediction: specific force and rates (body), their rate derivative, and
    gravity in the body frame from the autopilot's roll and pitch (the T_g g of eq. 3.4)."""

    accel: np.ndarray
    gyro: np.ndarray
    gyro_dot: np.ndarray
    gravity_body: np.ndarray


def process_model(sig: np.ndarray, dt: float, u: ImuInput) -> np.ndarray:
    """Discrete eq. 3.1-3.5 for a batch of states (N, 12): one explicit step of length ``dt``."""
    r, e, v, wd = sig[:, POS], sig[:, ATT], sig[:, VEL], sig[:, RATE]
    w, wdot = u.gyro, u.gyro_dot
    a_h = u.accel + u.gravity_body  # vehicle's inertial acceleration, h components (eq. 3.4)
    # eq. 3.5: -a_h - wdot x r - 2 w x v - w x (w x r), the rate terms as two 3x3 products for the batch
    Sw = skew(w)
    vdot = -a_h - r @ (skew(wdot) + Sw @ Sw).T - v @ (2.0 * Sw).T
    C, E = euler_dcm_batch(e, rate=True)  # C_h^d, E(e)
    w_rel = w - np.einsum("nji,nj->ni", C, wd)  # w_h - C_d^h w_d (eq. 2.14)
    edot = np.einsum("nij,nj->ni", E, w_rel)
    out = np.empty_like(sig)
    out[:, POS] = r + v * dt + 0.5 * vdot * dt * dt
    out[:, ATT] = e + edot * dt
    out[:, VEL] = v + vdot * dt
    out[:, RATE] = wd
    return out


def ship_acceleration_bound(amplitude, omega, sigma_amplitude=0.0, sigma_omega=0.0) -> np.ndarray:
    """Peak acceleration of a sinusoid of uncertain amplitude and frequency, eq. 3.7."""
    a = np.asarray(amplitude, float) + 3.0 * np.asarray(sigma_amplitude, float)
    w = np.asarray(omega, float) + 3.0 * np.asarray(sigma_omega, float)
    return a * w * w


_I3 = np.eye(3)
_I3.flags.writeable = False
_NOISE_TEMPLATES: dict[float, tuple[np.ndarray, np.ndarray]] = {}


def _noise_templates(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Fresh F_z, F_ship of ``process_noise`` with the blocks that depend on ``dt`` alone filled in (copies
    of templates kept for the last few step lengths)."""
    t = _NOISE_TEMPLATES.get(dt)
    if t is None:
        if len(_NOISE_TEMPLATES) >= 16:
            _NOISE_TEMPLATES.clear()
        dt2 = 0.5 * dt * dt
        Fz = np.zeros((N_STATE, 6))
        Fz[POS, 0:3] = -dt2 * _I3
        Fz[VEL, 0:3] = -dt * _I3
        Fs = np.zeros((N_STATE, 6))
        Fs[RATE, 3:6] = dt * _I3
        t = _NOISE_TEMPLATES[dt] = (Fz, Fs)
    return t[0].copy(), t[1].copy()


def process_noise(x: np.ndarray, dt: float, u: ImuInput, imu_cov: np.ndarray, ship_cov: np.ndarray) -> np.ndarray:
    """Q = F_z Sigma_imu F_z^T + F_ship Sigma_ship F_ship^T (eq. 3.8) at the mean ``x``.

    ``F_z`` is the Jacobian of one step of eq. 3.5/3.2 with respect to the accelerometer and gyro
    readings (6), ``F_ship`` the one with respect to the deck's linear (deck frame) and angular
    accelerations (6) that the zero-acceleration model leaves out. ``imu_cov`` (6, 6) is the
    per-sample covariance of (accel, gyro); ``ship_cov`` (6, 6) that of the deck accelerations.
    The numerical derivative of the rates is not differentiated: its noise telescopes over steps.
    """
    # Written out in Python floats for speed (one state, not a batch): every entry is the same IEEE operation on
    # the same numbers as the array form it replaces (kept in tests/estimation/test_deck_model.py, compared bit
    # for bit). numpy's cos / sin equal math's (libm), its tan is kept; the dot product and the matmuls (BLAS)
    # are kept as they were.
    r0, r1, r2, ef, et, ep, v0, v1, v2 = x[0:9].tolist()
    w = u.gyro
    w0, w1, w2 = w.tolist()
    cf, ct, cp, sf, st, sp = math.cos(ef), math.cos(et), math.cos(ep), math.sin(ef), math.sin(et), math.sin(ep)
    stcp, stsp = st * cp, st * sp
    C = np.array([[ct * cp, sf * stcp - cf * sp, sf * sp + cf * stcp],  # C_h^d (euler_dcm_batch's entries)
                  [ct * sp, cf * cp + sf * stsp, cf * stsp - sf * cp],
                  [-st, sf * ct, cf * ct]])
    tt = np.tan(x[4:5]).item()
    E = np.array([[1.0, sf * tt, cf * tt], [0.0, cf, -sf], [0.0, sf / ct, cf / ct]])  # E(e), eq. 2.13
    dt2 = 0.5 * dt * dt
    Fz, Fs = _noise_templates(dt)
    # dv/dw = 2 [v]x + 2 r w^T - (w.r) I - w r^T, entry by entry in the array form's order ((2 S + 2 R) - d I) - W
    wr = float(np.dot(w, x[POS]))
    z = wr * 0.0  # (the identity's zeros times w.r)
    dvdw = np.array([
        [((0.0 + 2.0 * (r0 * w0)) - wr) - w0 * r0, ((2.0 * -v2 + 2.0 * (r0 * w1)) - z) - w0 * r1,
         ((2.0 * v1 + 2.0 * (r0 * w2)) - z) - w0 * r2],
        [((2.0 * v2 + 2.0 * (r1 * w0)) - z) - w1 * r0, ((0.0 + 2.0 * (r1 * w1)) - wr) - w1 * r1,
         ((2.0 * -v0 + 2.0 * (r1 * w2)) - z) - w1 * r2],
        [((2.0 * -v1 + 2.0 * (r2 * w0)) - z) - w2 * r0, ((2.0 * v0 + 2.0 * (r2 * w1)) - z) - w2 * r1,
         ((0.0 + 2.0 * (r2 * w2)) - wr) - w2 * r2]])
    Fz[VEL, 3:6] = dt * dvdw
    Fz[POS, 3:6] = dt2 * dvdw
    Fz[ATT, 3:6] = dt * E
    Fs[POS, 0:3] = dt2 * C.T
    Fs[VEL, 0:3] = dt * C.T
    Fs[ATT, 3:6] = -dt2 * E @ C.T
    return Fz @ imu_cov @ Fz.T + Fs @ ship_cov @ Fs.T


@dataclass(frozen=True)
class CameraGeometry:
    """Camera pose in the vehicle frame: position ``rho`` (FRD, m) and rotation body -> camera."""

    rho: np.ndarray
    T_cam: np.ndarray  # 3x3, OpenCV camera axes


def light_vectors(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry):
    """s_i (eq. 2.26) in camera axes (N, L, 3), the lights C_d^h b_i (N, L, 3) and C_h^d (N, 3, 3) for
    every state and light (the rates of eq. 2.28 are formed from these in ``bearings_and_rates``)."""
    r, e = sig[:, POS], sig[:, ATT]
    C = euler_dcm_batch(e)  # C_h^d
    b_h = np.einsum("nji,lj->nli", C, lights)  # C_d^h b_i
    p = r[:, None, :] + b_h - cam.rho
    s = p @ cam.T_cam.T
    return s, b_h, C


def bearings_and_rates(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry, gyro: np.ndarray, vectors=None):
    """Predicted bearings (eq. 2.25) and bearing rates (eq. 2.27) of every light: (N, L, 2) each.
    ``vectors``: ``light_vectors(sig, lights, cam)`` when the caller has it already."""
    s, b_h, C = light_vectors(sig, lights, cam) if vectors is None else vectors
    wd = sig[:, RATE]
    w_rel = gyro - np.einsum("nji,nj->ni", C, wd)  # eq. 2.29
    pdot = sig[:, None, VEL] - _cross(w_rel[:, None, :], b_h)
    sdot = pdot @ cam.T_cam.T
    sx, sy, sz = s[..., 0], s[..., 1], s[..., 2]
    dx, dy, dz = sdot[..., 0], sdot[..., 1], sdot[..., 2]
    bear = np.arctan(s[..., :2] / sz[..., None])
    rate = np.empty_like(bear)
    rate[..., 0] = (dx * sz - sx * dz) / (sx * sx + sz * sz)
    rate[..., 1] = (dy * sz - sy * dz) / (sy * sy + sz * sz)
    return bear, rate


def measurement_model(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry, gyro: np.ndarray,
                      idx: np.ndarray, rate_idx: np.ndarray, vectors=None) -> np.ndarray:
    """Stacked measurement (eq. 3.10): bearings of lights ``idx``, then rates of lights ``rate_idx``
    (``vectors``: ``light_vectors(sig, lights, cam)`` when the caller has it already)."""
    bear, rate = bearings_and_rates(sig, lights, cam, gyro, vectors)
    return np.concatenate([bear[:, idx, :].reshape(len(sig), -1), rate[:, rate_idx, :].reshape(len(sig), -1)], axis=1)


def bearings_only(sig: np.ndarray, lights: np.ndarray, cam: CameraGeometry, vectors=None) -> np.ndarray:
    """Bearings of every light (N, 2L), for data association (``vectors`` as ``measurement_model``)."""
    s, _, _ = light_vectors(sig, lights, cam) if vectors is None else vectors
    return np.stack([np.arctan(s[..., 0] / s[..., 2]), np.arctan(s[..., 1] / s[..., 2])], axis=-1).reshape(len(sig), -1)


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
