"""PFCM outer loop on the YACS-augmented R-MAX (seed 002 §4.4, eq. 4.25), run at 50 Hz.

    YAW   = r_ff + K1y δψ
    PITCH = K1p δp_x + K2p δv_x + K3p d(δv_x)/dt + K4p ∫δv_x dt
    ROLL  = φ_ff + K1r δp_y + K2r δv_y                       (+ K3r ∫δp_y dt; eq. 4.26 inner loop, below)
    THR   = K1t δp_z + K2t δv_z + K3t ∫δv_z dt                (+ the target climb rate, see below)

δp, δv: control point minus helicopter and target velocity minus helicopter velocity, in the
heading frame (x forward, y right, z down; ``guidance/pfcm.py``). The gains here are in physical
units: the pitch and roll sums are accelerations [m/s²] turned into attitude commands
θ_c = −a_x/g, φ_c = φ_ff + a_y/g, the throttle sum is a climb-rate command [m/s] (the identified
YACS heave channel holds a climb rate: ``CLIMB_GAIN`` m/s per unit), the yaw sum a yaw rate; each
becomes YACS units through the inverse DC gains of eq. 3.4. ``PathLoopGains.yacs_units`` lists the
same gains in YACS units (what eq. 4.25 multiplies).

Departures from eq. 4.25, each switchable: (0) the pitch feed-forward θ_ff = (X_u u − u̇)/g of
eq. 4.14 with the target speed and its rate (the thesis left it out and saw the speed lag the
profile); (1) lateral integral action K3r ∫δp_y against the wind
(``roll_integral``; not part of eq. 4.26, which is the inner roll loop of (5)); (2) the pitch and
roll integrators are kept in the world frame and projected on the current body axes
(``world_integrators``): the wind drag they cancel is world-fixed, so a turn does not unwind
them; (3) the target climb rate is fed forward to the throttle, and (4) so is T_ff of eq. 4.14
(the thesis left it out): on this model thr *is* a climb-rate command and the vertical thrust lost
in a bank of φ_ff, g (1/cos φ_ff − 1), is made up by holding a climb rate that much faster against
the heave damping −Z_w (eq. 3.9), otherwise the helicopter sinks ~0.15 m in a 15° turn.
The roll command is limited to φ_max + 1.5° (``max_roll``; the trajectory generator plans turns at
φ_max), and a live generator is told the roll the lateral integrator spends against the wind
(``set_lateral_bias``), which it takes off φ_max for v_targ2.

(5) The inner roll compensator of §4.5 (eq. 4.26, Fig. 4.11 b; ``roll_compensator``, on by default
in the scenarios): instead of the open-loop DC inversion ail = φ_c/Gφ(0), a lead + integral
C(s) = K α (1 + τ s)/(1 + α τ s) + K_I/s on the roll error φ_c − φ (INS roll) drives the YACS roll
input (``control/rmax_roll.py``, Tustin at 50 Hz, anti-windup at the YACS limit). K = 3, α = 0.5,
τ = 0.5 s, K_I = 8 /s: inner crossover 4.78 rad/s, PM 68.2°, GM 17.2 dB, φ/φ_c bandwidth 5.59 rad/s
against 3.05 rad/s of the YACS roll response alone; roll-step rise time 0.40 s against 0.68 s on
the R-MAX model, 12.6 % overshoot. With it on, the lateral PID is designed on the inner closed loop
by the same rule (``design_path_loop(base=PathLoopGains(roll_compensator=True))``,
``COMPENSATED_LATERAL``): K1r 0.654 -> 2.421, K2r 1.523 -> 2.619, K3r 0.070 -> 0.559, lateral
crossover 1.46 -> 2.82 rad/s at 45° PM. Measured (seeds 1-4, mean): pfcm-spiral cross-track rms
0.276 -> 0.183 m, max 0.576 -> 0.417 m; pfcm-segment rms 0.072 -> 0.055 m, max unchanged (0.156 m);
speed error unchanged, max roll +0.5° (spiral) and +0.8° (segment). The gain comes from the stiffer lateral loop the inner
loop makes admissible: the inner loop under the old lateral gains changes nothing (spiral rms
0.280 m), and the new lateral gains without it track as well in these simulations but have only
19° PM on the identified model (docs/architecture.md, PFCM).

Tuning (``design_path_loop``): python-control on the eq. 3.4/3.9 plant of ``control/rmax.py``
(``design_position_loop``, loops broken at the actuator, 50 Hz sample-and-hold as a Padé delay).
Lateral: the largest-Kp PID with 45° phase margin and 6 dB gain margin (K1r, K2r, K3r = Kp, Kd,
Ki). Along the path δp_x ≈ 0 (the control point is the projection of the helicopter), so the
pitch loop is a velocity loop whose integral ∫δv_x is the along-track lag: the PD design of the
longitudinal axis gives K4p = Kp, K2p = Kd, and K1p = Kp holds the end point; K3p = 0. Vertical:
a PD on height (crossover 2 rad/s, 60° PM) gives K1t = Kp, K2t = Kd; K3t = 0.25 Kp catches up a
lag of the vertical profile. Yaw: P at 1 rad/s crossover. Checked in closed loop on the
``pfcm-segment`` and ``pfcm-spiral`` scenarios (tests/control/test_rmax_path.py, tests/mission).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from visnav.control.rmax import CLIMB_GAIN, PITCH_DC, ROLL_DC, YAW_RATE_DC, design_position_loop
from visnav.control.rmax_roll import ROLL_COMPENSATOR, RollCompensator, check_gains, roll_loop
from visnav.guidance.pfcm import PathReference, heading_rotation
from visnav.measurements import NavEstimate, YacsCommand
from visnav.log_schema import register_stream
from visnav.scalar import clip as _clip

register_stream("pfcm_control", phi_c=("rad", "", "roll command"), theta_c=("rad", "", "pitch command"),
                climb_c=("m/s", "up", "climb-rate command"), yaw_rate_c=("rad/s", "", "yaw-rate command"),
                **{k: ("YACS unit (+-500 = full stick)", "", f"{k} input to the YACS")
                   for k in ("ail", "ele", "rud", "thr")},
                dp=("m", "heading frame (x forward, y right, z down)", "control point minus position"),
                dv=("m/s", "heading frame (x forward, y right, z down)", "reference minus velocity"),
                i_x=("m", "heading x", "longitudinal integrator (of dv_x)"),
                i_y=("m s", "heading y", "lateral integrator (of dp_y)"),
                phi_ff=("rad", "", "feed-forward roll"),
                **{f"sat_{k}": ("bool", "", f"{k} saturated") for k in ("ail", "ele", "rud", "thr")},
                dt=("s", "", "time since the previous update that this one integrates (saturation time, integrators)"))

G = 9.81




#: lateral gains K1r, K2r, K3r designed on the eq. 4.26 inner roll loop (``design_path_loop`` with
#: ``base=PathLoopGains(roll_compensator=True)``; tests/control/test_rmax_roll.py checks them)
COMPENSATED_LATERAL = {"k1r": 2.421091, "k2r": 2.619277, "k3r": 0.559475}


@dataclass(frozen=True)
class PathLoopGains:
    """Eq. 4.25 gains in physical units (see the module docstring) and the command limits."""

    k1p: float = 0.320636  # m/s² per m (δp_x)
    k2p: float = 0.982764  # m/s² per m/s (δv_x)
    k3p: float = 0.0  # m/s² per m/s² (d δv_x/dt)
    k4p: float = 0.320636  # m/s² per m (∫δv_x)
    k1r: float = 0.654175  # m/s² per m (δp_y)
    k2r: float = 1.522924  # m/s² per m/s (δv_y)
    k3r: float = 0.070251  # m/s² per m s (∫δp_y), lateral wind integral; 0 = eq. 4.25
    k1t: float = 3.875260  # climb m/s per m (δh)
    k2t: float = 0.417461  # climb m/s per m/s (δḣ)
    k3t: float = 0.968815  # climb m/s per m (∫δḣ)
    k1y: float = 1.020278  # yaw rate rad/s per rad (δψ)
    climb_feedforward: bool = True
    pitch_feedforward: bool = True
    load_factor_feedforward: bool = True
    heave_damping: float = 0.6  # −Z_w of eq. 3.9 [1/s], for the load-factor feed-forward
    drag_xu: float = -0.025  # eq. 3.9 X_u [1/s], for θ_ff
    world_integrators: bool = True
    max_roll: float = math.radians(16.5)  # command limits [rad]: φ_max + 1.5° for corrections
    max_pitch: float = math.radians(15.0)
    max_yaw_rate: float = math.radians(40.0)  # [rad/s]
    max_climb_rate: float = 3.0  # [m/s]
    integral_limit: float = 1.5  # |K ∫| per channel [m/s²]
    derivative_tau: float = 0.1  # low-pass on d δv_x/dt [s]
    input_limit: float = 500.0
    roll_compensator: bool = False  # eq. 4.26 inner roll loop (control/rmax_roll.py) instead of the DC inversion
    roll_k: float = ROLL_COMPENSATOR["k"]  # eq. 4.26 K (high-frequency gain, per normalised roll plant)
    roll_alpha: float = ROLL_COMPENSATOR["alpha"]  # lead ratio, 0 < α <= 1
    roll_tau: float = ROLL_COMPENSATOR["tau"]  # lead zero time constant [s]
    roll_ki: float = ROLL_COMPENSATOR["ki"]  # integral gain [1/s]

    def __post_init__(self) -> None:
        check_gains(self.roll_k, self.roll_alpha, self.roll_tau, self.roll_ki)
        for name in ("k1p", "k2p", "k3p", "k4p", "k1r", "k2r", "k3r", "k1t", "k2t", "k3t", "k1y",
                     "integral_limit", "derivative_tau"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {v}")
        if not self.drag_xu <= 0:
            raise ValueError(f"drag_xu must be <= 0 (drag), got {self.drag_xu}")
        for name in ("max_roll", "max_pitch", "max_yaw_rate", "max_climb_rate", "input_limit", "heave_damping"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")

    @classmethod
    def with_roll_compensator(cls, **kw) -> PathLoopGains:
        """The eq. 4.26 inner roll loop on, with the lateral gains designed on it (``design_path_loop``)."""
        return cls(**{"roll_compensator": True, **COMPENSATED_LATERAL, **kw})

    def roll_closed_loop(self, rate_hz: float = 50.0):
        """φ/φ_c of the eq. 4.26 inner loop (python-control), or None when it is off."""
        if not self.roll_compensator:
            return None
        return roll_loop(self.roll_k, self.roll_alpha, self.roll_tau, self.roll_ki, rate_hz)[1]

    def yacs_units(self) -> dict[str, float]:
        """The gains as eq. 4.25 multiplies them: YACS units per m, per m/s, per rad (yaw)."""
        d = 180.0 / math.pi
        pitch, roll = d / (G * PITCH_DC), d / (G * ROLL_DC)
        return {"K1p": self.k1p * pitch, "K2p": self.k2p * pitch, "K3p": self.k3p * pitch, "K4p": self.k4p * pitch,
                "K1r": self.k1r * roll, "K2r": self.k2r * roll, "K3r": self.k3r * roll,
                "K1t": self.k1t / CLIMB_GAIN, "K2t": self.k2t / CLIMB_GAIN, "K3t": self.k3t / CLIMB_GAIN,
                "K1y": self.k1y * d / YAW_RATE_DC}


@dataclass(frozen=True)
class PathLoopDesign:
    gains: PathLoopGains
    margins: dict  # axis -> control.rmax.AxisMargins


def design_path_loop(rate_hz: float = 50.0, delay_s: float = 0.0, target_pm_deg: float = 45.0,
                     min_gm_db: float = 6.0, lateral_ki_ratio: float = 0.25, vertical_crossover: float = 2.0,
                     vertical_pm_deg: float = 60.0, vertical_profile_gain: float = 0.25,
                     yaw_crossover: float = 1.0, base: PathLoopGains | None = None) -> PathLoopDesign:
    """Eq. 4.25 gains from python-control loop shaping (the mapping in the module docstring).
    With ``base.roll_compensator`` the lateral loop is designed on the eq. 4.26 inner roll loop."""
    inner = base.roll_closed_loop(rate_hz) if base is not None else None
    lat = design_position_loop(rate_hz, delay_s, target_pm_deg, min_gm_db, ki_ratio=lateral_ki_ratio,
                               vertical_crossover=vertical_crossover, vertical_pm_deg=vertical_pm_deg,
                               vertical_ki_ratio=0.0, yaw_crossover=yaw_crossover, roll_loop=inner)
    lon = design_position_loop(rate_hz, delay_s, target_pm_deg, min_gm_db, ki_ratio=0.0,
                               vertical_crossover=vertical_crossover, vertical_pm_deg=vertical_pm_deg,
                               vertical_ki_ratio=0.0, yaw_crossover=yaw_crossover)
    a, b = lat.gains, lon.gains
    g = replace(base or PathLoopGains(), k1p=b.kp_lon, k2p=b.kd_lon, k3p=0.0, k4p=b.kp_lon,
                k1r=a.kp_lat, k2r=a.kd_lat, k3r=a.ki_lat, k1t=a.kp_vert, k2t=a.kd_vert,
                k3t=vertical_profile_gain * a.kp_vert, k1y=a.k_yaw)
    return PathLoopDesign(g, {"lateral": lat.lateral, "longitudinal": lon.longitudinal,
                              "vertical": lat.vertical, "yaw": lat.yaw})


class PathFollowingController:
    """Eq. 4.25 at ``rate_hz`` (50 Hz): a ``PathReference``, or a live trajectory generator with
    ``step(t, nav) -> PathReference`` (then guidance and control run together at this rate), plus
    the navigation solution -> ``YacsCommand``.

    ``saturation_time_s``: time with at least one channel saturated, i.e. its YACS input at ±500
    or its command limit (roll, pitch, yaw rate, climb rate) acting (per channel in
    ``channel_saturation_s``); ``recorder`` (optional) gets a ``pfcm_control`` row per update.
    """

    def __init__(self, gains: PathLoopGains | None = None, rate_hz: float = 50.0,
                 recorder: Callable[..., None] | None = None):
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.gains = gains if gains is not None else PathLoopGains()
        self.rate_hz = float(rate_hz)
        self.record = recorder
        self.reset()

    def reset(self) -> None:
        self._last_t: float | None = None
        self._i_lon = np.zeros(3)  # world-frame integrator of δv_x (along the body x axis) [m]
        self._i_lat = np.zeros(3)  # world-frame integrator of δp_y [m s]
        self._i_z = 0.0  # ∫δḣ [m]
        self._dvx_prev: float | None = None
        self._dvx_rate = 0.0
        self.saturation_time_s = 0.0
        self.channel_saturation_s = dict.fromkeys(("ail", "ele", "rud", "thr"), 0.0)
        self.last_reference: PathReference | None = None
        self.attitude_command = np.zeros(2)  # φ_c, θ_c [rad]
        k = self.gains
        self._roll = RollCompensator(k.roll_k, k.roll_alpha, k.roll_tau, k.roll_ki, self.rate_hz,
                                     k.input_limit) if k.roll_compensator else None

    def command(self, t: float, nav: NavEstimate, ref) -> YacsCommand:
        r = ref.step(t, nav) if hasattr(ref, "step") else ref
        if not isinstance(r, PathReference):
            raise ValueError(f"reference must be a PathReference or a generator of them, got {type(r).__name__}")
        for name, arr in (("nav.position", nav.position), ("nav.velocity", nav.velocity),
                          ("nav.attitude", nav.attitude)):
            if np.shape(arr) != (3,) or not math.isfinite(float(arr[0] + arr[1] + arr[2])):
                raise ValueError(f"{name} must be 3 finite values, got {arr}")
        dt = 0.0 if self._last_t is None else min(max(t - self._last_t, 0.0), 5.0 / self.rate_hz)
        self._last_t = t
        self.last_reference = r
        k = self.gains
        psi = float(nav.attitude[2])
        C = heading_rotation(psi)
        xb, yb = C[0], C[1]  # body x and y axes in NED (rows of the NED -> heading rotation)
        dp = C @ (np.asarray(r.position, float) - np.asarray(nav.position, float))
        dv = C @ (np.asarray(r.velocity, float) - np.asarray(nav.velocity, float))
        dp0, dp1, dp2 = dp.tolist()  # heading frame: along, across, down
        dv0, dv1, dv2 = dv.tolist()
        if not k.world_integrators:  # body-frame integrators: re-express the stored ones on the new axes
            self._i_lon = xb * (xb @ self._i_lon)
            self._i_lat = yb * (yb @ self._i_lat)
        # d δv_x/dt, first-order low-pass
        if self._dvx_prev is not None and dt > 0:
            a = dt / (k.derivative_tau + dt)
            self._dvx_rate += a * ((dv0 - self._dvx_prev) / dt - self._dvx_rate)
        self._dvx_prev = dv0
        # pitch and roll (accelerations), eq. 4.25 (+ the lateral integral)
        i_x, i_y = float(xb @ self._i_lon), float(yb @ self._i_lat)
        a_x = k.k1p * dp0 + k.k2p * dv0 + k.k3p * self._dvx_rate + k.k4p * i_x
        a_y = k.k1r * dp1 + k.k2r * dv1 + k.k3r * i_y
        theta_ff = (k.drag_xu * r.v_target - r.accel_target) / G if k.pitch_feedforward else 0.0
        theta_raw = theta_ff - a_x / G
        phi_raw = r.phi_ff + a_y / G
        theta_c = _clip(theta_raw, -k.max_pitch, k.max_pitch)
        phi_c = _clip(phi_raw, -k.max_roll, k.max_roll)
        # throttle: climb-rate command [m/s] (h up = −z)
        dh, dhd = -dp2, -dv2
        climb_ff = -float(r.velocity[2]) if k.climb_feedforward else 0.0
        if k.load_factor_feedforward:  # T_ff of eq. 4.14 as the climb rate the YACS must hold
            climb_ff += G * (1.0 / math.cos(r.phi_ff) - 1.0) / k.heave_damping
        w_raw = climb_ff + k.k1t * dh + k.k2t * dhd + k.k3t * self._i_z
        w_c = _clip(w_raw, -k.max_climb_rate, k.max_climb_rate)
        r_raw = r.r_ff + k.k1y * r.heading_error
        r_c = _clip(r_raw, -k.max_yaw_rate, k.max_yaw_rate)
        lim = k.input_limit
        roll_cmd = math.degrees(phi_c)  # open-loop DC inversion (eq. 4.25) ...
        if self._roll is not None:  # ... or the eq. 4.26 inner loop on the INS roll
            e = math.degrees(phi_c - float(nav.attitude[0]))
            if not self._roll.started:  # bumpless start: first output = the DC inversion
                self._roll.reset(e, roll_cmd)
            elif dt > 0:
                roll_cmd = self._roll.step(e)
            else:
                roll_cmd = self._roll.last
        raw = (roll_cmd / ROLL_DC, math.degrees(theta_c) / PITCH_DC, math.degrees(r_c) / YAW_RATE_DC,
               w_c / CLIMB_GAIN)
        # a channel is saturated when its YACS input is at ±input_limit or its command limit acts
        sat = (abs(raw[0]) >= lim or phi_raw != phi_c, abs(raw[1]) >= lim or theta_raw != theta_c,
               abs(raw[2]) >= lim or r_c != r_raw, abs(raw[3]) >= lim or w_raw != w_c)
        # integrators: conditional integration (anti-windup) and clamping
        if dt > 0:
            if not sat[1]:
                self._i_lon = self._clamp(self._i_lon + xb * (dv0 * dt), k.k4p, k.integral_limit)
            if not sat[0]:
                self._i_lat = self._clamp(self._i_lat + yb * (dp1 * dt), k.k3r, k.integral_limit)
            if not sat[3] and k.k3t > 0:
                self._i_z = _clip(self._i_z + dhd * dt, -k.max_climb_rate / k.k3t, k.max_climb_rate / k.k3t)
            if any(sat):
                self.saturation_time_s += dt
            for c, flag in zip(self.channel_saturation_s, sat):
                self.channel_saturation_s[c] += dt if flag else 0.0
        self.attitude_command = np.array([phi_c, theta_c])
        if hasattr(ref, "set_lateral_bias"):  # the roll the wind correction costs, for v_targ2
            ref.set_lateral_bias(k.k3r * self._i_lat[:2])
        cmd = YacsCommand(t=t, ail=_clip(raw[0], -lim, lim), ele=_clip(raw[1], -lim, lim),
                          rud=_clip(raw[2], -lim, lim), thr=_clip(raw[3], -lim, lim))
        if self.record is not None:
            self.record("pfcm_control", t, phi_c=phi_c, theta_c=theta_c, climb_c=w_c, yaw_rate_c=r_c,
                        ail=cmd.ail, ele=cmd.ele, rud=cmd.rud, thr=cmd.thr, dp=dp, dv=dv, i_x=i_x, i_y=i_y,
                        phi_ff=r.phi_ff, sat_ail=sat[0], sat_ele=sat[1],
                        sat_rud=sat[2], sat_thr=sat[3], dt=dt)
        return cmd

    @staticmethod
    def _clamp(v: np.ndarray, gain: float, limit: float) -> np.ndarray:
        n = math.sqrt(float(v @ v))
        cap = limit / gain if gain > 0 else 0.0
        return v * (cap / n) if n > cap and n > 0 else v
