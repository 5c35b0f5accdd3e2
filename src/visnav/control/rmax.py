"""PALACE position loop for the YACS-augmented RMAX (seed 000 §2.1.2, Fig. 2.3; seed 002 eq. 3.4).

A 10 Hz loop takes the world-frame position and velocity errors to the 'white rabbit'
(``PositionReference``), rotates them by the heading into the body frame (the actuators act in
body axes, seed 000 §2.1.2), turns them into desired accelerations by PID (+ reference-velocity
and drag feed-forward), then into attitude commands θ_c = −a_x/g, φ_c = a_y/g, and into YACS units
through the inverse DC gains of eq. 3.4. The gains come from ``design_position_loop`` (loop broken
at the cyclic actuator, as in seed 000 §5.2, Tables 5.1/5.2).

This module keeps its own copy of the eq. 3.4 plant (control/ does not import vehicles/).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import control as ct
import numpy as np
from scipy import optimize

from visnav.measurements import NavEstimate, PositionReference, YacsCommand
from visnav.scalar import clip as _clip

G = 9.81
#: seed 002 eq. 3.4 (num, den): roll [deg], pitch [deg], yaw rate [deg/s] per YACS unit, heave [g]
PLANT_TFS: dict[str, tuple[list[float], list[float]]] = {
    "roll": (list(2.3 * np.array([1.0, 3.87, 53.3])), list(np.polymul([1, 6.29, 16.2], [1, 8.97, 168.0]))),
    "pitch": (list(0.5 * np.array([1.0, 9.76, 75.5])), list(np.polymul([1, 3.0, 5.55], [1, 2.06, 123.5]))),
    "yaw_rate": (list(9.7 * np.array([1.0, 12.25])), list(np.polymul([1, 4.17], [1, 3.5, 213.4]))),
    "heave": (list(0.0828 * np.polymul([1, 0], [1, 3.37])), list(np.polymul([1, 0.95], [1, 13.1, 214.1]))),
}
#: eq. 3.9 drag derivatives Xu, Yv and the effective heave damping [1/s]. The vehicle model's
#: default acts Zw on the air mass only (the identified aZ/thr already holds a climb rate, see
#: vehicles/rmax.py), so the heave plant seen by the controller has no own-motion damping: 0.
DRAG = {"x": -0.025, "y": -0.1, "z": 0.0}


def _dc(name: str, order: int = 0) -> float:
    num, den = PLANT_TFS[name]
    return num[-1 - order] / den[-1]


ROLL_DC, PITCH_DC, YAW_RATE_DC = _dc("roll"), _dc("pitch"), _dc("yaw_rate")  # deg (/s) per unit
#: aZ/thr = s H(s), H(0) [g s per unit]: without the Zw drag a thr step is a climb-rate step of g H(0)
HEAVE_H0 = _dc("heave", 1)
CLIMB_GAIN = G * HEAVE_H0  # [m/s per unit]; with Zw the steady climb rate of a held thr is 0


def normalized_plant(axis: str, delay: float = 0.05, pade_order: int = 3,
                     roll_loop: ct.TransferFunction | None = None) -> ct.TransferFunction:
    """Plant seen by the PID at the cyclic (or pedal, collective) actuator, per unit of PID output.

    lateral:  a_y -> ail = deg(a_y/g)/φ_dc -> φ (eq. 3.4) -> v̇ = Yv v + gφ -> y: Gφ/Gφ(0)/(s(s−Yv))
    longit.:  a_x -> ele = deg(−a_x/g)/θ_dc -> θ -> u̇ = Xu u − gθ -> x:        Gθ/Gθ(0)/(s(s−Xu))
    vertical: a -> thr = a/(g H(0)) -> aZ = s H(s) thr -> ḧ = Zw ḣ + g aZ -> h:  H/H(0)/(s−Zw)
    yaw:      ψ̇_c -> rud -> r (eq. 3.4) -> ψ:                                 Gr/Gr(0)/s
    times a Padé approximation of ``delay`` (half a controller sample + any sensor delay).
    ``roll_loop``: φ/φ_c of an inner roll loop (unit DC gain, e.g. the eq. 4.26 compensator of
    ``control/rmax_path.py``) that replaces the open-loop DC inversion Gφ/Gφ(0) of the lateral axis.
    """
    s = ct.tf("s")
    if roll_loop is not None and axis != "lateral":
        raise ValueError(f"roll_loop applies to the lateral axis only, got axis {axis!r}")
    if axis == "lateral":
        roll = ct.tf(*PLANT_TFS["roll"]) / ROLL_DC if roll_loop is None else roll_loop
        p = roll / (s * (s - DRAG["y"]))
    elif axis == "longitudinal":
        p = ct.tf(*PLANT_TFS["pitch"]) / PITCH_DC / (s * (s - DRAG["x"]))
    elif axis == "vertical":
        num, den = PLANT_TFS["heave"]
        p = ct.tf(np.asarray(num[:-1]) / HEAVE_H0, den) / (s - DRAG["z"])  # num/s = H(s)
    elif axis == "yaw":
        p = ct.tf(*PLANT_TFS["yaw_rate"]) / YAW_RATE_DC / s
    else:
        raise ValueError(f"axis must be lateral, longitudinal, vertical or yaw, got {axis!r}")
    if not delay >= 0:
        raise ValueError(f"delay must be >= 0 s, got {delay}")
    if delay > 0:
        p = p * ct.tf(*ct.pade(delay, pade_order))
    return p


def pid_tf(kp: float, kd: float, ki: float) -> ct.TransferFunction:
    """C(s) = Kp + Kd s + Ki/s (Kd acts on the measured velocity; same loop gain)."""
    s = ct.tf("s")
    return kp + kd * s + (ki / s if ki else 0 * s)


@dataclass(frozen=True)
class AxisMargins:
    """Margins of one loop broken at its actuator. ``gm_db``: upper gain margin (gain increase)."""

    gm_db: float
    pm_deg: float
    w_gc: float  # gain crossover [rad/s] (where the PM is read)
    w_pc: float  # phase crossover [rad/s] (where the GM is read)


@dataclass(frozen=True)
class AxisDesign:
    """Gains of one axis (PID output in m/s² or rad/s before the YACS scaling) and its margins."""

    kp: float
    kd: float
    ki: float
    margins: AxisMargins


def loop_margins(loop: ct.TransferFunction) -> AxisMargins:
    """Stability margins by ``control.stability_margins``; the GM is the one above crossover."""
    gm, pm, _, w180, wc, _ = ct.stability_margins(loop, returnall=True)
    gm, pm, w180, wc = (np.atleast_1d(np.asarray(a, float)) for a in (gm, pm, w180, wc))
    i = int(np.argmin(np.abs(pm)))
    upper = (w180 > wc[i]) & (gm > 0)
    j = np.flatnonzero(upper)
    k = j[np.argmin(gm[j])] if j.size else None
    return AxisMargins(gm_db=float(20 * np.log10(gm[k])) if k is not None else math.inf,
                       pm_deg=float(pm[i]), w_gc=float(wc[i]),
                       w_pc=float(w180[k]) if k is not None else math.nan)


def _freq(tf: ct.TransferFunction, w: np.ndarray) -> np.ndarray:
    num, den = np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)
    return np.polyval(num, 1j * w) / np.polyval(den, 1j * w)


def _integrators(tf: ct.TransferFunction) -> int:
    """Poles minus zeros at s = 0 (trailing zero coefficients)."""
    def trailing(c: np.ndarray) -> int:
        c = np.asarray(c, float)
        return len(c) - 1 - int(np.flatnonzero(c)[-1])
    return trailing(tf.den[0][0]) - trailing(tf.num[0][0])


def _loop_ok(L: np.ndarray, n_int: int, pm_min: float, gm_min_db: float) -> bool:
    """Grid check of a loop response: every gain crossover at PM >= pm_min, every −180° crossing
    at least gm_min_db away from |L| = 1 (gain increase above the crossover, decrease below)."""
    mag = np.abs(L)
    ph = np.degrees(np.unwrap(np.angle(L)))
    ph -= 360.0 * np.round((ph[0] + 90.0 * n_int) / 360.0)  # low-frequency branch: −90°/integrator
    ic = np.flatnonzero(np.diff(np.sign(mag - 1.0)) != 0)
    if ic.size == 0:
        return False
    phc = ph[ic]
    if np.any((phc < -180.0 + pm_min) | (phc > 180.0 - pm_min)):
        return False
    k = np.floor((ph + 180.0) / 360.0)
    i180 = np.flatnonzero(k[:-1] != k[1:])
    lim = gm_min_db / 20.0
    above = i180 > ic.max()
    lm = np.log10(mag[i180])
    return bool(np.all(np.where(above, lm <= -lim, lm >= lim)))


def _pm_locus(P: np.ndarray, w: np.ndarray, pm: float, ki_ratio: float) -> tuple[np.ndarray, ...]:
    """PID gains that put the crossover at each ω with phase margin pm:
    C(jω) = e^{j(pm−180°)}/P(jω), Kp = Re C, Kd ω − Ki/ω = Im C with Ki = ki_ratio Kp²/Kd."""
    C = np.exp(1j * np.radians(pm - 180.0)) / P
    kp, b = C.real, C.imag
    kdw = (b + np.sqrt(b * b + 4.0 * ki_ratio * kp * kp)) / 2.0
    kd = kdw / w
    ki = np.divide(ki_ratio * kp * kp, kd, out=np.zeros_like(kd), where=kd > 0)
    return kp, kd, ki


def _design_pid(plant: ct.TransferFunction, pm_min: float, gm_min_db: float, ki_ratio: float,
                w: np.ndarray) -> AxisDesign:
    """Largest Kp on the constant-phase-margin locus (see ``design_position_loop``)."""
    n_int = _integrators(plant) + (1 if ki_ratio > 0 else 0)
    P = _freq(plant, w)
    jw = 1j * w

    def ok(kp: float, kd: float, ki: float) -> bool:
        return _loop_ok((kp + kd * jw + ki / jw) * P, n_int, pm_min, gm_min_db)

    def gains(x: float) -> tuple[float, float, float]:
        return tuple(float(g[0]) for g in _pm_locus(_freq(plant, np.array([x])), np.array([x]),
                                                     pm_min, ki_ratio))

    kp, kd, ki = _pm_locus(P, w, pm_min, ki_ratio)
    for i in np.argsort(-kp):
        if not (kp[i] > 0 and kd[i] > 0) or not ok(kp[i], kd[i], ki[i]):
            continue
        lo, hi = w[max(i - 1, 0)], w[min(i + 1, len(w) - 1)]
        x = optimize.minimize_scalar(lambda z: -gains(z)[0], bounds=(lo, hi), method="bounded",
                                     options={"xatol": 1e-9}).x
        g = gains(x)
        if g[0] < kp[i] or not ok(*g):
            g = (float(kp[i]), float(kd[i]), float(ki[i]))
        loop = pid_tf(*g) * plant
        _check_stable(loop)
        return AxisDesign(*g, loop_margins(loop))
    raise RuntimeError(f"no PID gains reach {pm_min} deg phase margin with {gm_min_db} dB gain margin")


def _gains_at(plant: ct.TransferFunction, w_c: float, pm: float, ki_ratio: float) -> AxisDesign:
    """PID gains placing the crossover at w_c with phase margin pm (on the locus of ``_pm_locus``)."""
    kp, kd, ki = (float(g[0]) for g in _pm_locus(_freq(plant, np.array([w_c])), np.array([w_c]),
                                                   pm, ki_ratio))
    if not (kp > 0 and kd >= 0):
        raise ValueError(f"crossover {w_c} rad/s cannot have {pm} deg phase margin with a PID")
    loop = pid_tf(kp, kd, ki) * plant
    _check_stable(loop)
    return AxisDesign(kp, kd, ki, loop_margins(loop))


def _crossover_limit(plant: ct.TransferFunction, pm: float, w: np.ndarray) -> float:
    """Highest crossover a PD (lead <= 90°) can give at phase margin pm: phase(P) = pm − 270°."""
    P = _freq(plant, w)
    ph = np.degrees(np.unwrap(np.angle(P)))
    ph -= 360.0 * np.round((ph[0] + 90.0 * _integrators(plant)) / 360.0)
    i = np.flatnonzero(ph >= pm - 270.0)
    return float(w[i[-1]]) if i.size else math.nan


def _check_stable(loop: ct.TransferFunction) -> None:
    poles = ct.poles(ct.feedback(loop, 1))
    if np.any(poles.real >= 0):
        raise RuntimeError(f"designed loop is closed-loop unstable: poles {poles}")


@dataclass(frozen=True)
class RmaxPositionGains:
    """PID gains of the position loop (outputs: accelerations [m/s²], yaw rate [rad/s]), limits,
    and the drag derivatives used for feed-forward. Defaults: ``design_position_loop()``."""

    kp_lon: float = 0.281020
    kd_lon: float = 0.945858
    ki_lon: float = 0.0208732
    kp_lat: float = 0.544867
    kd_lat: float = 1.36656
    ki_lat: float = 0.0543116
    kp_vert: float = 3.79614
    kd_vert: float = 1.27653
    ki_vert: float = 2.82224
    k_yaw: float = 1.02028
    max_tilt: float = math.radians(15.0)  # attitude command limit [rad]
    max_yaw_rate: float = math.radians(30.0)  # [rad/s]
    integral_limit: float = 1.0  # horizontal integral contribution [m/s²]
    integral_zone: float = 0.5  # integrate while the horizontal error is below this [m], or ...
    integral_speed_zone: float = 0.2  # ... the velocity error stayed below this [m/s] ...
    integral_settle_time: float = 2.0  # ... for this long [s] (a steady offset, not a transient)
    drag: tuple[float, float, float] = (DRAG["x"], DRAG["y"], DRAG["z"])  # Xu, Yv, Zw [1/s]
    input_limit: float = 500.0

    def __post_init__(self) -> None:
        for name in ("kp_lon", "kd_lon", "ki_lon", "kp_lat", "kd_lat", "ki_lat", "kp_vert", "kd_vert",
                     "ki_vert", "k_yaw", "integral_limit", "integral_zone", "integral_speed_zone",
                     "integral_settle_time"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {v}")
        for name in ("max_tilt", "max_yaw_rate", "input_limit"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class DesignResult:
    """Outcome of ``design_position_loop``: gains, margins per axis (loops broken at the actuator),
    the loop transfer functions, and the highest crossover a PD could reach at the target PM."""

    gains: RmaxPositionGains
    lateral: AxisMargins
    longitudinal: AxisMargins
    vertical: AxisMargins
    yaw: AxisMargins
    loops: dict[str, ct.TransferFunction] = field(repr=False)
    crossover_limit: dict[str, float]
    rate_hz: float
    delay_s: float


def design_position_loop(rate_hz: float = 10.0, delay_s: float = 0.0, target_pm_deg: float = 45.0,
                         min_gm_db: float = 6.0, ki_ratio: float = 0.25, vertical_crossover: float = 2.0,
                         vertical_pm_deg: float = 60.0, vertical_ki_ratio: float = 0.25,
                         yaw_crossover: float = 1.0, pade_order: int = 3,
                         base: RmaxPositionGains | None = None,
                         roll_loop: ct.TransferFunction | None = None) -> DesignResult:
    """Design the PALACE position loop on the eq. 3.4 / 3.9 RMAX model.

    Each loop is broken at its actuator (seed 000 §5.2): L(s) = C(s)·P(s) with P from
    ``normalized_plant`` and a Padé approximation of the delay 1/(2·rate_hz) + delay_s (the
    sample-and-hold of the 10 Hz loop plus any measurement delay).

    Lateral and longitudinal: a PID C = Kp + Kd s + Ki/s with Ki = ki_ratio·Kp²/Kd. Putting the
    crossover at ω with phase margin φm fixes C(jω) = e^{j(φm−180°)}/P(jω), so Kp = Re C(jω)
    whatever the Kd/Ki split, and Kd ω − Ki/ω = Im C(jω) (ki_ratio = 0.25 puts a double zero at
    Kp/(2 Kd): C = Kd (s + Kp/(2Kd))²/s; 0 gives a PD). The design takes the ω that maximises
    Kp (the stiffest position loop) among those whose full loop keeps every crossover at >= φm
    and a gain margin >= min_gm_db, then reports the margins by ``control.stability_margins``.
    The highest crossover any PD could reach (pure velocity feedback, no position stiffness) is
    returned as ``crossover_limit``; the thesis' loop (seed 000 Table 5.2, 45.8° at 2.92 rad/s
    lateral) wraps the ARP attitude loop, which eq. 3.4 already contains.
    Vertical (PID, thr) and yaw (P, rud): crossover placed at the given frequency.
    ``roll_loop``: an inner roll closed loop φ/φ_c under the lateral axis (``normalized_plant``).
    """
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
    if not (np.isfinite(delay_s) and delay_s >= 0):
        raise ValueError(f"delay_s must be >= 0, got {delay_s}")
    if not 0 < target_pm_deg < 90:
        raise ValueError(f"target_pm_deg must be in (0, 90), got {target_pm_deg}")
    if not ki_ratio >= 0:
        raise ValueError(f"ki_ratio must be >= 0, got {ki_ratio}")
    delay = 0.5 / rate_hz + delay_s
    w = np.geomspace(0.01, min(100.0, 20 * math.pi * rate_hz), 4000)
    axes = ("lateral", "longitudinal", "vertical", "yaw")
    plants = {a: normalized_plant(a, delay, pade_order, roll_loop if a == "lateral" else None) for a in axes}
    lat = _design_pid(plants["lateral"], target_pm_deg, min_gm_db, ki_ratio, w)
    lon = _design_pid(plants["longitudinal"], target_pm_deg, min_gm_db, ki_ratio, w)
    vert = _gains_at(plants["vertical"], vertical_crossover, vertical_pm_deg, vertical_ki_ratio)
    k_yaw = float(1.0 / abs(_freq(plants["yaw"], np.array([yaw_crossover]))[0]))
    gains = replace(base or RmaxPositionGains(), kp_lon=lon.kp, kd_lon=lon.kd, ki_lon=lon.ki,
                    kp_lat=lat.kp, kd_lat=lat.kd, ki_lat=lat.ki, kp_vert=vert.kp, kd_vert=vert.kd,
                    ki_vert=vert.ki, k_yaw=k_yaw)
    loops = {a: position_loop(a, gains, rate_hz, delay_s, pade_order, roll_loop if a == "lateral" else None)
             for a in plants}
    _check_stable(loops["yaw"])
    limit = {a: _crossover_limit(plants[a], target_pm_deg, w) for a in ("lateral", "longitudinal")}
    return DesignResult(gains, lat.margins, lon.margins, vert.margins, loop_margins(loops["yaw"]),
                        loops, limit, float(rate_hz), float(delay_s))


def position_loop(axis: str, gains: RmaxPositionGains | None = None, rate_hz: float = 10.0,
                  delay_s: float = 0.0, pade_order: int = 3,
                  roll_loop: ct.TransferFunction | None = None) -> ct.TransferFunction:
    """Loop transfer function of one axis broken at its actuator, for given gains and an extra
    measurement delay (e.g. the 43 ms attitude delay of seed 000 §5.2)."""
    k = gains or RmaxPositionGains()
    pid = {"lateral": (k.kp_lat, k.kd_lat, k.ki_lat), "longitudinal": (k.kp_lon, k.kd_lon, k.ki_lon),
           "vertical": (k.kp_vert, k.kd_vert, k.ki_vert), "yaw": (k.k_yaw, 0.0, 0.0)}
    if axis not in pid:
        raise ValueError(f"axis must be one of {sorted(pid)}, got {axis!r}")
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
    return pid_tf(*pid[axis]) * normalized_plant(axis, 0.5 / rate_hz + delay_s, pade_order, roll_loop)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class RmaxPositionController:
    """The PALACE position loop (seed 000 §2.1.2): white rabbit + navigation -> YACS command.

    Recomputes every 1/rate_hz and holds its output in between. Horizontal errors are rotated by
    the heading into body axes; the integrators live in the world frame (wind is world-fixed)
    with clamping and conditional integration as anti-windup.
    """

    def __init__(self, gains: RmaxPositionGains | None = None, rate_hz: float = 10.0) -> None:
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.gains = gains if gains is not None else RmaxPositionGains()
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / rate_hz
        self.reset()

    def reset(self) -> None:
        """Forget the held output, the schedule and the integrators."""
        self._next: float | None = None
        self._last_t: float | None = None
        self._held = YacsCommand(t=0.0)
        self._int_ne = np.zeros(2)  # world-frame horizontal integral [m/s²]
        self._slow_time = 0.0  # how long the horizontal velocity error has been small [s]
        self._int_z = 0.0  # vertical integral [m/s² per unit of the normalised plant]
        self.attitude_command = np.zeros(2)  # φ_c, θ_c of the last update [rad]

    def command(self, t: float, nav: NavEstimate, ref: PositionReference) -> YacsCommand:
        """The YACS command at time t (recomputed when a 1/rate_hz tick is due)."""
        if self._next is not None and t < self._next - 1e-9:
            return self._held
        for name, arr in (("nav.position", nav.position), ("nav.velocity", nav.velocity),
                          ("ref.position", ref.position), ("ref.velocity", ref.velocity)):
            if np.shape(arr) != (3,) or not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be 3 finite values, got {arr}")
        dt = 0.0 if self._last_t is None else min(t - self._last_t, 2 * self.period)
        self._last_t = t
        self._next = t + self.period if self._next is None or t > self._next + self.period \
            else self._next + self.period
        self._held = self._update(t, dt, nav, ref)
        return self._held

    def _update(self, t: float, dt: float, nav: NavEstimate, ref: PositionReference) -> YacsCommand:
        k = self.gains
        xu, yv, zw = k.drag
        ep = np.asarray(ref.position, float) - np.asarray(nav.position, float)
        ev = np.asarray(ref.velocity, float) - np.asarray(nav.velocity, float)
        psi = float(nav.attitude[2])
        c, s = math.cos(psi), math.sin(psi)
        to_body = np.array([[c, s], [-s, c]])  # world (N, E) -> heading frame (x fwd, y right)
        e_b, ev_b, vr_b = to_body @ ep[:2], to_body @ ev[:2], to_body @ np.asarray(ref.velocity, float)[:2]
        i_b = to_body @ self._int_ne
        a_x = k.kp_lon * e_b[0] + k.kd_lon * ev_b[0] + i_b[0] - xu * vr_b[0]
        a_y = k.kp_lat * e_b[1] + k.kd_lat * ev_b[1] + i_b[1] - yv * vr_b[1]
        theta_c = _clip(-a_x / G, -k.max_tilt, k.max_tilt)
        phi_c = _clip(a_y / G, -k.max_tilt, k.max_tilt)
        sat = np.array([abs(a_x / G) > k.max_tilt, abs(a_y / G) > k.max_tilt])
        self._slow_time = self._slow_time + dt if np.hypot(*ev[:2]) < k.integral_speed_zone else 0.0
        settled = np.hypot(*ep[:2]) < k.integral_zone or self._slow_time >= k.integral_settle_time
        if dt > 0 and settled:  # conditional integration (anti-windup)
            di_b = np.where(sat, 0.0, np.array([k.ki_lon * e_b[0], k.ki_lat * e_b[1]]) * dt)
            self._int_ne = self._int_ne + to_body.T @ di_b
            n = np.hypot(*self._int_ne)
            if n > k.integral_limit:
                self._int_ne *= k.integral_limit / n
        # vertical: h = −z; thr = (Kp e_h + Kd ė_h + I)/(g H(0)); İ = Ki e_h − Zw ḣ_ref (drag ff)
        e_h, ed_h, hd_ref = -ep[2], -ev[2], -float(ref.velocity[2])
        thr = (k.kp_vert * e_h + k.kd_vert * ed_h + self._int_z) / CLIMB_GAIN
        if abs(thr) < k.input_limit:
            zmax = k.input_limit * CLIMB_GAIN
            self._int_z = _clip(self._int_z + (k.ki_vert * e_h - zw * hd_ref) * dt, -zmax, zmax)
        r_c = _clip(k.k_yaw * _wrap(ref.yaw - psi), -k.max_yaw_rate, k.max_yaw_rate)
        self.attitude_command = np.array([phi_c, theta_c])
        lim = k.input_limit
        return YacsCommand(
            t=t,
            ail=_clip(math.degrees(phi_c) / ROLL_DC, -lim, lim),
            ele=_clip(math.degrees(theta_c) / PITCH_DC, -lim, lim),
            rud=_clip(math.degrees(r_c) / YAW_RATE_DC, -lim, lim),
            thr=_clip(thr, -lim, lim),
        )
