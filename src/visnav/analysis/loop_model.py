"""Analytic loop of the R-MAX position loop flying on MPE with late sensors (seed 000 §5.1-5.2).

The model behind Tables 5.1/5.2: how a mismatch between the instant an image describes and the
instant of the attitude MPE pairs it with, magnified by the height, moves the broken-loop response
at the cyclic actuator.
"""

from __future__ import annotations

import functools

import control as ct
import numpy as np

from visnav.analysis.frequency import AXIS_INDEX, margins_from_frd
from visnav.control.rmax import AxisMargins
from visnav.estimation.position_filter import PositionFilter
from visnav.control.rmax import DRAG, RmaxPositionGains, _freq, normalized_plant


@functools.lru_cache(maxsize=32)
def _filter_gains(accel_noise: float = 0.3, sigma_m: float = 0.02, imu_rate_hz: float = 100.0,
                  update_rate_hz: float = 10.0) -> tuple[float, float]:
    """Steady-state (K_p, K_v) of the navigator's PositionFilter per position update, found by
    running its own covariance recursion to convergence."""

    f = PositionFilter(accel_noise, np.zeros(3), np.zeros(3))
    f.t, n = 0.0, max(1, int(round(imu_rate_hz / update_rate_hz)))
    k = (0.0, 0.0)
    for i in range(400):
        for j in range(n):
            f.predict((i * n + j + 1) / imu_rate_hz, np.zeros(3))
        P = f.axis_covariance(0)  # the north axis' (p, v) covariance before the update: K = P H^T / (H P H^T + r), H = (1, 0)
        k = (P[0, 0] / (P[0, 0] + sigma_m**2), P[1, 0] / (P[0, 0] + sigma_m**2))
        f.update_position(np.zeros(3), sigma_m)
    return k


def _model(axis: str, s, delay, altitude_m: float, delay_s: float | None, compensation_s: float,
           gains, rate_hz: float, filter_gains, image_delay_s: float = 0.0):
    """The loop of ``model_loop`` with ``s`` = jω (array) or ``control.tf('s')`` and ``delay(t)`` =
    e^{−st} or its Padé approximation."""

    if axis not in AXIS_INDEX:
        raise ValueError(f"axis must be one of {sorted(AXIS_INDEX)}, got {axis!r}")
    if not (np.isfinite(altitude_m) and altitude_m > 0):
        raise ValueError(f"altitude_m must be > 0, got {altitude_m}")
    if delay_s is not None and not (np.isfinite(delay_s) and delay_s >= 0):
        raise ValueError(f"delay_s must be >= 0 or None (GPS), got {delay_s}")
    if not np.isfinite(compensation_s):
        raise ValueError(f"compensation_s must be finite, got {compensation_s}")
    if not (np.isfinite(image_delay_s) and image_delay_s >= 0):
        raise ValueError(f"image_delay_s must be >= 0, got {image_delay_s}")
    T = 1.0 / rate_hz
    k = gains or RmaxPositionGains()
    kp, kd, ki = (k.kp_lat, k.kd_lat, k.ki_lat) if axis == "lateral" else (k.kp_lon, k.kd_lon, k.ki_lon)
    D = DRAG["y"] if axis == "lateral" else DRAG["x"]
    hold = delay(T / 2)
    tau = 0.0 if delay_s is None else float(delay_s)
    c = float(image_delay_s)
    if delay_s is None:
        M = 1
    else:  # image of t − c paired with the attitude of t − (τ − comp): the mismatch times h
        M = delay(c) - altitude_m / 9.81 * s * (s - D) * (delay(c) - delay(tau - compensation_s))
    kpos, kvel = filter_gains or _filter_gains(update_rate_hz=rate_hz)
    k1, k2 = kpos / T, kvel / T
    den = s * s + k1 * s + k2
    p_hat = (k1 * s + k2) / den * M * hold + s * s / den * delay(tau)
    v_hat = s * p_hat + k1 * (p_hat - M * hold)
    return ((kp + ki / s) * p_hat + kd * v_hat) * hold


