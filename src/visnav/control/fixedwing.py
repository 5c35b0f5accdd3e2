"""Inner loops of the CONDOR orbit controller (seed 004 ch. 5, Fig. 5.1).

* aileron PD on the bank error, eq. 5.5: ``Delta A = -(K_Pphi (phi_ref - phi) - K_Dphi p)``;
* rudder P on the heading-rate error, eq. 5.6: ``Delta R = K_Ppsi (psi_dot_ref - psi_dot)`` with the
  inertial heading rate from the gyros, ``psi_dot = (q sin(phi) + r cos(phi)) / cos(theta)`` (the
  printed line lost its signs);
* bank-angle hold at 45 deg, eq. 5.7, with the rudder set to 10 deg, while |phi| > 45 deg (released
  below 40 deg);
* altitude PI giving the pitch reference, eq. 5.8, and elevator PD, eq. 5.9;
* an airspeed PI on the throttle (ArduPlane's speed loop; seed 004 does not print it);
* the turn coordinator the thesis names as the next step (§7.2.2, ch. 8): a rudder PI that nulls
  the body lateral specific force (the accelerometer's "ball").

The thesis' Delta A, Delta R, Delta E are ArduPlane servo conventions; the model's deflections
(Beard & McLain signs: positive aileron rolls right, positive rudder yaws left, positive elevator
pitches down) are ``delta_a = -Delta A``, ``delta_r = -Delta R``, ``delta_e = Delta E``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from visnav.measurements import Controls, FixedWingEstimate, TurnReference
from visnav.scalar import clip as _clip

G = 9.81




@dataclass(frozen=True)
class InnerGains:
    kp_phi: float = 2.0  # rad aileron / rad bank error
    kd_phi: float = 0.15  # rad / (rad/s)
    kp_psi: float = 0.6  # rad rudder / (rad/s) heading-rate error
    kp_h: float = 0.02  # rad pitch / m
    ki_h: float = 0.004  # rad pitch / (m s)
    kp_theta: float = 1.5
    kd_theta: float = 0.25
    kp_v: float = 0.08  # throttle / (m/s)
    ki_v: float = 0.02
    kp_ay: float = 0.04  # rad rudder / (m/s^2) lateral specific force
    ki_ay: float = 0.04
    bank_limit: float = math.radians(35.0)  # phi_ref limit (§5.1)
    bank_hold: float = math.radians(45.0)  # eq. 5.7
    hold_rudder: float = math.radians(10.0)
    theta_limit: float = math.radians(15.0)


@dataclass
class AirData:
    """What the autopilot measures: attitude (AHRS), body rates (gyros), baro height, airspeed (pitot),
    lateral specific force (accelerometer)."""

    phi: float
    theta: float
    p: float
    q: float
    r: float
    h: float
    Va: float
    ay: float

    @classmethod
    def from_estimate(cls, e: FixedWingEstimate) -> "AirData":
        """The navigator's estimate: AHRS attitude, gyro rates, baro height, pitot airspeed, accelerometer y."""
        phi, theta = np.asarray(e.attitude, float).tolist()[:2]
        p, q, r = np.asarray(e.body_rates, float).tolist()
        return cls(phi, theta, p, q, r, float(e.height), float(e.airspeed), float(e.specific_force[1]))


def heading_rate(phi: float, theta: float, q: float, r: float) -> float:
    """Inertial heading rate from body rates (eq. 5.6, second line)."""
    return (q * math.sin(phi) + r * math.cos(phi)) / math.cos(theta)


