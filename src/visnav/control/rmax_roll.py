"""Inner roll compensator of the PFCM (seed 002 §4.5, eq. 4.26, Fig. 4.11 b), at 50 Hz.

The basic PFCM sends the roll command φ_c to the YACS through its inverse DC gain (eq. 4.25, Fig.
4.11 a); the thesis added "an extra control loop on the roll channel besides the YACS control
system", a "phase lead compensation with an integral action" (eq. 4.26, garbled in the text):

    C(s) = K α (1 + τ s) / (1 + α τ s) + K_I / s,        0 < α <= 1

acting on the roll error e = φ_c − φ (φ: the INS roll) and driving the YACS roll input,
ail = C(s) e / Gφ(0) (here C is per unit of the normalised roll plant Gφ(s)/Gφ(0) of eq. 3.4, so
its gains are dimensionless, deg of command per deg of error). K α is the proportional gain at
low frequency, K the high-frequency gain (the noise gain the thesis warns about), the lead
zero/pole at 1/τ and 1/(α τ), and K_I the integral that gives φ/φ_c a unit DC gain.

Design (``roll_loop``, python-control, loop broken at the YACS input, the 50 Hz hold as a Padé
delay of 10 ms): the largest closed-loop bandwidth of φ/φ_c on a grid of (K, α, τ, K_I) with
PM >= 45°, GM >= 6 dB, a resonance peak |φ/φ_c| <= 1.1 (no roll overshoot: the field tuning
needed a second iteration for damped roll oscillations), one gain crossover (none near the 13
rad/s YACS resonance), a real lead (α <= 0.5) and a high-frequency gain K <= 3. Result:
K = 3, α = 0.5, τ = 0.5 s, K_I = 8 /s: crossover 4.78 rad/s, PM 68.2°, GM 17.2 dB, bandwidth
5.59 rad/s against 3.05 rad/s of the YACS roll response alone (tests/control/test_rmax_roll.py).
(On this model a PI, α = 1, at the same K reaches 6.2 rad/s: the eq. 3.4 roll response has its own
phase lead from its zeros at 7.3 rad/s; the lead of eq. 4.26 is kept as the thesis built it.)

``RollCompensator`` is the Tustin discretisation at the controller rate with conditional
integration (the integrator stops where the YACS input reaches ``input_limit`` while the error
pushes further; the controller's own roll limit ``max_roll`` acts on φ_c before it) and a bumpless start (its first output is the DC inversion of the first command).
"""

from __future__ import annotations

import math

import control as ct
import numpy as np

from visnav.control.rmax import PLANT_TFS, ROLL_DC

#: eq. 4.26 design (module docstring): K, α, τ [s], K_I [1/s]
ROLL_COMPENSATOR = {"k": 3.0, "alpha": 0.5, "tau": 0.5, "ki": 8.0}


def check_gains(k: float, alpha: float, tau: float, ki: float) -> None:
    if not (math.isfinite(k) and k > 0):
        raise ValueError(f"roll compensator K must be finite and > 0, got {k}")
    if not (math.isfinite(alpha) and 0 < alpha <= 1):
        raise ValueError(f"roll compensator alpha must be in (0, 1] (a lead), got {alpha}")
    if not (math.isfinite(tau) and tau > 0):
        raise ValueError(f"roll compensator tau must be finite and > 0 s, got {tau}")
    if not (math.isfinite(ki) and ki >= 0):
        raise ValueError(f"roll compensator K_I must be finite and >= 0, got {ki}")


def compensator_tf(k: float, alpha: float, tau: float, ki: float) -> ct.TransferFunction:
    """Eq. 4.26: C(s) = K α (1 + τ s)/(1 + α τ s) + K_I/s (deg of command per deg of roll error)."""
    check_gains(k, alpha, tau, ki)
    s = ct.tf("s")
    lead = k * alpha * (1 + tau * s) / (1 + alpha * tau * s)
    return lead + ki / s if ki > 0 else lead


def roll_plant(delay: float = 0.01, pade_order: int = 3) -> ct.TransferFunction:
    """Eq. 3.4 roll response normalised to unit DC gain, times a Padé approximation of ``delay``."""
    p = ct.tf(*PLANT_TFS["roll"]) / ROLL_DC
    return p * ct.tf(*ct.pade(delay, pade_order)) if delay > 0 else p


def roll_loop(k: float, alpha: float, tau: float, ki: float, rate_hz: float = 50.0,
              pade_order: int = 3) -> tuple[ct.TransferFunction, ct.TransferFunction]:
    """(L, T): the inner loop broken at the YACS roll input, L = C·Gφ/Gφ(0)·e^{−s/(2 rate)}, and
    the closed loop φ/φ_c = L/(1 + L) (unity feedback on the INS roll)."""
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
    L = compensator_tf(k, alpha, tau, ki) * roll_plant(0.5 / rate_hz, pade_order)
    return L, ct.feedback(L, 1)


class RollCompensator:
    """Eq. 4.26 discretised by Tustin at ``rate_hz``: ``step(e_deg) -> v_deg`` once per sample;
    the YACS input is v / ``ROLL_DC``."""

    def __init__(self, k: float, alpha: float, tau: float, ki: float, rate_hz: float = 50.0,
                 input_limit: float = 500.0) -> None:
        check_gains(k, alpha, tau, ki)
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.ts = 1.0 / rate_hz
        c, ca = 2.0 * tau / self.ts, 2.0 * alpha * tau / self.ts
        # lead: y[n] = b0 e[n] + b1 e[n−1] − a1 y[n−1]; integral: i[n] = i[n−1] + K_I T/2 (e[n] + e[n−1])
        self.b0, self.b1 = k * alpha * (1 + c) / (1 + ca), k * alpha * (1 - c) / (1 + ca)
        self.a1 = (1 - ca) / (1 + ca)
        self.ki, self.kp_dc = ki, k * alpha
        self.limit = input_limit * ROLL_DC  # the YACS input limit in deg of command
        self.reset()

    def reset(self, e0: float = 0.0, v0: float | None = None) -> None:
        """Steady state at error ``e0``; with ``v0`` the integrator is set so that the output is v0."""
        self._e, self._y = float(e0), self.kp_dc * float(e0)
        self._i = 0.0 if v0 is None else float(v0) - self._y
        self.last = self._y + self._i
        self.started = v0 is not None

    def step(self, e: float) -> float:
        e = float(e)
        if not math.isfinite(e):
            raise ValueError(f"roll error must be finite, got {e}")
        y = self.b0 * e + self.b1 * self._e - self.a1 * self._y
        i = self._i + 0.5 * self.ki * self.ts * (e + self._e)
        v = y + i
        if abs(v) > self.limit and (i - self._i) * v > 0:  # anti-windup: integrate only up to the limit
            i = min(i, max(self._i, self.limit - y)) if v > 0 else max(i, min(self._i, -self.limit - y))
            v = y + i
        self._e, self._y, self._i, self.last = e, y, i, v
        return v
