"""6-DOF small fixed-wing UAV (seed 004's Skywalker stand-in), after Beard & McLain.

Equations of motion: R. W. Beard and T. W. McLain, *Small Unmanned Aircraft: Theory and Practice*,
Princeton University Press 2012, ch. 3 (eq. 3.14-3.17: position, body velocities, Euler angles, body
rates with the Gamma inertia terms) and ch. 4 (eq. 4.6-4.19: longitudinal and lateral forces and
moments, the blended lift of eq. 4.9-4.10, the quadratic drag polar of eq. 4.11, the propeller of
eq. 4.18). Aerodynamic coefficients and geometry: the book's Aerosonde table (Appendix E.2),
written here from the published table.

The Aerosonde flies at 25-35 m/s with 13.5 kg; seed 004's Skywalker cruises at 15-18 m/s. The mass
and inertias are therefore scaled down (default 5 kg, inertias x 5/13.5) so that the same airframe
trims at 17 m/s with a moderate angle of attack, and the motor constant ``k_motor`` is lowered to 30 m/s
so that cruise throttle sits near mid range. Deflections: aileron, elevator, rudder [rad] with the
book's signs (positive elevator = trailing edge down = nose down; positive aileron = right roll
negative moment per C_l_delta_a > 0 convention of the book: delta_a > 0 rolls right); throttle in [0, 1].

State: NED position, body velocity (u, v, w), Euler (roll, pitch, yaw), body rates (p, q, r).
Wind is NED air velocity (steady + Dryden from ``world/wind.py``), frozen over one step; ``step(command,
dt, environment)`` takes it as ``vehicles/base.Environment.wind_ned``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from visnav.geometry.rotations import euler_to_dcm, euler_to_dcm3
from visnav.vehicles.base import Environment
from visnav.vehicles.kernels import fixedwing_constants, fixedwing_derivatives, fixedwing_rk4
from visnav.measurements import Controls, VehicleState  # noqa: F401  (Controls re-exported: the command type lives in measurements)

G = 9.81


@dataclass(frozen=True)
class FixedWingParams:
    """Beard & McLain Aerosonde (App. E.2); mass/inertia scaled to the Skywalker's speed (see module)."""

    mass: float = 5.0
    Jx: float = 0.8244 * 5.0 / 13.5
    Jy: float = 1.135 * 5.0 / 13.5
    Jz: float = 1.759 * 5.0 / 13.5
    Jxz: float = 0.1204 * 5.0 / 13.5
    S: float = 0.55
    b: float = 2.8956
    c: float = 0.18994
    S_prop: float = 0.2027
    rho: float = 1.2682
    k_motor: float = 30.0
    C_prop: float = 1.0
    e: float = 0.9
    M: float = 50.0
    alpha0: float = 0.4712
    # longitudinal
    C_L_0: float = 0.28
    C_L_alpha: float = 3.45
    C_L_q: float = 0.0
    C_L_de: float = -0.36
    C_D_p: float = 0.0437
    C_D_q: float = 0.0
    C_D_de: float = 0.0
    C_m_0: float = -0.02338
    C_m_alpha: float = -0.38
    C_m_q: float = -3.6
    C_m_de: float = -0.5
    # lateral
    C_Y_0: float = 0.0
    C_Y_beta: float = -0.98
    C_Y_p: float = 0.0
    C_Y_r: float = 0.0
    C_Y_da: float = 0.0
    C_Y_dr: float = -0.17
    C_l_0: float = 0.0
    C_l_beta: float = -0.12
    C_l_p: float = -0.26
    C_l_r: float = 0.14
    C_l_da: float = 0.08
    C_l_dr: float = 0.105
    C_n_0: float = 0.0
    C_n_beta: float = 0.25
    C_n_p: float = 0.022
    C_n_r: float = -0.35
    C_n_da: float = 0.06
    C_n_dr: float = -0.032
    max_deflection: float = math.radians(30.0)

    @property
    def AR(self) -> float:
        return self.b * self.b / self.S

    def gammas(self) -> tuple[float, ...]:
        """Gamma_1..Gamma_8 of Beard & McLain eq. 3.13."""
        Jx, Jz, Jxz, Jy = self.Jx, self.Jz, self.Jxz, self.Jy
        g = Jx * Jz - Jxz * Jxz
        return (Jxz * (Jx - Jy + Jz) / g, (Jz * (Jz - Jy) + Jxz * Jxz) / g, Jz / g, Jxz / g,
                (Jz - Jx) / Jy, Jxz / Jy, ((Jx - Jy) * Jx + Jxz * Jxz) / g, Jx / g)


