"""PFCM speed limits (seed 002 §4.3.3): trimmed-turn limits (eq. 4.15-4.16), the vortex-ring
descent limit (eq. 4.22-4.23), the braking speed (eq. 4.20) and the flight-envelope parameters."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

G = 9.81


def kinematic_speed_limits(radius_y: ArrayLike, r_max: float, phi_max: float, theta_max: float,
                           nz_max: float, xu: float = -0.025, g: float = G) -> dict[str, np.ndarray]:
    """u1..u4 of eq. 4.15 for the lateral curvature radius R_y^b [m] (trimmed level turn):
    u1 = |R r_max| (yaw rate), u2 = |g θ_max/X_u| (pitch, drag), u3 = sqrt(|φ_max g R|) (roll),
    u4 = |g (Nz_max − 1) g R²|^(1/4) (load factor, T_max = −Nz_max g). Vectorized over R."""
    for name, v in (("r_max", r_max), ("phi_max", phi_max), ("theta_max", theta_max)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be > 0, got {v}")
    if not nz_max > 1:
        raise ValueError(f"nz_max must be > 1 (load factor T_max/g), got {nz_max}")
    if not xu < 0:
        raise ValueError(f"xu must be < 0 (drag derivative), got {xu}")
    R = np.abs(np.asarray(radius_y, float))
    return {
        "u1": R * r_max,
        "u2": np.full(R.shape, abs(g * theta_max / xu)),
        "u3": np.sqrt(phi_max * g * R),
        "u4": (g * g * (nz_max - 1.0) * R * R) ** 0.25,
    }


def max_path_speed(radius_y: ArrayLike, r_max: float, phi_max: float, theta_max: float, nz_max: float,
                   xu: float = -0.025, g: float = G, include_pitch: bool = False) -> np.ndarray:
    """u_max = min(u1, u3, u4) (eq. 4.16); u2 joins only with ``include_pitch`` (the thesis leaves it
    out: the planner's cruise speed is always below it). R = inf (straight) gives inf."""
    u = kinematic_speed_limits(radius_y, r_max, phi_max, theta_max, nz_max, xu, g)
    out = np.minimum(np.minimum(u["u1"], u["u3"]), u["u4"])
    return np.minimum(out, u["u2"]) if include_pitch else out


def nz_max_for_mass(mass_kg: float, max_takeoff_kg: float = 94.0) -> float:
    """Load factor that keeps thrust within the maximum take-off weight (§4.3.3: 94 kg R-MAX)."""
    if not 0 < mass_kg < max_takeoff_kg:
        raise ValueError(f"mass_kg must be in (0, {max_takeoff_kg}), got {mass_kg}")
    return max_takeoff_kg / mass_kg


def hover_induced_velocity(mass_kg: float = 80.0, rotor_diameter_m: float = 3.115, rho: float = 1.225,
                           g: float = G) -> float:
    """V_i = sqrt(DL/(2ρ)) (eq. 4.22 in SI; the thesis' 60 sqrt(DL/2ρ) is the same in ft/min)."""
    if not (mass_kg > 0 and rotor_diameter_m > 0 and rho > 0):
        raise ValueError(f"mass, diameter and rho must be > 0, got {mass_kg}, {rotor_diameter_m}, {rho}")
    disk_loading = mass_kg * g / (math.pi * rotor_diameter_m**2 / 4.0)  # N/m²
    return math.sqrt(disk_loading / (2.0 * rho))


def descent_angle(tau: ArrayLike) -> np.ndarray:
    """γ = atan(τ_z/τ_x) (eq. 4.23) with τ_x the horizontal part; > 0 descending (NED z down)."""
    t = np.asarray(tau, float)
    return np.arctan2(t[..., 2], np.hypot(t[..., 0], t[..., 1]))


def max_descent_rate(gamma: ArrayLike, steep_angle: float = math.radians(30.0), w_steep: float = 1.5,
                     w_shallow: float = 3.0) -> np.ndarray:
    """w_MAXdescent of eq. 4.23 / Fig. 4.8: w_steep for γ >= steep_angle, w_shallow below; inf when
    not descending (γ <= 0)."""
    g = np.asarray(gamma, float)
    return np.where(g <= 0.0, np.inf, np.where(g >= steep_angle, w_steep, w_shallow))


def descent_speed_limit(tau: ArrayLike, steep_angle: float = math.radians(30.0), w_steep: float = 1.5,
                        w_shallow: float = 3.0) -> np.ndarray:
    """v_targ3 = w_MAXdescent/τ_z (eq. 4.23) for unit tangents τ (..., 3); inf when not descending."""
    t = np.asarray(tau, float)
    tz = t[..., 2]
    w = max_descent_rate(descent_angle(t), steep_angle, w_steep, w_shallow)
    return np.where(tz > 1e-9, w / np.maximum(tz, 1e-9), np.inf)


def brake_speed(l_end: ArrayLike, accel: float, v_end: ArrayLike = 0.0) -> np.ndarray:
    """v_brake = sqrt(|2 l_end Acc + v_end²|) (eq. 4.20)."""
    return np.sqrt(np.abs(2.0 * np.asarray(l_end, float) * accel + np.asarray(v_end, float) ** 2))


@dataclass(frozen=True)
class PfcmLimits:
    """Flight-envelope limits of §4.3.3 (angles in radians). ``r_max``: the thesis prints
    "40 rad/sec", read as 40 deg/s (0.70 rad/s). ``v_end``: speed at the end of the path."""

    v_cruise: float
    accel: float = 1.2
    r_max: float = math.radians(40.0)
    phi_max: float = math.radians(15.0)
    theta_max: float = math.radians(15.0)
    nz_max: float = 1.1
    vrs_steep_angle: float = math.radians(30.0)
    w_descent_steep: float = 1.5
    w_descent_shallow: float = 3.0
    v_end: float = 0.0
    xu: float = -0.025
    anticipate: bool = True

    def __post_init__(self) -> None:
        if not (np.isfinite(self.v_cruise) and self.v_cruise > 0):
            raise ValueError(f"v_cruise must be > 0 m/s, got {self.v_cruise}")
        if not (np.isfinite(self.accel) and self.accel > 0):
            raise ValueError(f"accel must be > 0 m/s², got {self.accel}")
        for name in ("w_descent_steep", "w_descent_shallow"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 m/s, got {getattr(self, name)}")
        if not 0 < self.vrs_steep_angle < math.pi / 2:
            raise ValueError(f"vrs_steep_angle must be in (0, pi/2), got {self.vrs_steep_angle}")
        if not self.v_end >= 0:
            raise ValueError(f"v_end must be >= 0 m/s, got {self.v_end}")
        kinematic_speed_limits(1.0, self.r_max, self.phi_max, self.theta_max, self.nz_max, self.xu)

    def u_max(self, radius_y: ArrayLike) -> np.ndarray:
        return max_path_speed(radius_y, self.r_max, self.phi_max, self.theta_max, self.nz_max, self.xu)

    def v_targ3(self, tau: ArrayLike) -> np.ndarray:
        return descent_speed_limit(tau, self.vrs_steep_angle, self.w_descent_steep, self.w_descent_shallow)
