"""PFCM mission manager: fly a planner path with the WITAS path following control mode (seed 002 ch. 4).

settle (hover at the path start, heading along the path) -> follow (the PFCM trajectory
generator ``guidance/pfcm.py`` drives the 50 Hz outer loop) -> hold (hover at the end point
for ``hold_s``) -> done. The path is complete when the control point reaches the end of the last
segment, or the helicopter is within ``end_tolerance_m`` of it along the path. The manager runs at
10 Hz; it hands the outer loop the live generator (a reference source), so that guidance and
control both run at the controller's 50 Hz.

Integrity (issue #18, ``mission/integrity.py``): on a GPS-denied homing nothing better than the
navigator exists on board, and a hover drifts on dead reckoning as much as the path does, so the
mission carries on along the path on dead reckoning when the navigator says ``unusable`` (its HPL grows,
the claim stays honest: the homing is judged safe when it does not end far from home claiming ``ok``);
every change of the state it reacts to is logged in ``integrity_reaction``.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.guidance.hermite import HermitePath, helix_waypoints
from visnav.guidance.pfcm import PfcmGuidance, PfcmLimits, PointHold
from visnav.measurements import Health, NavEstimate
from visnav.mission.integrity import IntegrityWatch
from visnav.log_schema import register_stream
from visnav.control.rmax_path import PathLoopGains

register_stream("pfcm", **{k: ("m/s", "", d) for k, d in (
    ("v_target", "speed target v_targ = min of the three"), ("v_targ1", "accelerate / cruise / brake profile"),
    ("v_targ2", "turn limit (eq. 4.15)"), ("v_targ3", "vortex-ring descent limit (eq. 4.23)"),
    ("speed", "navigation speed"))},
    phase=("text", "", "accelerate, cruise, brake or end"), segment=("1", "", "Hermite segment index"),
    s=("1", "", "parameter on the segment (0..1)"), arc_position=("m", "", "distance along the path"),
    distance_to_end=("m", "", "distance left along the path"), phi_ff=("rad", "", "feed-forward roll"),
    r_ff=("rad/s", "", "feed-forward yaw rate"), heading_error=("rad", "", "heading minus the path tangent"),
    control_point=("m", "NED world (origin at the scenario's home)", "the path's control point (ch. 4)"),
    nav_cross_track=("m", "", "navigation position to the control point"))


def spiral_waypoints(cfg) -> tuple[np.ndarray, np.ndarray]:
    """Waypoints and tangent directions of a ``PfcmSpiralConfig``: level lead-in north from the
    origin at the start height, a helix to ``end_height_m + exit_drop_m``, then (optionally) a
    straight exit descending ``exit_drop_m`` at ``exit_angle_deg``."""
    h0, h1, drop = cfg.start_height_m, cfg.end_height_m, cfg.exit_drop_m
    sgn = 1.0 if cfg.direction == "right" else -1.0
    P, T = [np.array([0.0, 0.0, -h0])], [np.array([1.0, 0.0, 0.0])]
    if cfg.lead_in_m > 0:
        P.append(np.array([cfg.lead_in_m, 0.0, -h0]))
        T.append(np.array([1.0, 0.0, 0.0]))
    n = max(1, int(math.ceil(cfg.turns * cfg.segments_per_turn)))
    hp, ht = helix_waypoints((cfg.lead_in_m, sgn * cfg.radius_m), cfg.radius_m, -sgn * math.pi / 2,
                             sgn * 2 * math.pi * cfg.turns, -h0, -(h1 + drop), n)
    P.extend(hp[1:])
    T.extend(ht[1:])
    if cfg.lead_in_m <= 0:  # the helix starts at the origin: use its own tangent there
        T[0] = ht[0]
    if drop > 0:
        d = ht[-1, :2] / np.linalg.norm(ht[-1, :2])
        g = math.radians(cfg.exit_angle_deg)
        run = drop / math.tan(g)
        P.append(P[-1] + np.array([d[0] * run, d[1] * run, drop]))
        T.append(np.array([d[0] * math.cos(g), d[1] * math.cos(g), math.sin(g)]))
    return np.array(P), np.array(T)


def build_path(cfg) -> HermitePath:
    """The ``HermitePath`` of a ``PfcmMissionConfig`` (ValueError names a bad segment)."""
    if cfg.path == "segments":
        return HermitePath.from_segments(cfg.segments)
    if cfg.path == "spiral":
        P, T = spiral_waypoints(cfg.spiral)
        return HermitePath.from_waypoints(P, T, scale="arc")
    return HermitePath.from_waypoints(cfg.waypoints_ned_m, cfg.tangents, scale=cfg.tangent_scale)


def limits_from_config(cfg) -> PfcmLimits:
    r = math.radians
    return PfcmLimits(v_cruise=cfg.v_cruise_mps, accel=cfg.accel_mps2, r_max=r(cfg.r_max_deg_s),
                      phi_max=r(cfg.phi_max_deg), theta_max=r(cfg.theta_max_deg), nz_max=cfg.nz_max,
                      vrs_steep_angle=r(cfg.vrs_steep_angle_deg), w_descent_steep=cfg.vrs_steep_descent_mps,
                      w_descent_shallow=cfg.vrs_shallow_descent_mps, v_end=cfg.v_end_mps,
                      anticipate=cfg.anticipate_limits)


def path_loop_gains(cfg, control):
    """The eq. 4.25 outer-loop gains for a ``PfcmMissionConfig``'s command limits and the controller options of
    ``control`` (``control.pfcm``): the eq. 4.26 inner roll loop with the lateral gains designed on it
    (``roll_compensator``), the lateral integral (``roll_integral``), the roll command margin."""

    make = PathLoopGains.with_roll_compensator if control.roll_compensator else PathLoopGains
    return make(max_roll=math.radians(cfg.phi_max_deg + control.roll_margin_deg),
                max_pitch=math.radians(cfg.theta_max_deg), max_yaw_rate=math.radians(cfg.r_max_deg_s),
                **({} if control.roll_integral else {"k3r": 0.0}))


def _heading(t: np.ndarray, fallback: float = 0.0) -> float:
    return math.atan2(t[1], t[0]) if math.hypot(t[0], t[1]) > 1e-6 * np.linalg.norm(t) else fallback


class PfcmMission:
    """Mission manager of a PFCM flight; ``step`` returns (reference source, mode)."""

    def __init__(self, cfg, recorder=None, path: HermitePath | None = None, *, iterations: int = 1):
        """``iterations``: the guidance's control-point feedback iterations per cycle (``control.pfcm``)."""
        self.cfg = cfg
        self.path = path if path is not None else build_path(cfg)
        self.limits = limits_from_config(cfg)
        self.guidance = PfcmGuidance(self.path, self.limits, iterations=iterations)
        first, last = self.path.segments[0], self.path.segments[-1]
        self.start_yaw = _heading(first.tangent(0.0))
        self.end_yaw = _heading(last.tangent(1.0), self.start_yaw)
        self._start_hold = PointHold(self.path.start, self.start_yaw)
        self._end_hold = PointHold(self.path.end, self.end_yaw)
        self.record = recorder or (lambda *a, **k: None)
        self.mode = "settle"
        self.t_mode = 0.0
        self.done = False
        self.aborted = False
        self.path_completed = False
        self.t_follow: float | None = None
        self.t_complete: float | None = None
        self.integrity = IntegrityWatch(self.record)
        self._reacted = "ok"

    def start_position(self) -> np.ndarray:
        return self.path.start.copy()

    def _set(self, mode: str, t: float, why: str = "") -> None:
        self.record("mode", t, mode=mode, previous=self.mode, reason=why)
        self.mode = mode
        self.t_mode = t

    def step(self, t: float, nav: NavEstimate, health: Health):
        c = self.cfg
        state = self.integrity.update(t, health)
        if self.integrity.seen_ok and state != self._reacted and (state != "unusable" or
                                                                 self.integrity.unusable_for(t) >= 1.0):
            self._reacted = state
            self.integrity.react(t, "dead reckoning along the path" if state == "unusable" else "none",
                                 f"HPL {self.integrity.hpl_m:.1f} m")
        if self.mode == "settle" and nav.valid and t - self.t_mode >= c.settle_s:
            self.t_follow = t
            self._set("follow", t, "start the path")
        if self.mode == "follow":
            r = self.guidance.step(t, nav)
            pos = np.asarray(nav.position, float)
            self.record("pfcm", t, v_target=r.v_target, v_targ1=r.v_targ1, v_targ2=r.v_targ2, v_targ3=r.v_targ3,
                        phase=r.phase, segment=r.segment, s=r.s, arc_position=r.arc_position,
                        distance_to_end=r.distance_to_end, phi_ff=r.phi_ff, r_ff=r.r_ff,
                        heading_error=r.heading_error, control_point=r.position,
                        nav_cross_track=float(np.linalg.norm(r.position - pos)),
                        speed=float(np.linalg.norm(nav.velocity)))
            if r.finished or r.distance_to_end <= c.end_tolerance_m:
                self.path_completed = True
                self.t_complete = t
                self._set("hold", t, f"end of the path ({r.distance_to_end:.2f} m to go)")
        elif self.mode == "hold" and t - self.t_mode >= c.hold_s:
            self.done = True
            self._set("done", t, "held the end point")
        ref = {"settle": self._start_hold, "follow": self.guidance}.get(self.mode, self._end_hold)
        if self.mode != "follow":
            ref.step(t, nav)  # keep its last output current for the log
        return ref, self.mode

    def camera_wanted(self, t: float) -> bool:
        """PFCM itself does not stop the camera (a navigator that uses one, WITAS, gets every frame)."""
        return True

    def on_touchdown(self, t: float) -> None:
        self.aborted = True
        self.done = True
        self._set("crashed", t, "touched the ground")
