"""Tau theory trajectories in closed form (seed 003 §2.5).

tau = x / x_dot is the time to contact of a closing gap x (eq. 2.33). Three laws:

* tau-dot (eq. 2.34-2.37): tau_dot = k, from x0 and x_dot0 (x0 x_dot0 < 0 to close);
* tau-guidance (Kendoul, eq. 2.38-2.41): tau = k/2 (t - T^2 / t), starts at rest, ends at t = T;
* higher-order tau-guidance (eq. 2.42-2.46): tau = k/3 (t - T^3 / t^2), starts with zero velocity
  *and* acceleration; with k = 1/2 it ends with zero velocity and acceleration 18 x0 / T^2.

Touchdown by k (each law): k < 0 never reaches the goal; 0 < k < 1/2 reaches it with zero
velocity and zero acceleration; k = 1/2 zero velocity, finite acceleration; k > 1/2 finite or
unbounded velocity / acceleration (an impact). Eq. 2.39 as extracted reads T^(k/2) in the
normaliser; x(0) = x0 needs T^(2/k), as eq. 2.40-2.41 have it. Eq. 2.41 as extracted carries the
exponent (1-k)/k on (T^2 - t^2); differentiating eq. 2.40 gives (1-2k)/k (checked numerically). Every function is vectorised in t and
returns (x, x_dot, x_ddot); outside [0, T] the guidance laws hold their end state.
"""

from __future__ import annotations

import contextlib
import math

import numpy as np


def _pow(base: np.ndarray, p: float) -> np.ndarray:
    """base**p with base clipped at 0 (the gap has closed), 0**negative -> inf."""
    b = np.maximum(base, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b > 0, b ** p, 0.0 if p > 0 else (1.0 if p == 0 else np.inf))


def tau_dot(t, x0: float, xdot0: float, k: float):
    """Eq. 2.35-2.37: x(t) = x0 (1 + k xdot0 t / x0)^(1/k) and its derivatives (k != 0)."""
    if k == 0:
        raise ValueError("tau-dot needs k != 0")
    t = np.asarray(t, float)
    c = 1.0 + k * xdot0 / x0 * t
    x = x0 * _pow(c, 1.0 / k)
    xd = xdot0 * _pow(c, (1.0 - k) / k)
    if k == 1.0:  # constant speed: no acceleration, even at contact
        xdd = np.zeros_like(x)
    else:
        xdd = xdot0**2 / x0 * (1.0 - k) * _pow(c, (1.0 - 2.0 * k) / k)
    return x, xd, xdd


def tau_dot_contact_time(x0: float, xdot0: float, k: float) -> float:
    """t_final = -tau_0 / k for 0 < k (inf when the gap never closes)."""
    tau0 = x0 / xdot0
    return -tau0 / k if k > 0 and tau0 < 0 else np.inf


def tau_guidance(t, x0: float, T: float, k: float):
    """Eq. 2.39-2.41: x = x0 / T^(2/k) (T^2 - t^2)^(1/k), from rest at t = 0 to the goal at t = T."""
    if T <= 0 or k == 0:
        raise ValueError(f"tau-guidance needs T > 0 and k != 0, got T={T}, k={k}")
    t = np.clip(np.asarray(t, float), 0.0, T)
    a = x0 / T ** (2.0 / k)
    g = T * T - t * t
    x = a * _pow(g, 1.0 / k)
    xd = -2.0 * a * t / k * _pow(g, (1.0 - k) / k)
    with np.errstate(invalid="ignore"):
        xdd = 2.0 * a / k * ((2.0 - k) / k * t * t - T * T) * _pow(g, (1.0 - 2.0 * k) / k)
    return x, xd, xdd


def higher_order_tau(t, x0: float, T: float, k: float):
    """Eq. 2.43-2.45: x = x0 / T^(3/k) (T^3 - t^3)^(1/k), from rest (zero velocity and acceleration).

    Eq. 2.45 is written here in the equivalent form
    x_ddot = (x0 / T^(3/k)) (3 t / k) [3 t^3 (1-k)/k (T^3 - t^3)^((1-2k)/k) - 2 (T^3 - t^3)^((1-k)/k)],
    which stays finite at t = T for k = 1/2. A float ``t`` (the mission's 50 Hz step) is evaluated in Python
    floats, an array in numpy; the same law (``_higher_order_tau_law``) either way.
    """
    if T <= 0 or k == 0:
        raise ValueError(f"higher-order tau needs T > 0 and k != 0, got T={T}, k={k}")
    if isinstance(t, float):
        # where Python's ** raises (numpy's gives inf) the array form below answers
        with contextlib.suppress(OverflowError, ZeroDivisionError):
            return tuple(np.float64(v) for v in _higher_order_tau_law(min(max(t, 0.0), T), x0, T, k, _pow_one))
    with np.errstate(invalid="ignore"):
        return _higher_order_tau_law(np.clip(np.asarray(t, float), 0.0, T), x0, T, k, _pow)


def _higher_order_tau_law(t, x0: float, T: float, k: float, pw):
    """x, x_dot, x_ddot of eq. 2.43-2.45 at ``t`` in [0, T], ``pw`` the clipped power (``_pow`` or ``_pow_one``)."""
    a = x0 / T ** (3.0 / k)
    g = (T - t) * (T * T + T * t + t * t)  # T^3 - t^3, exactly 0 at t = T
    x = a * pw(g, 1.0 / k)
    xd = -a * 3.0 * t * t / k * pw(g, (1.0 - k) / k)
    xdd = a * 3.0 * t / k * (3.0 * t**3 * (1.0 - k) / k * pw(g, (1.0 - 2.0 * k) / k) - 2.0 * pw(g, (1.0 - k) / k))
    return x, xd, xdd


def _pow_one(b: float, p: float) -> float:
    """``_pow`` of one number (NaN and b <= 0 give the constant, as np.where(b > 0, ...) does)."""
    return b**p if b > 0 else (0.0 if p > 0 else (1.0 if p == 0 else math.inf))


def higher_order_tau_touchdown_acceleration(x0: float, T: float) -> float:
    """Eq. 2.46: the acceleration at t = T of the k = 1/2 law, 18 x0 / T^2."""
    return 18.0 * x0 / T**2


def duration_for_touchdown_acceleration(x0: float, accel: float) -> float:
    """T such that the k = 1/2 law ends with acceleration ``accel`` (eq. 2.46 solved for T)."""
    return float(np.sqrt(18.0 * abs(x0) / accel))
