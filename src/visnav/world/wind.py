"""Steady wind plus Dryden turbulence, MIL-F-8785C / MIL-HDBK-1797 low-altitude model.

PALACE's drift simulations used "the Dryden wind model with gusts of varying intensity"
(seed 000, section 4.2 "Tracker Drift"). Low-altitude model (h < 1000 ft), with h in feet:

    L_w = h,   L_u = L_v = h / (0.177 + 0.000823 h)^1.2
    sigma_w = 0.1 W20,   sigma_u / sigma_w = sigma_v / sigma_w = 1 / (0.177 + 0.000823 h)^0.4

W20 is the wind speed at 20 ft: 15 / 30 / 45 kt for light / moderate / severe turbulence.
One-sided velocity spectra over temporal frequency omega [rad/s] at airspeed V:

    Phi_u(omega) = sigma_u^2 (2 L_u / (pi V)) / (1 + (L_u omega / V)^2)
    Phi_v(omega) = sigma_v^2 (L_v / (pi V)) (1 + 3 (L_v omega / V)^2) / (1 + (L_v omega / V)^2)^2
    (Phi_w as Phi_v with L_w, sigma_w)

realised by shaping filters driven by unit white noise (tau = L / V):

    H_u(s) = sigma_u sqrt(2 L_u / V) / (1 + tau_u s)
    H_v(s) = sigma_v sqrt(L_v / V) (1 + sqrt(3) tau_v s) / (1 + tau_v s)^2

Discretisation: *exact* for a stochastic input. Each filter's state space (A, B, C) becomes
x[k+1] = expm(A dt) x[k] + q[k], q ~ N(0, Q_d), Q_d = int_0^dt e^(As) B B' e^(A's) ds
(= P_inf - A_d P_inf A_d' for the stationary process), so the samples have exactly the
covariance of the continuous process at the sample instants, at any dt (a ZOH
discretisation of white noise is only approximate). The state starts in its stationary
distribution (continuous Lyapunov equation).

Gusts are velocities only (u, v, w) in the mean-wind axes: u along the direction the mean
wind blows towards, w down, v = w x u (to the right of u, seen from above).
Clamps: h >= 3 ft (and <= 1000 ft, the low-altitude model's range); V >= 1 m/s near hover
(turbulence is a frozen field convected past the vehicle; at zero relative speed the
time scales L / V would diverge).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal

__all__ = ["SteadyWind", "DrydenTurbulence", "Wind", "to_ned", "TURBULENCE_W20_KT"]

FT = 0.3048  # m per ft
KT = 1852.0 / 3600.0  # m/s per knot
#: wind speed at 20 ft per intensity (MIL-HDBK-1797)
TURBULENCE_W20_KT: dict[str, float] = {"none": 0.0, "light": 15.0, "moderate": 30.0, "severe": 45.0}
MIN_AIRSPEED_MPS = 1.0
MIN_ALTITUDE_FT = 3.0
MAX_ALTITUDE_FT = 1000.0


def _finite(name: str, value, *, positive: bool = False, nonneg: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or (positive and v <= 0) or (nonneg and v < 0):
        need = "positive and finite" if positive else "non-negative and finite" if nonneg else "finite"
        raise ValueError(f"{name} must be {need}, got {value!r}")
    return v


@dataclass(frozen=True)
class SteadyWind:
    """Mean wind of ``speed_mps`` blowing FROM ``from_deg`` (meteorological; 0 = from north)."""

    speed_mps: float
    from_deg: float

    def __post_init__(self) -> None:
        _finite("speed_mps", self.speed_mps, nonneg=True)
        _finite("from_deg", self.from_deg)

    @property
    def ned(self) -> np.ndarray:
        """(3,) NED wind velocity [m/s] (where the air goes: opposite to ``from_deg``)."""
        a = math.radians(self.from_deg)
        return np.array([-self.speed_mps * math.cos(a), -self.speed_mps * math.sin(a), 0.0])


def to_ned(gust_uvw, wind_from_deg: float) -> np.ndarray:
    """Rotate gusts (..., 3) from mean-wind axes (u downwind, v right, w down) to NED."""
    g = np.asarray(gust_uvw, dtype=float)
    if g.ndim == 0 or g.shape[-1] != 3:
        raise ValueError(f"gust_uvw must have shape (..., 3), got {g.shape}")
    psi = math.radians(_finite("wind_from_deg", wind_from_deg)) + math.pi  # downwind heading
    c, s = math.cos(psi), math.sin(psi)
    return g @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T  # the rotation about down by psi


def _sigma_w_from_intensity(intensity) -> float:
    if isinstance(intensity, str):
        key = intensity.strip().lower()
        if key not in TURBULENCE_W20_KT:
            raise ValueError(
                f"intensity must be one of {sorted(TURBULENCE_W20_KT)} or sigma_w in m/s, got {intensity!r}"
            )
        return 0.1 * TURBULENCE_W20_KT[key] * KT
    return _finite("intensity (sigma_w [m/s])", intensity, nonneg=True)


class _UnitShapingFilter:
    """Dryden shaping filter for sigma = 1 and tau = L / V = 1, in normalised coordinates.

    The filter (A, B, C), D = 0, is transformed (x -> T^-1 x, T T' = P_inf from the continuous
    Lyapunov equation) so that its stationary state covariance is the identity and the output
    is y = c x with |c| = 1. A filter with time constant tau and gain sigma is the same
    process with time scaled by tau and output scaled by sigma, so a state carried across a
    change of altitude or airspeed stays stationary for the new filter.

    Exact discretisation over a step h = dt / tau: A_d = expm(A h) and, the process being
    stationary with covariance I, Q_d = I - A_d A_d' (equal to Van Loan's integral
    int_0^h e^(As) B B' e^(A's) ds).

    Both Dryden filters have all their poles at s = -1 (tau = 1), so N = A + I is nilpotent
    (N^2 = 0: a similarity transform keeps that) and the exponential has the closed form
    expm(A h) = e^(-h) (I + h N) (first two terms of e^(-h) expm(N h)). It is used instead of
    ``scipy.linalg.expm``, whose Pade path costs up to ~2 ms for a 2 x 2 at small h; a
    filter without that structure falls back to ``expm``.
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        p_inf = linalg.solve_continuous_lyapunov(a, -b @ b.T)
        t = np.linalg.cholesky(p_inf)
        t_inv = np.linalg.inv(t)
        self.a = t_inv @ a @ t
        self.c = (c @ t).ravel()
        self.order = a.shape[0]
        n = self.a + np.eye(self.order)
        self._nil = n if np.allclose(n @ n, 0.0, atol=1e-12) else None

    def discretize(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(A_d, L) with x[k+1] = A_d x[k] + L n[k], n ~ N(0, I), for a step of h time constants."""
        if self._nil is not None:  # all poles at -1: expm(A h) = e^(-h) (I + h N), exactly
            ad = math.exp(-h) * (np.eye(self.order) + h * self._nil)
        else:
            ad = linalg.expm(self.a * h)
        qd = np.eye(self.order) - ad @ ad.T
        w, v = np.linalg.eigh(0.5 * (qd + qd.T))
        return ad, v * np.sqrt(np.clip(w, 0.0, None))


# H_u(s) = sqrt(2) / (1 + s);  H_v(s) = H_w(s) = (1 + sqrt(3) s) / (1 + s)^2   (sigma = tau = 1)
_UNIT_U = _UnitShapingFilter(np.array([[-1.0]]), np.array([[1.0]]), np.array([[math.sqrt(2.0)]]))
_UNIT_VW = _UnitShapingFilter(
    np.array([[0.0, 1.0], [-1.0, -2.0]]), np.array([[0.0], [1.0]]), np.array([[1.0, math.sqrt(3.0)]])
)
_UNITS = (_UNIT_U, _UNIT_VW, _UNIT_VW)


class DrydenTurbulence:
    """Dryden gust velocities (u, v, w) [m/s] in mean-wind axes (see module docstring)."""

    def __init__(
        self,
        intensity: str | float,
        rng: np.random.Generator,
        altitude_m: float = 10.0,
        airspeed_mps: float = 5.0,
    ) -> None:
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.sigma_w_20 = _sigma_w_from_intensity(intensity)
        self.rng = rng
        self.altitude_m = _finite("altitude_m", altitude_m)
        self.airspeed_mps = _finite("airspeed_mps", airspeed_mps)
        self._cache: dict[tuple[int, float], tuple[np.ndarray, np.ndarray]] = {}
        # start in the stationary distribution (identity covariance, see _UnitShapingFilter)
        self._x = [rng.standard_normal(f.order) for f in _UNITS]
        self.gust = self._output()

    def parameters(self) -> dict[str, float]:
        """sigma_u, sigma_v, sigma_w [m/s], L_u, L_v, L_w [m], V [m/s] used now (after clamps)."""
        h_ft = min(max(self.altitude_m / FT, MIN_ALTITUDE_FT), MAX_ALTITUDE_FT)
        den = 0.177 + 0.000823 * h_ft
        sig_w = self.sigma_w_20
        sig_uv = sig_w / den**0.4
        l_uv = h_ft / den**1.2 * FT
        return {
            "sigma_u": sig_uv, "sigma_v": sig_uv, "sigma_w": sig_w,
            "L_u": l_uv, "L_v": l_uv, "L_w": h_ft * FT,
            "V": max(self.airspeed_mps, MIN_AIRSPEED_MPS),
        }

    def _sigmas_taus(self) -> tuple[np.ndarray, np.ndarray]:
        sig, tau = self._sig_tau()
        return np.array(sig), np.array(tau)

    def _sig_tau(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(sigma_u, sigma_v, sigma_w), (tau_u, tau_v, tau_w) as floats: ``parameters()``'s formulas
        and ``L / V`` without the dict and the arrays (the same values; the 20 Hz ``step``)."""
        h_ft = min(max(self.altitude_m / FT, MIN_ALTITUDE_FT), MAX_ALTITUDE_FT)
        den = 0.177 + 0.000823 * h_ft
        sig_w = self.sigma_w_20
        sig_uv = sig_w / den**0.4
        l_uv = h_ft / den**1.2 * FT
        v = max(self.airspeed_mps, MIN_AIRSPEED_MPS)
        return (sig_uv, sig_uv, sig_w), (l_uv / v, l_uv / v, h_ft * FT / v)

    def _output(self, sig=None) -> np.ndarray:
        if sig is None:
            sig, _ = self._sig_tau()
        return np.array([s * float(f.c @ x) for s, f, x in zip(sig, _UNITS, self._x)])

    def _discrete(self, i: int, h: float) -> tuple[np.ndarray, np.ndarray]:
        """Discretisation for a step of ``h`` time constants, cached on a 2% log grid of h.

        Altitude and airspeed change every step in flight; snapping h to the grid (a 1% time
        scale error at most, far below the model's own accuracy) keeps the cache small and the
        100 Hz loop free of matrix exponentials.
        """
        key = (i, round(math.log(h) * 50.0))
        ent = self._cache.get(key)
        if ent is None:
            if len(self._cache) > 4096:
                self._cache.clear()
            ent = self._cache[key] = _UNITS[i].discretize(math.exp(key[1] / 50.0))
        return ent

    def step(
        self, dt: float, altitude_m: float | None = None, airspeed_mps: float | None = None
    ) -> np.ndarray:
        """Advance by ``dt`` [s] and return the (3,) gust (u, v, w) [m/s]; dt = 0 returns the
        current gust. New ``altitude_m`` / ``airspeed_mps`` apply from this step on."""
        dt = _finite("dt", dt, nonneg=True)
        if altitude_m is not None:
            self.altitude_m = _finite("altitude_m", altitude_m)
        if airspeed_mps is not None:
            self.airspeed_mps = _finite("airspeed_mps", airspeed_mps)
        sig, tau = self._sig_tau()  # once a step: the output uses the same altitude and airspeed
        if dt > 0.0:
            xs, rng = self._x, self.rng
            for i in range(3):
                ad, lq = self._discrete(i, dt / tau[i])
                xs[i] = ad @ xs[i] + lq @ rng.standard_normal(lq.shape[1])
        self.gust = self._output(sig)
        return self.gust.copy()

    def generate(self, n: int, dt: float) -> np.ndarray:
        """(n, 3) stationary gust samples at spacing ``dt``, vectorised with ``lfilter``.

        A fresh realisation at the current altitude and airspeed (initial state drawn from
        the stationary distribution, consuming ``rng``); the state used by :meth:`step` is
        not changed.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"n must be a positive int, got {n!r}")
        dt = _finite("dt", dt, positive=True)
        sig, tau = self._sigmas_taus()
        out = np.empty((int(n), 3))
        for i in range(3):
            out[:, i] = sig[i] * self._generate_unit(_UNITS[i], int(n), dt / tau[i])
        return out

    def _generate_unit(self, f: _UnitShapingFilter, n: int, h: float) -> np.ndarray:
        """y_k = c x_k, k = 1..n, from x_0 ~ N(0, I): forced part by lfilter, free part by the
        characteristic recursion."""
        ad, lq = f.discretize(h)
        m = f.order
        noise = self.rng.standard_normal((lq.shape[1], n))
        x0 = self.rng.standard_normal(m)
        c = f.c[None, :]
        y = np.zeros(n)
        den = np.poly(ad)
        for j in range(lq.shape[1]):
            # forced part sum_i c A^(i-1) L n[k-i]: num/den is strictly proper (num[0] = 0);
            # dropping num[0] advances the output one sample, so that out[k-1] = y_k
            num, den = signal.ss2tf(ad, lq[:, [j]], c, np.zeros((1, 1)))
            y += signal.lfilter(num[0][1:], den, noise[j])
        # free part c A^k x0: the first m terms directly, then den's recursion
        xk, head = x0, []
        for _ in range(min(m, n)):
            xk = ad @ xk
            head.append(float(f.c @ xk))
        free = np.empty(n)
        free[: len(head)] = head
        if n > m:
            zi = signal.lfiltic([1.0], den, y=head[::-1])
            free[m:] = signal.lfilter([1.0], den, np.zeros(n - m), zi=zi)[0]
        return y + free


class Wind:
    """Steady wind plus optional Dryden turbulence, in NED."""

    def __init__(self, steady: SteadyWind, turbulence: DrydenTurbulence | None = None) -> None:
        self.steady = steady
        self.turbulence = turbulence

    def velocity_ned(
        self, t: float, dt: float, altitude_m: float | None = None, airspeed_mps: float | None = None
    ) -> np.ndarray:
        """(3,) NED air velocity [m/s] at time ``t`` [s], advancing the turbulence by ``dt``."""
        _finite("t", t)
        if self.turbulence is None:
            _finite("dt", dt, nonneg=True)
            return self.steady.ned
        gust = self.turbulence.step(dt, altitude_m, airspeed_mps)
        return self.steady.ned + to_ned(gust, self.steady.from_deg)