def model_loop(axis: str, w, altitude_m: float = 12.0, delay_s: float | None = 0.0,
               compensation_s: float = 0.0, gains=None, rate_hz: float = 10.0,
               filter_gains: tuple[float, float] | None = None, image_delay_s: float = 0.0) -> np.ndarray:
    """L(jω) at the cyclic actuator of the R-MAX position loop flying on MPE (``delay_s`` None: GPS).

    Attitude late by τ' = delay_s − compensation_s tilts MPE's line of sight: the fix errs by
    h·(θ(t) − θ(t−τ')) in x and −h·(φ(t) − φ(t−τ')) in y (h the height: the vertical of the range
    vector R, R·sin 60°). With the position dynamics θ = −s(s−X_u)x/g (φ = s(s−Y_v)y/g) the MPE
    fix is y_m = M(s)·x, M = 1 − (h/g)s(s−D)(1 − e^{−sτ'}). An image late by c behind its stamp
    (``image_delay_s``: seed 000 §5.1, the frame paired with the attitude at the end of its ~10 ms
    of processing) shows x(t−c) and the tilt of t−c: M = e^{−sc} − (h/g)s(s−D)(e^{−sc} − e^{−sτ'}),
    so even a "0 ms" IMU (τ' = 0) leaves a mismatch c magnified by h. The navigator's Kalman filter
    (steady-state gains K_p, K_v per 10 Hz fix; K1 = K_p/T, K2 = K_v/T) blends it with the IMU
    acceleration, itself late by τ: p̂ = F_l·M·e^{−sT/2}·x + F_h·e^{−sτ}·x, F_l = (K1 s + K2)/Δ,
    F_h = s²/Δ, Δ = s² + K1 s + K2, v̂ = s p̂ + K1 (p̂ − y_m e^{−sT/2}); the PID acts on p̂ and v̂:
    L = [(Kp + Ki/s) p̂/x + Kd v̂/x]·P(s)·e^{−sT/2}, P the eq. 3.4 plant of
    ``control.rmax.normalized_plant`` and e^{−sT/2} the 10 Hz hold. With τ = τ' = 0 (and for GPS)
    p̂ = x up to the hold: L reduces to ``control.rmax.position_loop``.
    """

    w = np.asarray(w, float)
    s = 1j * w
    L = _model(axis, s, lambda t: np.exp(-s * t), altitude_m, delay_s, compensation_s, gains, rate_hz,
               filter_gains, image_delay_s)
    return L * _freq(normalized_plant(axis, 0.0), w)


def model_margins(altitude_m: float, delay_s: float | None, axis: str = "lateral",
                  compensation_s: float = 0.0, w_max: float = 2 * np.pi * 2.5, **kw) -> AxisMargins:
    """Margins of ``model_loop`` by ``margins_from_frd`` on 0.05 rad/s .. ``w_max`` (the band a
    sweep measures; the model is no good near the 10 Hz loop's Nyquist frequency anyway)."""
    w = np.geomspace(0.05, w_max, 1500)
    return margins_from_frd(w, model_loop(axis, w, altitude_m, delay_s, compensation_s, **kw))


def model_stable(altitude_m: float, delay_s: float | None, axis: str = "lateral",
                 compensation_s: float = 0.0, pade_order: int = 5, **kw) -> bool:
    """Closed-loop stability of ``model_loop`` (delays as Padé approximations; a compensation
    beyond the delay counts as exact)."""

    def delay(t: float):
        return ct.tf(*ct.pade(t, pade_order)) if t > 0 else ct.tf([1.0], [1.0])

    L = _model(axis, ct.tf("s"), delay, altitude_m, delay_s, compensation_s, kw.get("gains"),
               kw.get("rate_hz", 10.0), kw.get("filter_gains"), kw.get("image_delay_s", 0.0)) * normalized_plant(axis, 0.0)
    return bool(np.all(ct.poles(ct.feedback(L, 1)).real < 0))

