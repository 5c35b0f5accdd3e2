"""Error-state Kalman filter around the strapdown INS (seed 002 App. A.1.2, eq. A.2-A.10, 5.22-5.23).

Error state (truth minus nominal), 12 states as in the thesis, 15 with gyro biases:

    x = (dr^n [m], dv^n [m/s], eps^n [rad], db_a [m/s^2], (db_g [rad/s]))

``eps`` is the attitude error in NED axes, ``C_true = (I + [eps x]) C_est``. With the sensor model
``f_meas = f + b_a + n_a`` and ``w_meas = w + b_g + n_g`` the perturbation of eq. A.1 gives (A.4):

    dr'   = -w_en x dr + dv                                      (+ vertical gravity gradient
    dv'   = -(2 w_ie + w_en) x dv - f^n x eps - C db_a - C n_a      dv_d' += 2 g / R dr_d with
                                                                     the WGS-84 gravity model)
    eps'  = -w_in x eps - C db_g - C n_g
    db_a' = -beta_a db_a + w_ba ;  db_g' = -beta_g db_g + w_bg

(the thesis writes ``- eps x f + da`` with the bias sign of its own convention: same model).
Noise spectral densities: eq. A.9, plus bias random-walk densities.

Discretisation: ``"first_order"`` is the thesis' eq. A.7-A.8 (Phi = I + F dt,
Q_k = Phi G Q G^T Phi^T dt); ``"van_loan"`` computes Phi = expm(F dt) and Q_k exactly for F held
over the interval (Van Loan 1978; the exponential by scaling and squaring + Taylor series).
Both agree to first order in dt; the first-order form is the default (thesis, and faster).

Updates use the Joseph form; each is gated on its normalised innovation squared against the
chi-square quantile ``gate_probability`` with the measurement's dimension; rejections are counted
per update kind in ``stats`` and listed in ``rejections``. After every accepted update the error is
fed back into the nominal state (``q <- exp(eps) ⊗ q``) and reset to zero (ESKF reset Jacobian).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from visnav.estimation.ins import (
    NavState,
    StrapdownINS,
    quat_from_rotvec,
    quat_mult,
    quat_to_dcm,
    radii_of_curvature,
)
from visnav.geometry.rotations import euler_to_dcm, skew, wrap_angle
from visnav.measurements import ImuSample, NavEstimate
from dataclasses import replace

__all__ = ["EskfConfig", "ErrorStateKF", "UpdateResult", "heading_from_mag"]

R_, V_, E_, BA_, BG_ = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15)


def _expm(A: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring with a degree-10 Taylor series (truncation
    below 1e-16 once ||A / 2^s||_1 <= 0.25). For the small ``F dt`` blocks of Van Loan's method
    this is several times faster than scipy.linalg.expm and agrees with it to ~1e-15."""
    nrm = float(np.abs(A).sum(axis=0).max())
    if not math.isfinite(nrm):
        return expm(A)
    s = max(0, math.ceil(math.log2(nrm / 0.25))) if nrm > 0.25 else 0
    X = A / (2.0**s)
    E = np.eye(len(A)) + X
    term = X
    for k in range(2, 11):
        term = term @ X / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


@dataclass(frozen=True)
class EskfConfig:
    """Noise model and options. Densities are continuous-time (per sqrt(Hz))."""

    accel_noise: float = 0.05  # accelerometer white noise density [m/s^2/sqrt(Hz)]
    gyro_noise: float = 1e-3  # gyro white noise density [rad/s/sqrt(Hz)]
    accel_bias_noise: float = 1e-3  # accel bias random-walk density [m/s^3/sqrt(Hz)]
    gyro_bias_noise: float = 1e-5  # gyro bias random-walk density [rad/s^2/sqrt(Hz)]
    accel_bias_tau_s: float = math.inf  # Gauss-Markov time constant (inf: random walk), beta=1/tau
    gyro_bias_tau_s: float = math.inf
    gyro_bias: bool = False  # estimate gyro biases (15 states) or not (12 states, the thesis)
    discretization: str = "first_order"  # "first_order" (eq. A.7-A.8) | "van_loan"
    gate_probability: float = 0.9997  # chi-square gate; 1.0 disables gating
    lat0_deg: float = 58.4  # latitude of the local NED origin (Earth and transport rate)
    h0_m: float = 0.0
    earth_rotation: bool = True
    gravity_mps2: float | None = None  # None: WGS-84 normal gravity; a number: constant g

    def __post_init__(self):
        for name in ("accel_noise", "gyro_noise", "accel_bias_noise", "gyro_bias_noise"):
            v = getattr(self, name)
            if not (v >= 0.0 and math.isfinite(v)):
                raise ValueError(f"EskfConfig.{name} must be finite and >= 0, got {v}")
        if self.discretization not in ("first_order", "van_loan"):
            raise ValueError(f"EskfConfig.discretization must be 'first_order' or 'van_loan', "
                             f"got {self.discretization!r}")
        if not 0.0 < self.gate_probability <= 1.0:
            raise ValueError(f"EskfConfig.gate_probability must be in (0, 1], got {self.gate_probability}")


