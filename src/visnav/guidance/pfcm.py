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
   braking results): the same limits along the path ahead are met by braking at Acc in time
   (``brake_lead_s`` earlier, the pitch channel's lag), and v_targ rises at most at Acc. With
   ``roll_headroom`` the roll the outer loop spends against the wind (``set_lateral_bias``) is
   taken off φ_max in u3 (at the control point for this turn's direction, ahead its magnitude):
   §3.5 reads roll-input saturation at 10 m/s (Fig. 3.8) as too fast for the curvature.
3. Heading error δψ = atan2(t_y, t_x) − ψ (§4.3.3 item 3).
4. Feed-forward r_ff = u/R_y^b, φ_ff = u²/(g R_y^b) (eq. 4.14, 4.24), u the along-path speed,
   in their exact trimmed-turn form φ_ff = atan(u²/(g R)), r_ff = cos φ_ff u/R (eq. 4.14 is the
   small-angle form: 2% more bank at 15°, a steady inward offset), with R_y^b taken a channel lag
   ahead (``roll_lead_s``, ``yaw_lead_s``) and the lateral acceleration rate-limited
   (``ff_roll_rate``): a curvature step at a joint becomes a ramp that ends when the turn starts.

Frames: the "body" frame of eq. 4.18/4.24 is taken as the heading frame (x forward, y right,
z down): the YACS attitude commands act there, and with |φ|, |θ| <= 15° the difference is cos 15°.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from visnav.guidance.hermite import HermitePath
from visnav.guidance.speed_limits import (  # noqa: F401  (re-exported: the PFCM's public API)
    PfcmLimits,
    brake_speed,
    descent_angle,
    descent_speed_limit,
    hover_induced_velocity,
    kinematic_speed_limits,
    max_descent_rate,
    max_path_speed,
    nz_max_for_mass,
)
from visnav.measurements import NavEstimate, read_only
from visnav.scalar import clip as _clip

G = 9.81




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
    accel_target: float  # d v_target/dt [m/s²] (for the θ_ff of eq. 4.14)
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


class _LiveReference:
    """A reference source: ``step(t, nav)`` gives a ``PathReference``; ``position``, ``velocity``,
    ``yaw`` and ``source`` read the last one (what a log of the reference records)."""

    last: PathReference | None = None

    @property
    def position(self) -> np.ndarray:
        return self.last.position if self.last is not None else np.full(3, np.nan)

    @property
    def velocity(self) -> np.ndarray:
        return self.last.velocity if self.last is not None else np.zeros(3)

    @property
    def yaw(self) -> float:
        return self.last.yaw if self.last is not None else math.nan

    @property
    def source(self) -> str:
        return self.last.source if self.last is not None else "gps"


def heading_rotation(psi: float) -> np.ndarray:
    """NED -> heading frame (x forward, y right, z down)."""
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


class PfcmGuidance(_LiveReference):
    """The PFCM trajectory generator on a ``HermitePath``; call ``step(t, nav)`` at the control rate.

    A second call at the same ``t`` returns the cached output (the mission manager and the outer
    loop may both ask). ``iterations``: control-point feedback iterations per call (eq. 4.10).
    """

    def __init__(self, path: HermitePath, limits: PfcmLimits, iterations: int = 1,
                 segment_end_speeds: ArrayLike | None = None, table_step_m: float = 0.5,
                 roll_lead_s: float = 0.6, yaw_lead_s: float = 0.2, brake_lead_s: float = 0.45,
                 ff_roll_rate: float = math.radians(30.0), roll_headroom: bool = True):
        if not isinstance(path, HermitePath):
            raise ValueError(f"path must be a HermitePath, got {type(path).__name__}")
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations}")
        for name, v in (("roll_lead_s", roll_lead_s), ("yaw_lead_s", yaw_lead_s), ("brake_lead_s", brake_lead_s),
                        ("ff_roll_rate", ff_roll_rate)):
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be >= 0, got {v}")
        self.path, self.limits, self.iterations = path, limits, int(iterations)
        self.roll_lead_s, self.yaw_lead_s = float(roll_lead_s), float(yaw_lead_s)
        self.brake_lead_s = float(brake_lead_s)
        self.ff_jerk = G * float(ff_roll_rate)  # lateral jerk limit [m/s³]
        self.accel_tau = 0.1  # low-pass of the target acceleration [s]
        self.roll_headroom = bool(roll_headroom)
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
        self._a_ff = 0.0
        self._accel = 0.0
        self.lateral_bias_ne = np.zeros(2)
        self._t: float | None = None
        self.last: PathReference | None = None

    # -- the look-ahead envelopes of v_targ2 and v_targ3 ---------------------------------------
    def _build_envelope(self, step: float) -> None:
        """Limits on a dense table along the path (heading aligned with the path), each folded into
        v_env(l) = min over l' >= l of sqrt(v(l')² + 2 Acc (l' − l)) by a reverse cumulative min.
        The table also holds the curvature, for the feed-forward look-ahead."""
        n = max(8, int(math.ceil(self.path.lengths.max() / step)) + 1)
        smp = self.path.sample(n)
        lim = self.limits
        tau = smp["tangent"] / np.linalg.norm(smp["tangent"], axis=1, keepdims=True)
        k = smp["curvature"]
        h = np.hypot(tau[:, 0], tau[:, 1])
        # lateral curvature in a heading frame aligned with the horizontal tangent
        side = np.column_stack([-tau[:, 1], tau[:, 0]]) / np.maximum(h, 1e-9)[:, None]
        k_lat = np.sum(k[:, :2] * side, axis=1)  # > 0: the path turns right
        ky = np.abs(k_lat)
        v2 = np.where(ky > 1e-9, lim.u_max(1.0 / np.maximum(ky, 1e-12)), np.inf) / np.maximum(h, 1e-9)
        v3 = lim.v_targ3(tau)
        l = smp["l"]
        a2 = 2.0 * lim.accel * l

        def envelope(v: np.ndarray) -> np.ndarray:
            e = np.minimum.accumulate((np.minimum(v * v, 1e12) + a2)[::-1])[::-1] - a2
            return np.sqrt(np.clip(e, 0.0, 1e12))  # 1e6 m/s: no limit ahead (inf after lookup)

        self.profile_table = {"l": l, "v_targ2": v2, "v_targ3": v3, "envelope2": envelope(v2),
                              "envelope3": envelope(v3), "lateral_curvature": k_lat}
        self._rows = np.column_stack([envelope(v2), envelope(v3), k_lat])

    def _row(self, l: float) -> list[float]:
        """The table row (envelope2, envelope3, lateral curvature) at arc length l, linearly interpolated
        (clamped to the table's ends)."""
        L = self.profile_table["l"]
        j = min(max(int(np.searchsorted(L, l)) - 1, 0), len(L) - 2)
        f = min(max((l - L[j]) / (L[j + 1] - L[j]), 0.0), 1.0)
        return ((1.0 - f) * self._rows[j] + f * self._rows[j + 1]).tolist()

    def _u_max(self, ky: float, phi: float) -> float:
        """Scalar eq. 4.15-4.16 for |k_y^b| and a roll limit φ (inf on a straight)."""
        if ky <= 1e-9:
            return math.inf
        lim, R = self.limits, 1.0 / ky
        return min(R * lim.r_max, math.sqrt(phi * G * R), (G * G * (lim.nz_max - 1.0) * R * R) ** 0.25)

    def set_lateral_bias(self, accel_ne: ArrayLike) -> None:
        """The horizontal acceleration [m/s², N/E] the outer loop's integrators spend against the
        wind; the roll it costs is taken off φ_max for v_targ2 (see ``step``)."""
        a = np.asarray(accel_ne, float)[:2]
        if not all(map(math.isfinite, a.ravel().tolist())):
            raise ValueError(f"accel_ne must be finite, got {accel_ne!r}")
        self.lateral_bias_ne = a

    # -- eq. 4.6-4.10 ----------------------------------------------------------------------------
    def update_control_point(self, p_heli: ArrayLike) -> tuple[int, float]:
        """Advance (segment, s) by the local feedback of eq. 4.7-4.10."""
        p_heli = np.asarray(p_heli, float)
        segs = self.path.segments
        for _ in range(self.iterations):
            while True:
                p, t, _ = segs[self.segment].frame_at(self.s)
                nt = math.sqrt(t @ t)
                e_f = float((p - p_heli) @ t) / nt  # eq. 4.7-4.8
                s = self.s - e_f / nt  # eq. 4.10
                if s > 1.0 and self.segment < len(segs) - 1:
                    self.segment += 1  # next segment: the parameter restarts at 0 (§4.3.3 item 1)
                    self.s = 0.0
                    continue
                break
            self.s = min(max(s, 0.0), 1.0)
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
        p_cp, t_n, k_n = sg.frame_at(s)
        n_t = math.sqrt(t_n @ t_n)
        tau = t_n / n_t
        tau0, tau1, tau2 = tau.tolist()
        l_now = self.path.arc_position(i, s)
        l_total = self.path.length
        l_left = max(l_total - l_now, 0.0)
        C = heading_rotation(psi)
        tau_b, k_b = C @ tau, C @ k_n  # eq. 4.24
        # v_targ2 (eq. 4.21) with R_y^b = 1/k_y^b, and v_targ3 (eq. 4.23)
        ky = float(k_b[1])
        tb0 = float(tau_b[0])
        # roll headroom: the bank the wind correction adds in this turn's direction is not available
        # for turning (the remedy §3.5 suggests when the roll input saturates, Fig. 3.8)
        lim_phi = lim.phi_max
        if self.roll_headroom:
            bn, be = self.lateral_bias_ne.tolist()
            c10, c11 = C[1].tolist()[:2]
            bias = (c10 * bn + c11 * be) / G
            lim_phi = max(lim.phi_max - max(math.copysign(1.0, ky) * bias, 0.0), 0.5 * lim.phi_max)
            env_scale = math.sqrt(max(lim.phi_max - math.hypot(bn, be) / G, 0.5 * lim.phi_max) / lim.phi_max)
        else:
            env_scale = 1.0
        u_max = self._u_max(abs(ky), lim_phi)
        v2 = u_max / tb0 if tb0 > 1e-3 else math.inf
        v3 = math.inf
        if tau2 > 1e-9:  # eq. 4.23
            gamma = math.atan2(tau2, math.hypot(tau0, tau1))
            v3 = (lim.w_descent_steep if gamma >= lim.vrs_steep_angle else lim.w_descent_shallow) / tau2
        u = max(float(vel @ tau), 0.0)
        l_brake = min(l_now + u * self.brake_lead_s, l_total)  # braking lead: the pitch lag
        if lim.anticipate:
            env = self._row(l_brake)
            v2 = min(v2, env_scale * env[0] if env[0] < 1e5 else math.inf)
            v3 = min(v3, env[1] if env[1] < 1e5 else math.inf)
        v1 = self._v_targ1(dt, self._v_brake(l_brake))
        v = min(v1, v2, v3)
        v = min(v, self.v_prev + lim.accel * dt)  # rises at most at Acc, also after a limit ends
        finished = i == len(self.path) - 1 and s >= 1.0
        if finished:
            v, self.phase = 0.0, "end"
        if dt > 0:  # d v_targ/dt, low-passed (v_brake follows the measured position)
            a = _clip((v - self.v_prev) / dt, -2.0 * lim.accel, lim.accel)
            self._accel += dt / (self.accel_tau + dt) * (a - self._accel)
        accel = self._accel
        self.v_prev = v
        # heading (§4.3.3 item 3) and feed-forward (eq. 4.14, 4.24), u = along-path speed
        tn0, tn1, _ = t_n.tolist()
        horiz = math.hypot(tn0, tn1)
        yaw = math.atan2(tn1, tn0) if horiz > 1e-6 * n_t else psi
        d_psi = (yaw - psi + math.pi) % (2 * math.pi) - math.pi
        # the curvature a channel lag ahead (roll, yaw); the roll's lateral acceleration u² k_y is
        # rate-limited (a curvature step at a joint becomes a ramp)
        def k_ahead(lead: float) -> float:
            if lead <= 0:
                return ky
            return self._row(min(l_now + u * lead, l_total))[2]  # in the path's own frame there

        a_ff = u * u * k_ahead(self.roll_lead_s)
        if self.ff_jerk > 0 and dt > 0:
            a_ff = _clip(a_ff, self._a_ff - self.ff_jerk * dt, self._a_ff + self.ff_jerk * dt)
        self._a_ff = a_ff
        # trimmed turn: tan φ = u²/(g R), body yaw rate r = ψ̇ cos φ (eq. 4.14 is the small-angle form)
        phi_ff = math.atan(a_ff / G)
        r_ff = u * k_ahead(self.yaw_lead_s) * math.cos(phi_ff)
        self.last = PathReference(
            t=t, position=p_cp, velocity=v * tau, yaw=yaw, tangent=tau, curvature=k_n, segment=i, s=s,
            v_target=v, accel_target=accel, v_targ1=v1, v_targ2=v2, v_targ3=v3, phase=self.phase, heading_error=d_psi,
            r_ff=r_ff, phi_ff=phi_ff, distance_to_end=l_left, arc_position=l_now, finished=finished,
            source=getattr(nav, "source", "gps"))
        return read_only(self.last)  # handed out again at the same t: nobody may write into it


class PointHold(_LiveReference):
    """Hover over a point with a heading: a ``PathReference`` source for the same outer loop
    (before the path starts and after it ends). ``step(t, nav)`` like ``PfcmGuidance``."""

    def __init__(self, point: ArrayLike, yaw: float):
        p = np.asarray(point, float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"point must be 3 finite NED values, got {point!r}")
        self.point, self.hold_yaw = p, float(yaw)
        self.last: PathReference | None = None

    def step(self, t: float, nav: NavEstimate) -> PathReference:
        psi = float(nav.attitude[2])
        d_psi = (self.hold_yaw - psi + math.pi) % (2 * math.pi) - math.pi
        tau = np.array([math.cos(self.hold_yaw), math.sin(self.hold_yaw), 0.0])
        self.last = PathReference(
            t=t, position=self.point, velocity=np.zeros(3), yaw=self.hold_yaw, tangent=tau, curvature=np.zeros(3),
            segment=-1, s=0.0, v_target=0.0, accel_target=0.0, v_targ1=0.0, v_targ2=math.inf, v_targ3=math.inf,
            phase="hold",
            heading_error=d_psi, r_ff=0.0, phi_ff=0.0, distance_to_end=0.0, arc_position=0.0, finished=True,
            source=getattr(nav, "source", "gps"))
        return self.last