def _lift_drag(p: FixedWingParams, alpha: float) -> tuple[float, float]:
    """C_L (eq. 4.9-4.10, sigma-blended flat plate past stall) and C_D (eq. 4.11) at ``alpha``."""
    ea, eb = math.exp(-p.M * (alpha - p.alpha0)), math.exp(p.M * (alpha + p.alpha0))
    sigma = (1.0 + ea + eb) / ((1.0 + ea) * (1.0 + eb))
    cl_lin = p.C_L_0 + p.C_L_alpha * alpha
    sa = math.sin(alpha)
    cl = (1.0 - sigma) * cl_lin + sigma * 2.0 * math.copysign(1.0, alpha) * sa * sa * math.cos(alpha)
    cd = p.C_D_p + cl_lin * cl_lin / (math.pi * p.e * p.AR)
    return cl, cd


def derivatives(p: FixedWingParams, x: np.ndarray, u: Controls, wind_ned: np.ndarray,
                gam: tuple | None = None) -> tuple[np.ndarray, dict]:
    """dx/dt of the 12-state model (eq. 3.14-3.17) and the air data (Va, alpha, beta, specific force)."""
    _, _, _, uu, vv, ww, phi, th, psi, P, Q, R = np.asarray(x, float).tolist()
    C = euler_to_dcm3(phi, th, psi)  # body -> NED (eq. 3.14's rotation)
    ur, vr, wr = (np.array([uu, vv, ww]) - C.T @ wind_ned).tolist()  # air-relative body velocity (eq. 2.7)
    Va = math.sqrt(ur * ur + vr * vr + wr * wr)  # eq. 2.8
    Va_s = max(Va, 1.0)
    alpha = math.atan2(wr, ur)
    beta = math.asin(max(-1.0, min(1.0, vr / Va_s)))
    qbar = 0.5 * p.rho * Va_s * Va_s * p.S
    cl, cd = _lift_drag(p, alpha)
    ca, sa = math.cos(alpha), math.sin(alpha)
    da, de, dr, dt = u.aileron, u.elevator, u.rudder, u.throttle
    # eq. 4.19 longitudinal force coefficients in body axes
    cx, cxq, cxde = -cd * ca + cl * sa, -p.C_D_q * ca + p.C_L_q * sa, -p.C_D_de * ca + p.C_L_de * sa
    cz, czq, czde = -cd * sa - cl * ca, -p.C_D_q * sa - p.C_L_q * ca, -p.C_D_de * sa - p.C_L_de * ca
    c2v, b2v = p.c / (2.0 * Va_s), p.b / (2.0 * Va_s)
    m, ct, st, cf, sf = p.mass, math.cos(th), math.sin(th), math.cos(phi), math.sin(phi)
    thrust = 0.5 * p.rho * p.S_prop * p.C_prop * ((p.k_motor * dt) ** 2 - Va * Va)  # eq. 4.18
    fx = -m * G * st + qbar * (cx + cxq * c2v * Q + cxde * de) + thrust  # eq. 4.18
    fy = m * G * ct * sf + qbar * (p.C_Y_0 + p.C_Y_beta * beta + p.C_Y_p * b2v * P + p.C_Y_r * b2v * R
                                   + p.C_Y_da * da + p.C_Y_dr * dr)
    fz = m * G * ct * cf + qbar * (cz + czq * c2v * Q + czde * de)
    l_m = qbar * p.b * (p.C_l_0 + p.C_l_beta * beta + p.C_l_p * b2v * P + p.C_l_r * b2v * R
                        + p.C_l_da * da + p.C_l_dr * dr)  # eq. 4.19
    m_m = qbar * p.c * (p.C_m_0 + p.C_m_alpha * alpha + p.C_m_q * c2v * Q + p.C_m_de * de)
    n_m = qbar * p.b * (p.C_n_0 + p.C_n_beta * beta + p.C_n_p * b2v * P + p.C_n_r * b2v * R
                        + p.C_n_da * da + p.C_n_dr * dr)
    g1, g2, g3, g4, g5, g6, g7, g8 = gam or p.gammas()
    pos_dot = C @ np.array([uu, vv, ww])  # eq. 3.14
    vel_dot = (R * vv - Q * ww + fx / m, P * ww - R * uu + fy / m, Q * uu - P * vv + fz / m)  # eq. 3.15
    tt = st / ct
    eul_dot = (P + sf * tt * Q + cf * tt * R, cf * Q - sf * R, (sf * Q + cf * R) / ct)  # eq. 3.16
    rate_dot = (g1 * P * Q - g2 * Q * R + g3 * l_m + g4 * n_m,  # eq. 3.17
                g5 * P * R - g6 * (P * P - R * R) + m_m / p.Jy,
                g7 * P * Q - g1 * Q * R + g4 * l_m + g8 * n_m)
    dx = np.array([*pos_dot.tolist(), *vel_dot, *eul_dot, *rate_dot])
    air = {"Va": Va, "alpha": alpha, "beta": beta,
           "specific_force": np.array([fx, fy, fz]) / m - C[2] * G}  # f/m - C^T (0, 0, g)
    return dx, air