@dataclass(frozen=True)
class UpdateResult:
    kind: str
    accepted: bool
    nis: float  # normalised innovation squared
    innovation: np.ndarray
    gate: float


def heading_from_mag(mag_body, roll: float, pitch: float, declination: float = 0.0) -> float:
    """Tilt-compensated magnetic heading [rad] (true north with ``declination`` east-positive)."""
    m = np.asarray(mag_body, dtype=float)
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    mx = m[0] * cp + m[1] * sr * sp + m[2] * cr * sp
    my = m[1] * cr - m[2] * sr
    return float(wrap_angle(math.atan2(-my, mx) + declination))


@dataclass
class _Stats:
    accepted: int = 0
    rejected: int = 0


class ErrorStateKF:
    """INS + error-state KF. See docs/ins.md for the interface.

    ``state``: initial nominal NavState (its ``t`` is the filter time).
    ``P0``: initial error covariance (n x n) or a vector of n standard deviations,
    n = 12 (15 with ``config.gyro_bias``).
    """

    def __init__(self, state: NavState, P0, config: EskfConfig | None = None):
        self.cfg = config or EskfConfig()
        self.n = 15 if self.cfg.gyro_bias else 12
        self.ins = StrapdownINS(self.cfg.lat0_deg, self.cfg.h0_m, self.cfg.earth_rotation,
                                self.cfg.gravity_mps2)
        self.x = state.copy()
        P0 = np.asarray(P0, dtype=float)
        if P0.shape == (self.n,):
            P0 = np.diag(P0**2)
        if P0.shape != (self.n, self.n) or not np.all(np.isfinite(P0)):
            raise ValueError(f"P0 must be {self.n} sigmas or a finite {self.n}x{self.n} matrix, "
                             f"got shape {P0.shape}")
        self.P = 0.5 * (P0 + P0.T)
        self._last_imu: ImuSample | None = None
        self._f_n = np.array([0.0, 0.0, -9.81])  # last specific force in NED (for F)
        self.stats: dict[str, _Stats] = {}
        self.rejections: list[tuple[float, str, float]] = []  # (t, kind, nis)
        self.rejected_samples = 0
        self._gates: dict[int, float] = {}
        self._I = np.eye(self.n)
        self._F0, self._G0 = self._model_template()
        self._Qc = self._noise()

    def _noise(self) -> np.ndarray:
        c = self.cfg
        qc = [c.accel_noise**2] * 3 + [c.gyro_noise**2] * 3 + [c.accel_bias_noise**2] * 3
        if c.gyro_bias:
            qc += [c.gyro_bias_noise**2] * 3
        return np.diag(qc)

    def retune(self, **changes) -> None:
        """Change noise densities or the gate in flight (``EskfConfig`` fields; not ``gyro_bias``, the state
        size): e.g. a larger bias random walk once a sensor is known faulty, so that the bias states follow
        its steps."""

        if "gyro_bias" in changes and bool(changes["gyro_bias"]) != self.cfg.gyro_bias:
            raise ValueError("retune cannot change the state size (gyro_bias)")
        self.cfg = replace(self.cfg, **changes)
        self._F0, self._G0 = self._model_template()
        self._Qc = self._noise()
        self._gates.clear()

    def _gate(self, dof: int) -> float:
        g = self._gates.get(dof)
        if g is None:
            g = self._gates[dof] = float(chi2.ppf(self.cfg.gate_probability, dof))
        return g

    # ------------------------------------------------------------ model
    def _model_template(self) -> tuple[np.ndarray, np.ndarray]:
        """The constant blocks of F and G (identities, bias time constants), copied per step."""
        n = self.n
        F, G = np.zeros((n, n)), np.zeros((n, 9 if n == 12 else 12))
        F[R_, V_] = np.eye(3)
        F[BA_, BA_] = -np.eye(3) / self.cfg.accel_bias_tau_s
        G[BA_, 6:9] = np.eye(3)
        if n == 15:
            F[BG_, BG_] = -np.eye(3) / self.cfg.gyro_bias_tau_s
            G[BG_, 9:12] = np.eye(3)
        return F, G

    def error_model(self, f_n: np.ndarray, C: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Continuous F (eq. A.4 / 5.22) and G (eq. A.2) at the current nominal state (``C``: its
        body -> NED DCM when the caller has it already)."""
        n, s = self.n, self.x
        if C is None:
            C = quat_to_dcm(s.quat)
        F = self._F0.copy()
        if self.ins.earth_rotation:  # (without it the rate blocks stay the template's zeros)
            w_ie, w_en = self.ins.rates_at(s.position, s.velocity)
            w_in = w_ie + w_en
            F[R_, R_] = -skew(w_en)
            F[V_, V_] = -skew(2.0 * w_ie + w_en)
            F[E_, E_] = -skew(w_in)
        if self.cfg.gravity_mps2 is None:  # the nominal's gravity depends on height: model it
            g = self.ins.gravity_at(s.position)[2]
            lat, h = self.ins.lat_h(s.position)
            rn, re = radii_of_curvature(lat)
            F[5, 2] = 2.0 * g / (math.sqrt(rn * re) + h)  # vertical gravity gradient (dg/dh)
        F[V_, E_] = -skew(f_n)
        F[V_, BA_] = -C
        G = self._G0.copy()
        G[V_, 0:3] = -C
        G[E_, 3:6] = -C
        if n == 15:
            F[E_, BG_] = -C
        return F, G

    def discretize(self, F: np.ndarray, G: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(Phi, Q_k) by eq. A.7-A.8 or by Van Loan's method, per ``config.discretization``."""
        GQG = G @ self._Qc @ G.T
        if self.cfg.discretization == "first_order":
            Phi = self._I + F * dt
            return Phi, Phi @ GQG @ Phi.T * dt
        n = self.n
        M = np.zeros((2 * n, 2 * n))
        M[:n, :n] = -F
        M[:n, n:] = GQG
        M[n:, n:] = F.T
        E = _expm(M * dt)
        Phi = E[n:, n:].T
        return Phi, Phi @ E[:n, n:]

    # ------------------------------------------------------------ prediction
    def predict(self, imu: ImuSample) -> bool:
        """Take one IMU sample: propagates nominal state and covariance from the previous sample
        (mean of the two samples over the interval). The first sample only sets the time.
        A sample with NaN / inf or a non-increasing time is skipped (counted in
        ``rejected_samples``); returns whether it was used."""
        a = np.asarray(imu.accel, dtype=float)
        w = np.asarray(imu.gyro, dtype=float)
        if a.shape != (3,) or w.shape != (3,) or not (np.isfinite(a).all() and np.isfinite(w).all()
                                                      and math.isfinite(imu.t)):
            self.rejected_samples += 1
            return False
        prev = self._last_imu
        if prev is None:  # the filter time becomes the first sample's time
            self._last_imu = imu
            self.x.t = float(imu.t)
            return True
        dt = float(imu.t - prev.t)
        if dt <= 0.0:
            self.rejected_samples += 1
            return False
        self.propagate(0.5 * (a + np.asarray(prev.accel)), 0.5 * (w + np.asarray(prev.gyro)), dt)
        self.x.t = float(imu.t)  # no accumulated rounding of the filter time
        self._last_imu = imu
        return True

    def propagate(self, accel, gyro, dt: float) -> None:
        """Advance nominal state (eq. A.1) and covariance (eq. A.5-A.8) by ``dt`` with IMU
        readings held over the interval."""
        f_b = np.asarray(accel, dtype=float) - self.x.accel_bias
        C = quat_to_dcm(self.x.quat)
        self._f_n = C @ f_b
        F, G = self.error_model(self._f_n, C)
        Phi, Qk = self.discretize(F, G, dt)
        self.x = self.ins.propagate(self.x, accel, gyro, dt)
        P = Phi @ self.P @ Phi.T + Qk
        self.P = 0.5 * (P + P.T)

    # ------------------------------------------------------------ updates
    def update(self, kind: str, y: np.ndarray, H: np.ndarray, R: np.ndarray, gate: bool = True) -> UpdateResult:
        """Generic update with innovation ``y`` (measurement minus prediction), Jacobian ``H``
        w.r.t. the error state and covariance ``R``; gated, fed back and reset."""
        y = np.atleast_1d(np.asarray(y, dtype=float))
        R = np.atleast_2d(np.asarray(R, dtype=float))
        st = self.stats.setdefault(kind, _Stats())
        if not (np.isfinite(y).all() and np.isfinite(R).all()):
            st.rejected += 1
            self.rejections.append((self.x.t, kind, math.nan))
            return UpdateResult(kind, False, math.nan, y, math.nan)
        PHt = self.P @ H.T
        S = H @ PHt + R
        Sinv = 1.0 / S if S.shape == (1, 1) else np.linalg.inv(S)  # (scalar: baro, heading)
        nis = float(y @ Sinv @ y)
        thr = math.inf if (not gate or self.cfg.gate_probability >= 1.0) else self._gate(len(y))
        if nis > thr:
            st.rejected += 1
            self.rejections.append((self.x.t, kind, nis))
            return UpdateResult(kind, False, nis, y, thr)
        K = PHt @ Sinv
        dx = K @ y
        IKH = self._I - K @ H
        P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self.P = 0.5 * (P + P.T)
        self._inject(dx)
        st.accepted += 1
        return UpdateResult(kind, True, nis, y, thr)

    def _inject(self, dx: np.ndarray) -> None:
        s = self.x
        s.position = s.position + dx[R_]
        s.velocity = s.velocity + dx[V_]
        q = quat_mult(quat_from_rotvec(dx[E_]), s.quat)
        s.quat = q / math.sqrt(q.dot(q))  # np.linalg.norm's own formula, without its overhead
        s.accel_bias = s.accel_bias + dx[BA_]
        if self.n == 15:
            s.gyro_bias = s.gyro_bias + dx[BG_]
        # reset: eps_new = eps - eps_hat rotated; Jacobian I + [eps_hat/2 x] on the attitude block
        Gr = self._I.copy()
        Gr[E_, E_] += 0.5 * skew(dx[E_])
        self.P = Gr @ self.P @ Gr.T

    @staticmethod
    def _cov(cov, dim: int, what: str) -> np.ndarray:
        c = np.asarray(cov, dtype=float)
        if c.ndim == 0:
            return np.eye(dim) * float(c) ** 2  # a scalar is a standard deviation
        if c.shape == (dim,):
            return np.diag(c**2)  # a vector holds standard deviations
        if c.shape == (dim, dim):
            return c
        raise ValueError(f"{what}: covariance must be a sigma, {dim} sigmas or {dim}x{dim}, got shape {c.shape}")

    def update_position(self, position, cov, gate: bool = True) -> UpdateResult:
        """Position fix in local NED [m] (eq. 5.23 first rows): 3-D, or 2-D horizontal (N, E)
        when ``position`` has 2 components (the PMF's output). ``cov``: sigma [m], sigmas or a
        covariance matrix [m^2]."""
        z = np.asarray(position, dtype=float).ravel()
        if z.shape not in ((2,), (3,)):
            raise ValueError(f"position must have 2 (N, E) or 3 (N, E, D) components, got {z.shape}")
        d = len(z)
        H = np.zeros((d, self.n))
        H[:, :d] = np.eye(d)
        return self.update(f"position{d}d", z - self.x.position[:d], H,
                           self._cov(cov, d, "position"), gate)

    def update_baro(self, altitude_m: float, sigma_m: float, gate: bool = True) -> UpdateResult:
        """Barometric altitude above the NED origin [m] (up positive; eq. 5.23 last row)."""
        H = np.zeros((1, self.n))
        H[0, 2] = -1.0
        return self.update("baro", [float(altitude_m) + self.x.position[2]], H, [[sigma_m**2]], gate)

    def update_velocity(self, velocity, cov, gate: bool = True) -> UpdateResult:
        """NED velocity [m/s] (e.g. GPS or visual odometry)."""
        z = np.asarray(velocity, dtype=float).ravel()
        if z.shape != (3,):
            raise ValueError(f"velocity must have 3 components, got {z.shape}")
        H = np.zeros((3, self.n))
        H[:, V_] = np.eye(3)
        return self.update("velocity", z - self.x.velocity, H, self._cov(cov, 3, "velocity"), gate)

    def heading_jacobian(self) -> np.ndarray:
        """d yaw / d eps for ``C_true = (I + [eps x]) C``: yaw = atan2(C10, C00)."""
        C = quat_to_dcm(self.x.quat)
        den = C[0, 0] ** 2 + C[1, 0] ** 2
        return np.array([-C[0, 0] * C[2, 0], -C[1, 0] * C[2, 0], den]) / den

    def update_heading(self, yaw: float, sigma: float, gate: bool = True) -> UpdateResult:
        """Heading aid [rad] (compass), innovation wrapped to (-pi, pi]."""
        C = quat_to_dcm(self.x.quat)
        y = wrap_angle(float(yaw) - math.atan2(C[1, 0], C[0, 0]))
        H = np.zeros((1, self.n))
        H[0, E_] = self.heading_jacobian()
        return self.update("heading", [y], H, [[sigma**2]], gate)

    def update_magnetometer(self, mag_body, sigma: float, declination: float = 0.0,
                            gate: bool = True) -> UpdateResult:
        """Compass aid from a body magnetometer vector: tilt-compensated with the filter's roll and
        pitch, then a heading update."""
        r, p, _ = self.x.euler
        return self.update_heading(heading_from_mag(mag_body, r, p, declination), sigma, gate)

    def update_attitude(self, euler, sigma, gate: bool = True) -> UpdateResult:
        """Attitude aid from an independent attitude solution (the autopilot's, seed 002 §6.2), Euler angles
        [rad]: with ``C_meas = (I + [eps x]) C`` the innovation is ``eps = log(C_meas C^T)`` (NED axes) and
        ``H = [0 0 I 0 ...]``. ``sigma``: [rad], one or three (N, E, D axes)."""
        Cm = euler_to_dcm(np.asarray(euler, dtype=float))
        y = Rotation.from_matrix(Cm @ quat_to_dcm(self.x.quat).T).as_rotvec()
        H = np.zeros((3, self.n))
        H[:, E_] = np.eye(3)
        return self.update("attitude", y, H, self._cov(sigma, 3, "attitude"), gate)

    def update_gravity(self, accel_body, sigma: float, gate: bool = True) -> UpdateResult:
        """AHRS aid: when not accelerating, the accelerometer reads ``C^T (-g^n) + b_a``.
        With ``C_true^T = C^T (I - [eps x])``: ``h = C^T(-g) - C^T [g x] eps + db_a``."""
        f = np.asarray(accel_body, dtype=float)
        C = quat_to_dcm(self.x.quat)
        g = self.ins.gravity_at(self.x.position)
        y = f - (C.T @ (-g) + self.x.accel_bias)
        H = np.zeros((3, self.n))
        H[:, E_] = -C.T @ skew(g)
        H[:, BA_] = np.eye(3)
        return self.update("gravity", y, H, self._cov(sigma, 3, "gravity"), gate)

    # ------------------------------------------------------------ output
    def estimate(self, t: float | None = None, source: str = "inertial") -> NavEstimate:
        """NavEstimate at ``t`` (default: filter time); position extrapolated with the velocity
        when ``t`` differs. Covariance: the 6x6 position/velocity block. ``source`` labels it
        (e.g. "vision" when vision updates drive the filter)."""
        s = self.x
        dt = 0.0 if t is None else float(t) - s.t
        return NavEstimate(
            t=s.t + dt,
            position=s.position + s.velocity * dt,
            velocity=s.velocity.copy(),
            attitude=s.euler,
            covariance=self.P[:6, :6].copy(),
            valid=bool(np.all(np.isfinite(self.P))),
            source=source,
        )

    @property
    def attitude_sigma(self) -> np.ndarray:
        """1-sigma attitude errors (N, E, D axes) [rad]."""
        return np.sqrt(np.diag(self.P[E_, E_]))
