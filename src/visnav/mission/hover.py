"""Hover missions for the PALACE analyses (seed 000 §4.2, §5.2).

The vehicle holds a point of the 60 deg glide slope at ``altitude_m`` on GPS, starts tracking the
point the camera looks at (Förstner near the designated point), and after ``coherence_time_s`` of good
coherence either keeps flying on GPS with MPE running open loop (``source = "gps"``: the drift
experiment of §4.2) or switches to MPE (``source = "mpe"``: the closed-loop sweeps of §5.2). The
hold lasts ``hold_s``. No re-initialisation: the drift of one track is what is measured.

Optionally a logarithmic chirp is injected at a cyclic actuator (``sweep_axis``), for the
broken-loop frequency response at the actuator (the loop broken where the thesis broke it).
"""

from __future__ import annotations

import numpy as np

from visnav.measurements import Health, NavEstimate, PositionReference
from visnav.mission.base import NavigatorRequests, mode_gate

AXES = {"lateral": 0, "longitudinal": 1}  # index into (ail, ele, rud, thr)


def log_chirp(t: np.ndarray | float, f0: float, f1: float, duration: float) -> np.ndarray:
    """Unit logarithmic chirp from f0 to f1 [Hz] over ``duration`` [s] (zero outside it)."""
    t = np.asarray(t, dtype=float)
    k = np.log(f1 / f0) / duration
    phase = 2 * np.pi * f0 * (np.expm1(k * t) / k)
    return np.where((t >= 0) & (t <= duration), np.sin(phase), 0.0)


class HoverMission(NavigatorRequests):
    def __init__(self, cfg, navigator, yaw: float = 0.0, recorder=None):
        self.cfg = cfg
        self.nav = navigator
        self.source = "gps"  # the navigation source this mission set (the navigator starts on GPS)
        self.yaw = float(yaw)
        self.point = np.array([cfg.point_m[0], cfg.point_m[1], 0.0])
        g = np.deg2rad(cfg.look_angle_deg)
        back = -np.array([np.cos(yaw), np.sin(yaw), 0.0]) * cfg.altitude_m / np.tan(g)
        self.hold = self.point + back + np.array([0.0, 0.0, -cfg.altitude_m])
        self.mode = "settle"
        self.t_mode = 0.0
        self.good_since: float | None = None
        self.t_hold: float | None = None
        self.done = False
        self.aborted = False
        self.mission_record = recorder or (lambda *a, **k: None)
        self.vision_time = 0.0
        self.reinitializations = 0
        self.fallbacks = 0
        self._last_t: float | None = None

    def start_position(self) -> np.ndarray:
        return self.hold.copy()

    def _set(self, mode: str, t: float, why: str = "") -> None:
        self.mission_record("mode", t, mode=mode, previous=self.mode, reason=why)
        self.mode = mode
        self.t_mode = t

    def step(self, t: float, nav: NavEstimate, health: Health):
        c = self.cfg
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        if self.source == "mpe":
            self.vision_time += dt
        if self.mode == "settle" and t - self.t_mode >= c.settle_s:
            self._ask(t, "request-tracking", target_ned=self.point, init_from="gps")
            self._set("acquire", t, "start tracking")
        elif self.mode == "acquire":
            if not health.tracking and not self._pending(health, t):
                self._ask(t, "request-tracking", target_ned=self.point, init_from="gps")  # tracker failed: again (§4.1)
                self.good_since = None
            good = health.tracking and health.coherence >= c.coherence_threshold and not self._pending(health, t)
            if not good:
                self.good_since = None
            elif self.good_since is None:
                self.good_since = t
            elif t - self.good_since >= c.coherence_time_s:
                if c.source == "mpe":
                    self._ask(t, "request-tracking-rebase", init_from="gps")
                    self._ask(t, "set-source", source="mpe")
                self.t_hold = t
                self._set("hold", t, f"hover on {c.source}, MPE {'closed' if c.source == 'mpe' else 'open'} loop")
        elif self.mode == "hold":
            if not health.tracking and not self._pending(health, t):
                self._set("lost", t, "track lost")
                if self.source == "mpe":
                    self._ask(t, "set-source", source="gps")
            elif t - self.t_mode >= c.hold_s:
                self._set("done", t, "hold complete")
                self.done = True
        elif self.mode == "lost" and t - self.t_mode > 2.0:
            self.done = True
        ref = PositionReference(t=t, position=self.hold.copy(), velocity=np.zeros(3), yaw=self.yaw,
                                source=self.source)
        return ref, self.mode

    def actuator_injection(self, t: float) -> np.ndarray | None:
        """YACS increments added to the controller's output (the sweep), or None."""
        c = self.cfg
        if c.sweep_axis == "none" or self.t_hold is None or self.mode != "hold":
            return None
        tau = t - self.t_hold - c.sweep_start_s
        if tau < 0 or tau > c.sweep_duration_s:
            return None
        u = np.zeros(4)
        u[AXES[c.sweep_axis]] = c.sweep_amplitude * float(log_chirp(tau, c.sweep_f0_hz, c.sweep_f1_hz,
                                                                     c.sweep_duration_s))
        return u

    @mode_gate
    def camera_wanted(self, t: float) -> bool:
        """The tracker runs for the whole hover."""
        return True

    def on_touchdown(self, t: float) -> None:
        self._set("touchdown", t, "unexpected ground contact")
        self.done = True