@dataclass
class FixedWingModel:
    """RK4 integration of :func:`derivatives`; ``state`` is a :class:`VehicleState`."""

    params: FixedWingParams = field(default_factory=FixedWingParams)
    x: np.ndarray = field(default_factory=lambda: np.zeros(12))
    t: float = 0.0
    #: step through ``vehicles/kernels.fixedwing_rk4`` (the same equations on floats, held to this module's
    #: ``derivatives`` at 1e-12 by the tests); False: the readable RK4 below
    kernel: bool = True

    def __post_init__(self) -> None:
        self._gam = self.params.gammas()
        self._k = fixedwing_constants(self.params, self._gam)
        self._air = {"Va": 0.0, "alpha": 0.0, "beta": 0.0, "specific_force": np.zeros(3)}
        self._air_at: tuple | None = None  # (state, controls, wind) of the last step: air data on demand
        self._air_raw: tuple | None = None  # the kernel step's air data at its new state, not yet read
        self._state_x: np.ndarray | None = None  # the x and t ``state`` was built for
        self._state_t = math.nan

    @property
    def air(self) -> dict:
        """Airspeed ``Va``, ``alpha``, ``beta`` and the specific force (body) after the last step;
        evaluated when first read (a loop that reads it at its control rate skips the rest)."""
        if self._air_at is not None:
            x1, uc, w = self._air_at
            if self.kernel:
                u4 = (uc.aileron, uc.elevator, uc.rudder, uc.throttle)
                self._air_raw = fixedwing_derivatives(self._k, x1.tolist(), u4, w.tolist(), air=True)[1]
            else:
                self._air = derivatives(self.params, x1, uc, w, self._gam)[1]
            self._air_at = None
        if self._air_raw is not None:  # the kernel's step evaluated them at the new state
            Va, alpha, beta, f = self._air_raw
            self._air = {"Va": Va, "alpha": alpha, "beta": beta, "specific_force": np.array(f)}
            self._air_raw = None
        return self._air

    def hold_air_data(self, u: Controls, wind_ned) -> None:
        """The air data ``air`` reports before the first step: those of the current state under ``u`` and the wind."""
        self._air_at, self._air_raw = (self.x.copy(), self._clip(u), np.asarray(wind_ned, float)), None

    @classmethod
    def from_trim(cls, params: FixedWingParams, trim: "Trim", position_ned, heading: float) -> "FixedWingModel":
        x = trim.state.copy()
        x[0:3] = position_ned
        x[8] = heading
        return cls(params, x)

    def _clip(self, u: Controls) -> Controls:
        """The controls within the surfaces' deflection limits and the throttle's [0, 1]."""
        lim = self.params.max_deflection
        return Controls(min(max(float(u.aileron), -lim), lim), min(max(float(u.elevator), -lim), lim),
                        min(max(float(u.rudder), -lim), lim), min(max(float(u.throttle), 0.0), 1.0))

    def step(self, u: Controls, dt: float, environment: Environment) -> None:
        """Classic RK4 of :func:`derivatives` over ``dt`` with the controls and the environment's wind held."""
        uc = self._clip(u)
        if not isinstance(environment, Environment):
            raise TypeError(f"FixedWingModel.step takes a vehicles.base.Environment, got {type(environment).__name__}")
        w = np.asarray(environment.wind_ned, float)
        if not all(map(math.isfinite, w.tolist())):
            raise ValueError(f"wind must be finite, got {environment.wind_ned}")

        def f(x):
            return derivatives(self.params, x, uc, w, self._gam)[0]

        x = self.x
        air = None
        if self.kernel:  # the air data at the new state come with the step (before the yaw wrap: the same to rounding)
            u4 = (uc.aileron, uc.elevator, uc.rudder, uc.throttle)
            x1, air = fixedwing_rk4(self._k, x.tolist(), u4, w.tolist(), dt, air=True)
        else:
            k1 = f(x)
            k2 = f(x + 0.5 * dt * k1)
            k3 = f(x + 0.5 * dt * k2)
            k4 = f(x + dt * k3)
            x1 = (x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)).tolist()
        x1[8] = (x1[8] + math.pi) % (2 * math.pi) - math.pi
        if not all(map(math.isfinite, x1)):
            raise FloatingPointError(f"fixed-wing state diverged at t={self.t:.2f}s")
        self.x = x1 = np.array(x1)
        self.t += dt
        self._air_at, self._air_raw = (None, air) if air is not None else ((x1, uc, w), None)

    def euler_rates(self) -> np.ndarray:
        return derivatives(self.params, self.x, Controls(), np.zeros(3), self._gam)[0][6:9]

    def velocity_ned(self) -> np.ndarray:
        """NED velocity (``state.velocity`` without building the whole state)."""
        x = self.x
        return _dcm(x[6:9]) @ x[3:6]

    @property
    def state(self) -> VehicleState:
        """Truth at ``t`` (cached until the next step or until ``x`` is replaced; change ``x`` by
        assigning a new array, not in place, after reading ``state``)."""
        x = self.x
        # (keyed on the array itself, not its id, which a new array could reuse)
        if x is not self._state_x or self.t != self._state_t:
            C = euler_to_dcm3(*x[6:9].tolist())
            self._state = VehicleState(t=self.t, position=x[0:3].copy(), velocity=C @ x[3:6], euler=x[6:9].copy(),
                                       body_rates=x[9:12].copy(), specific_force=self.air["specific_force"])
            self._state_x, self._state_t = x, self.t
        return self._state