class FixedWingAutopilot:
    """The autopilot (Fig. 5.1) at ``rate_hz``: ``command(t, estimate, reference)`` flies the navigator's
    ``FixedWingEstimate`` (never truth) to a ``TurnReference``; ``info`` holds the last step's internals."""

    def __init__(self, gains: InnerGains, trim: Controls, rate_hz: float = 50.0) -> None:
        self.g, self.trim = gains, trim
        self.rate_hz = float(rate_hz)
        self.int_h = self.int_v = self.int_ay = 0.0
        self.bank_hold_active = False
        self._t: float | None = None
        self.info: dict = {"phi_ref": math.nan, "theta_ref": math.nan, "psidot": math.nan, "bank_hold": False}

    def command(self, t: float, estimate: FixedWingEstimate, reference: TurnReference) -> Controls:
        """Controls at ``t``; the integrators advance by the time since the previous call (1 / rate_hz first)."""
        dt = 1.0 / self.rate_hz if self._t is None else t - self._t
        self._t = t
        r = reference
        u, self.info = self.law(dt, AirData.from_estimate(estimate), r.psidot_ail, r.psidot_rud, r.v_bank,
                                r.altitude, r.airspeed)
        return u

    def law(self, dt: float, m: AirData, psidot_ref_ail: float, psidot_ref_rud: float | None,
            v_bank: float, h_des: float, va_des: float) -> tuple[Controls, dict]:
        """Controls for the two heading-rate references (aileron through the bank reference eq. 5.4,
        rudder eq. 5.6; ``psidot_ref_rud`` None = turn coordinator)."""
        g = self.g
        if not math.isfinite(m.phi + m.theta + m.p + m.q + m.r + m.h + m.Va + m.ay):  # (finite sum: all finite)
            for k, v in vars(m).items():
                if not math.isfinite(v):
                    raise ValueError(f"autopilot input {k} is not finite ({v!r})")
        phi_ref = _clip(math.atan(v_bank * psidot_ref_ail / G), -g.bank_limit, g.bank_limit)  # eq. 5.4
        psidot = heading_rate(m.phi, m.theta, m.q, m.r)
        if abs(m.phi) > g.bank_hold:
            self.bank_hold_active = True
        elif abs(m.phi) < g.bank_hold - math.radians(5.0):
            self.bank_hold_active = False
        if self.bank_hold_active:  # eq. 5.7
            dA = -(g.kp_phi * (math.copysign(g.bank_hold, m.phi) - m.phi) - g.kd_phi * m.p)
            dR = -math.copysign(g.hold_rudder, m.phi)  # yaw out of the turn
        else:
            dA = -(g.kp_phi * (phi_ref - m.phi) - g.kd_phi * m.p)  # eq. 5.5
            if psidot_ref_rud is None:  # turn coordinator
                self.int_ay += m.ay * dt
                self.int_ay = _clip(self.int_ay, -2.0, 2.0)
                dR = -(g.kp_ay * m.ay + g.ki_ay * self.int_ay)
            else:
                dR = g.kp_psi * (psidot_ref_rud - psidot)  # eq. 5.6
        # altitude hold eq. 5.8-5.9
        eh = h_des - m.h
        self.int_h = _clip(self.int_h + eh * dt, -g.theta_limit / max(g.ki_h, 1e-9),
                           g.theta_limit / max(g.ki_h, 1e-9))
        theta_ref = _clip(g.kp_h * eh + g.ki_h * self.int_h, -g.theta_limit, g.theta_limit)
        dE = -(g.kp_theta * (theta_ref - m.theta) - g.kd_theta * m.q)
        ev = va_des - m.Va
        self.int_v = _clip(self.int_v + ev * dt, -10.0, 10.0)
        thr = self.trim.throttle + g.kp_v * ev + g.ki_v * self.int_v
        u = Controls(aileron=-dA + self.trim.aileron, elevator=dE + self.trim.elevator,
                     rudder=-dR + self.trim.rudder, throttle=_clip(thr, 0.0, 1.0))
        info = {"phi_ref": phi_ref, "theta_ref": theta_ref, "psidot": psidot, "bank_hold": self.bank_hold_active}
        return u, info


def control_power(params, airspeed_mps: float) -> tuple[float, float, float]:
    """Angular acceleration [rad/s^2] per radian of aileron, elevator and rudder at ``airspeed_mps``
    (Beard & McLain eq. 4.15-4.16 with the deflection terms alone, the cross inertia ignored):
    q S b C_l_da / Jx, q S c C_m_de / Jy, q S b C_n_dr / Jz (magnitudes)."""
    p = params
    qs = 0.5 * p.rho * airspeed_mps * airspeed_mps * p.S
    return (abs(qs * p.b * p.C_l_da / p.Jx), abs(qs * p.c * p.C_m_de / p.Jy), abs(qs * p.b * p.C_n_dr / p.Jz))


def scaled_gains(gains: InnerGains, params, airspeed_mps: float, ref_params, ref_airspeed_mps: float) -> InnerGains:
    """``gains`` (tuned on ``ref_params`` at ``ref_airspeed_mps``) carried to another airframe: each surface's
    gains times the ratio of the reference's control power to this airframe's (``control_power``), so that
    an error commands the same angular acceleration as on the reference: aileron (``kp_phi``, ``kd_phi``),
    rudder (``kp_psi``, ``kp_ay``, ``ki_ay``), elevator damping (``kd_theta``). The elevator's proportional
    gain ``kp_theta`` stays: the pitch is held by the airframe's own static stability, so an elevator
    deflection sets an angle of attack (``C_m_de / C_m_alpha``, dimensionless) whatever the control power,
    and the same gain asks the same angle of attack per degree of pitch error (scaled with the rest, the
    pitch loop of the 0.41 m PingWing answers ~30x slower and the altitude hold sinks it). The ratios are
    exactly 1 for the reference itself; the outer loops (altitude, airspeed, heading rate) are unchanged."""
    a, e, r = (x0 / x1 for x0, x1 in zip(control_power(ref_params, ref_airspeed_mps),
                                          control_power(params, airspeed_mps)))
    return replace(gains, kp_phi=gains.kp_phi * a, kd_phi=gains.kd_phi * a, kp_psi=gains.kp_psi * r,
                   kp_ay=gains.kp_ay * r, ki_ay=gains.ki_ay * r, kd_theta=gains.kd_theta * e)
