"""PFCM trajectory generator (seed 002 §4.3.2-4.3.3): control point, velocity profile, feed-forward.

Each call (50 Hz, like the WITAS control function) takes the navigation solution and returns a
``PathReference`` for the outer loop of eq. 4.25:

1. Control point by local feedback on the segment parameter (eq. 4.6-4.10). With
   e = p_cp − p_heli (eq. 4.8) and e_f = e·t/|t| (eq. 4.7), the orthogonality condition
   e·t = 0 (eq. 4.6) is approached by s_n = s_{n−1} − e_f/|dp/ds| (eq. 4.10 with the sign rebuilt
   from eq. 4.8: the parameter moves forward when the helicopter is ahead of the control point).
   ``iterations`` repeats the update; its fixed point is the local orthogonal projection.
2. Target speed v_targ = min(v_targ1, v_targ2, v_targ3):
   v_targ1: accelerate (1.2 m/s²) / cruise / brake state machine (Fig. 4.5), braking when
   v_brake = sqrt(2 l_end Acc + v_end²) < v_cruise (eq. 4.19-4.20);
   v_targ2 = u_max/τ_x^b with u_max = min(u1, u3, u4) of the trimmed turn (eq. 4.15-4.16, 4.21);
   v_targ3 = w_max/τ_z with w_max = 1.5 m/s for descent angles γ >= 30°, 3 m/s below (eq. 4.23).
   Beyond the thesis (which evaluates v_targ2/3 at the control point only and notes that abrupt
   braking results): the same limits along the path ahead are met by braking at Acc in time,
   and v_targ rises at most at Acc (no step when a limit ends).
3. Heading error δψ = atan2(t_y, t_x) − ψ (§4.3.3 item 3).
4. Feed-forward r_ff = u/R_y^b, φ_ff = u²/(g R_y^b) (eq. 4.14, 4.24), u the along-path speed.

Frames: the "body" frame of eq. 4.18/4.24 is taken as the heading frame (x forward, y right,
z down): the YACS attitude commands act there, and with |φ|, |θ| <= 15° the difference is cos 15°.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from visnav.guidance.hermite import HermitePath
from visnav.measurements import NavEstimate

G = 9.81


# ---------------------------------------------------------------------------------- limits
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


# ---------------------------------------------------------------------------------- outputs
@dataclass(frozen=True)
class PathReference:
    """One trajectory-generator output (NED, SI). ``position``/``velocity``/``yaw`` as in a
    ``PositionReference`` (control point, v_targ τ, path heading)."""

    t: float
    position: np.ndarray
    velocity: np.ndarray
    yaw: float
    tangent: np.ndarray  # unit τ (eq. 4.17)
    curvature: np.ndarray  # k^n (eq. 4.5) [1/m]
    segment: int
    s: float
    v_target: float
    v_targ1: float
    v_targ2: float
    v_targ3: float
    phase: str  # accelerate | cruise | brake | end
    heading_error: float
    r_ff: float
    phi_ff: float
    distance_to_end: float
    arc_position: float
    finished: bool
    source: str = "gps"


def heading_rotation(psi: float) -> np.ndarray:
    """NED -> heading frame (x forward, y right, z down)."""
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


class PfcmGuidance:
    """The PFCM trajectory generator on a ``HermitePath``; call ``step(t, nav)`` at the control rate.

    A second call at the same ``t`` returns the cached output (the mission manager and the outer
    loop may both ask). ``iterations``: control-point feedback iterations per call (eq. 4.10).
    """

    def __init__(self, path: HermitePath, limits: PfcmLimits, iterations: int = 1,
                 segment_end_speeds: ArrayLike | None = None, table_step_m: float = 0.5):
        if not isinstance(path, HermitePath):
            raise ValueError(f"path must be a HermitePath, got {type(path).__name__}")
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations}")
        self.path, self.limits, self.iterations = path, limits, int(iterations)
        n = len(path)
        v_end = np.full(n, np.inf) if segment_end_speeds is None else np.asarray(segment_end_speeds, float)
        if v_end.shape != (n,) or np.any(v_end < 0):
            raise ValueError(f"segment_end_speeds must be {n} values >= 0, got {segment_end_speeds}")
        v_end = v_end.copy()
        v_end[-1] = min(v_end[-1], limits.v_end)
        self.segment_end_speeds = v_end
        self._ends = path.starts + path.lengths  # arc length of every segment end
        self._build_envelope(table_step_m)
        self.reset()

    def reset(self) -> None:
        self.segment, self.s = 0, 0.0
        self.phase = "accelerate"
        self.v_acc = 0.0
        self.v_prev = 0.0
        self._t: float | None = None
        self.last: PathReference | None = None

    # -- the look-ahead envelope of v_targ2 and v_targ3 ----------------------------------------
    def _build_envelope(self, step: float) -> None:
        """Limits on a dense table along the path (heading aligned with the path), folded into
        v_env(l) = min over l' >= l of sqrt(v(l')² + 2 Acc (l' − l)) by a reverse cumulative min."""
        n = max(8, int(math.ceil(self.path.lengths.max() / step)) + 1)
        smp = self.path.sample(n)
        lim = self.limits
        tau = smp["tangent"] / np.linalg.norm(smp["tangent"], axis=1, keepdims=True)
        k = smp["curvature"]
        h = np.hypot(tau[:, 0], tau[:, 1])
        # lateral curvature in a heading frame aligned with the horizontal tangent
        side = np.column_stack([-tau[:, 1], tau[:, 0]]) / np.maximum(h, 1e-9)[:, None]
        ky = np.abs(np.sum(k[:, :2] * side, axis=1))
        v2 = np.where(ky > 1e-9, lim.u_max(1.0 / np.maximum(ky, 1e-12)), np.inf) / np.maximum(h, 1e-9)
        v = np.minimum(v2, lim.v_targ3(tau))
        l = smp["l"]
        a = np.minimum(v * v, 1e12) + 2.0 * lim.accel * l
        env2 = np.minimum.accumulate(a[::-1])[::-1] - 2.0 * lim.accel * l
        self._env_l, self._env_v = l, np.sqrt(np.maximum(env2, 0.0))
        self.profile_table = {"l": l, "v_targ2": v2, "v_targ3": lim.v_targ3(tau), "envelope": self._env_v}

    # -- eq. 4.6-4.10 ----------------------------------------------------------------------------
    def update_control_point(self, p_heli: ArrayLike) -> tuple[int, float]:
        """Advance (segment, s) by the local feedback of eq. 4.7-4.10."""
        p = np.asarray(p_heli, float)
        segs = self.path.segments
        for _ in range(self.iterations):
            sg = segs[self.segment]
            t = sg.tangent(self.s)
            nt = float(np.linalg.norm(t))
            e_f = float(np.dot(sg.position(self.s) - p, t)) / nt  # eq. 4.7-4.8
            s = self.s - e_f / nt  # eq. 4.10
            if s > 1.0 and self.segment < len(segs) - 1:
                self.segment += 1  # next segment: the parameter restarts at 0 (§4.3.3 item 1)
                self.s = 0.0
                continue
            self.s = float(np.clip(s, 0.0, 1.0))
        return self.segment, self.s

    # -- v_targ1 (Fig. 4.5, eq. 4.19-4.20) -------------------------------------------------------
    def _v_brake(self, l_now: float) -> float:
        """min over the segment ends ahead of eq. 4.20 (the last end has v_end = limits.v_end)."""
        i = self.segment
        return float(np.min(brake_speed(self._ends[i:] - l_now, self.limits.accel, self.segment_end_speeds[i:])))

    def _v_targ1(self, dt: float, v_brake: float) -> float:
        lim = self.limits
        if self.phase == "accelerate":
            self.v_acc += lim.accel * dt
            if self.v_acc >= lim.v_cruise:
                self.phase = "cruise"
            elif self.v_acc >= v_brake:
                self.phase = "brake"
            else:
                return self.v_acc
        if v_brake < lim.v_cruise:  # eq. 4.19
            self.phase = "brake"
            return v_brake
        self.phase = "cruise"
        return lim.v_cruise

    # ------------------------------------------------------------------------------------------
    def step(self, t: float, nav: NavEstimate) -> PathReference:
        """Trajectory-generator output for the navigation solution ``nav`` at time t."""
        if self._t is not None and abs(t - self._t) < 1e-9 and self.last is not None:
            return self.last
        dt = 0.0 if self._t is None else max(t - self._t, 0.0)
        self._t = t
        pos = np.asarray(nav.position, float)
        vel = np.asarray(nav.velocity, float)
        psi = float(nav.attitude[2])
        lim = self.limits
        i, s = self.update_control_point(pos)
        sg = self.path.segments[i]
        p_cp, t_n, k_n = sg.position(s), sg.tangent(s), sg.curvature(s)
        tau = t_n / np.linalg.norm(t_n)
        l_now = self.path.arc_position(i, s)
        l_left = self.path.distance_to_end(i, s)
        C = heading_rotation(psi)
        tau_b, k_b = C @ tau, C @ k_n  # eq. 4.24
        # v_targ2 (eq. 4.21) with R_y^b = 1/k_y^b, and v_targ3 (eq. 4.23)
        ky = float(k_b[1])
        u_max = float(lim.u_max(1.0 / ky)) if abs(ky) > 1e-9 else math.inf
        v2 = u_max / tau_b[0] if tau_b[0] > 1e-3 else math.inf
        v3 = float(lim.v_targ3(tau))
        if lim.anticipate:
            env = float(np.interp(l_now, self._env_l, self._env_v))
            v2, v3 = min(v2, env), min(v3, env)
        v1 = self._v_targ1(dt, self._v_brake(l_now))
        v = min(v1, v2, v3)
        v = min(v, self.v_prev + lim.accel * dt)  # rises at most at Acc, also after a limit ends
        finished = i == len(self.path) - 1 and s >= 1.0
        if finished:
            v, self.phase = 0.0, "end"
        self.v_prev = v
        # heading (§4.3.3 item 3) and feed-forward (eq. 4.14, 4.24), u = along-path speed
        horiz = math.hypot(t_n[0], t_n[1])
        yaw = math.atan2(t_n[1], t_n[0]) if horiz > 1e-6 * np.linalg.norm(t_n) else psi
        d_psi = (yaw - psi + math.pi) % (2 * math.pi) - math.pi
        u = max(float(vel @ tau), 0.0)
        r_ff, phi_ff = u * ky, u * u * ky / G
        self.last = PathReference(
            t=t, position=p_cp, velocity=v * tau, yaw=yaw, tangent=tau, curvature=k_n, segment=i, s=s,
            v_target=v, v_targ1=v1, v_targ2=v2, v_targ3=v3, phase=self.phase, heading_error=d_psi,
            r_ff=r_ff, phi_ff=phi_ff, distance_to_end=l_left, arc_position=l_now, finished=finished,
            source=getattr(nav, "source", "gps"))
        return self.last