def _dcm(e) -> np.ndarray:
    return euler_to_dcm(np.asarray(e, float))


@dataclass
class Trim:
    state: np.ndarray  # 12 states (position 0, heading 0)
    controls: Controls
    alpha: float
    beta: float
    residual: float


def trim(params: FixedWingParams, Va: float, turn_radius: float = math.inf, gamma: float = 0.0) -> Trim:
    """Trim for wings-level flight (``turn_radius`` inf) or a steady coordinated turn at constant
    airspeed (Beard & McLain §5.3): unknowns alpha, beta, roll, and the four controls; residuals the
    body accelerations and angular accelerations (no wind), the climb rate, and zero lateral specific
    force (a coordinated turn: the rudder's side force is balanced by a little sideslip).
    Solved with ``scipy.optimize.least_squares``."""
    from scipy.optimize import least_squares

    if not Va > 0:
        raise ValueError(f"Va must be positive, got {Va!r}")
    psi_dot = 0.0 if math.isinf(turn_radius) else Va * math.cos(gamma) / turn_radius

    def build(z):
        alpha, beta, phi, da, de, dr, dt = z
        u = Va * math.cos(alpha) * math.cos(beta)
        v = Va * math.sin(beta)
        w = Va * math.sin(alpha) * math.cos(beta)
        # pitch from the flight-path angle (Beard & McLain §5.3): sin(gamma) = a sin(theta) - b cos(theta)
        a = math.cos(alpha) * math.cos(beta)
        b = math.sin(phi) * math.sin(beta) + math.cos(phi) * math.sin(alpha) * math.cos(beta)
        sg = math.sin(gamma)
        theta = math.atan2(a * b + sg * math.sqrt(max(a * a - sg * sg + b * b, 0.0)), a * a - sg * sg)
        p_ = -psi_dot * math.sin(theta)
        q_ = psi_dot * math.sin(phi) * math.cos(theta)
        r_ = psi_dot * math.cos(phi) * math.cos(theta)
        x = np.array([0, 0, 0, u, v, w, phi, theta, 0, p_, q_, r_], float)
        return x, Controls(da, de, dr, dt)

    def res(z):
        x, c = build(z)
        dx, air = derivatives(params, x, c, np.zeros(3))
        out = list(dx[3:6]) + list(dx[9:12])
        # climb rate and the coordinated-turn condition: no lateral specific force (ball centred)
        out.append(dx[2] + Va * math.sin(gamma))
        out.append(air["specific_force"][1])
        return np.array(out)

    sol = least_squares(res, np.array([0.05, 0.0, 0.0, 0.0, -0.05, 0.0, 0.6]),
                        bounds=([-0.3, -0.3, -1.2, -0.5, -0.5, -0.5, 0.0], [0.4, 0.3, 1.2, 0.5, 0.5, 0.5, 1.0]),
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    x, c = build(sol.x)
    return Trim(x, c, float(sol.x[0]), float(sol.x[1]), float(np.abs(sol.fun).max()))


def default_trim(Va: float = 17.0) -> tuple[FixedWingParams, Trim]:
    p = FixedWingParams()
    return p, trim(p, Va)


__all__ = ["FixedWingParams", "Controls", "FixedWingModel", "Trim", "trim", "derivatives", "default_trim"]


#: span [m] and cruise speed [m/s] of the airframe whose wing area and propeller disc ``micro_params`` keeps
#: (rounds 1-4 of the geo-location mission flew this Aerosonde scaled geometrically to 1.1 m span, at 13 m/s)
MICRO_REFERENCE_SPAN_M = 1.1
MICRO_REFERENCE_AIRSPEED_MPS = 13.0


def micro_params(mass: float = 0.434, span: float = 0.41, cruise_mps: float = 19.0) -> FixedWingParams:
    """The PingWing of seed 002 §7.4.1 ("a wing span of 41 centimeters and a total weight of 434 grams ...
    a cruise speed of 19 m/s"), on the Aerosonde's dimensionless coefficients.

    The chapter gives span, mass and cruise speed, not the wing area. Scaling the Aerosonde geometrically
    to 0.41 m span (aspect ratio 15) would leave 0.011 m^2 of wing: C_L 1.7 at 19 m/s, a 21 deg angle of
    attack and 86 % throttle, not an aircraft. The wing area is therefore kept at that of the airframe the
    mission flew in rounds 1-4 (the Aerosonde scaled to ``MICRO_REFERENCE_SPAN_M`` = 1.1 m: 0.079 m^2,
    wing loading 5.5 kg/m^2; an assumption): on 0.41 m of span a 0.19 m mean chord, aspect ratio 2.1,
    a stubby flying wing as the MAV competitions' size limits produce. The Aerosonde is rectangular
    (c = S / b), so the chord is the area over the span; the dimensionless coefficients stay (the drag
    polar's induced term takes the new aspect ratio); the inertias scale as mass x span^2 from the
    Aerosonde's (13.5 kg, 2.8956 m; radii of gyration 8.5 % of the span in roll); the propeller disc is
    that airframe's too (0.029 m^2, a 19 cm propeller); the motor constant is 25 m/s x cruise / 13 m/s,
    so that cruise needs about 55 % throttle at any ``cruise_mps`` (19 m/s: alpha -0.9 deg, 55.5 %
    throttle, elevator -2 deg, the Aerosonde's camber giving C_L 0.28 at zero alpha; a 35 deg
    coordinated turn: 53 m radius, 55.7 % throttle). The surfaces turn this airframe 6x (roll, yaw) to
    40x (pitch) faster per radian than the 1.1 m one: its autopilot gains are carried over by
    ``control.fixedwing.scaled_gains``.

    ``span=1.1, cruise_mps=13`` is exactly the airframe of rounds 1-4 (alpha 3.1 deg, 55 % throttle)."""
    base = FixedWingParams()
    k = span / base.b
    kr = MICRO_REFERENCE_SPAN_M / base.b  # wing area and propeller disc of the reference airframe
    sm = mass / 13.5 * k * k  # inertia scale from the original Aerosonde (13.5 kg, span 2.8956 m)
    return replace(base, mass=mass, Jx=0.8244 * sm, Jy=1.135 * sm, Jz=1.759 * sm, Jxz=0.1204 * sm,
                   S=base.S * kr * kr, b=span, c=base.c * kr * (kr / k), S_prop=base.S_prop * kr * kr,
                   k_motor=25.0 * cruise_mps / MICRO_REFERENCE_AIRSPEED_MPS)
