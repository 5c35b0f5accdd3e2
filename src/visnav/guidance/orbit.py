"""Outer loop of the CONDOR circular orbit (seed 004 ch. 5 and §7.2, Table 7.1).

Heading-rate reference = base heading rate + heading-rate error:

* error, eq. 5.1: ``psi_dot_err = K_P (R - R_des) + K_D R_dot`` for a right-hand orbit (target on the
  right wing, right turn positive). The print reads ``-(K_P (R - R_des) - K_D R_dot)``, whose
  proportional sign pushes the aircraft away from the circle while its damping sign is right; we take
  the stable sign for both (R > R_des: turn in more).
* base, original logic (eq. 5.2, Table 7.1): ``V_IAS / R``, the rate that holds the *current*
  circle, limited to +-40 % of the nominal ``V / R_des`` (§5.1);
* base, modified logic (eq. 7.1, Table 7.1): ``V_GS_avg / R_des``, constant; without GPS the mean
  ground speed over a loop is taken as the running mean of the airspeed (over a full circle in a
  steady wind the two differ by (W/V)^2 / 4, 1.5 % at 8 kt);
* in the modified logic the rudder keeps the original logic (§7.2.2); ``coordinated`` is the modified
  aileron logic with the rudder on a turn coordinator (the next step of §7.2.2, ch. 8).

R and R_dot come from the navigator (``navigation/condor.py``: GPS in the loiter, the vision radius
through the lossy, late link and its alpha-beta ``RadiusFilter`` in the orbit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from visnav.scalar import clip as _clip

LOGICS = ("original", "modified", "coordinated")


@dataclass(frozen=True)
class OrbitGains:
    kp: float  # rad/s per m of radius error
    kd: float  # rad/s per m/s of radius rate


class OrbitGuidance:
    def __init__(self, logic: str, r_des: float, v_nominal: float, original: OrbitGains, modified: OrbitGains,
                 base_limit: float = 0.4, v_avg_tau_s: float = 60.0) -> None:
        if logic not in LOGICS:
            raise ValueError(f"orbit logic must be one of {', '.join(LOGICS)}, got {logic!r}")
        if not r_des > 0:
            raise ValueError(f"desired radius must be positive, got {r_des!r}")
        self.logic, self.r_des, self.v_nom = logic, r_des, v_nominal
        self.g_orig, self.g_mod = original, modified
        self.base_limit, self.tau = base_limit, v_avg_tau_s
        self.v_avg = v_nominal

    def _err(self, g: OrbitGains, R: float, Rdot: float) -> float:
        return g.kp * (R - self.r_des) + g.kd * Rdot  # eq. 5.1 (sign, see module)

    def update(self, dt: float, R: float, Rdot: float, v_ias: float) -> dict:
        """Heading-rate references for aileron and rudder (None: turn coordinator) and the components
        plotted in Figs. 7.6 / 7.12."""
        self.v_avg += (v_ias - self.v_avg) * min(1.0, dt / self.tau)
        nominal = self.v_nom / self.r_des
        base_orig = _clip(v_ias / max(R, 1.0), (1 - self.base_limit) * nominal,
                                  (1 + self.base_limit) * nominal)  # eq. 5.2 limited +-40 %
        err_orig = self._err(self.g_orig, R, Rdot)
        if self.logic == "original":
            base, err, v_bank = base_orig, err_orig, v_ias
            rud = base_orig + err_orig  # eq. 5.3
        else:
            base = self.v_avg / self.r_des  # eq. 7.1
            err, v_bank = self._err(self.g_mod, R, Rdot), self.v_avg
            rud = base_orig + err_orig if self.logic == "modified" else None
        return {"psidot_ref_ail": base + err, "psidot_ref_rud": rud, "base": base, "err": err, "v_bank": v_bank}
