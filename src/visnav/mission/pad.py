"""WITAS vision landing on the three-circle pad (seed 002 ch. 6): GPS-free from 20 m to touch-down.

The R-MAX starts hovering at ``start_height_m`` beside the pad with the camera looking down. At the
first vision fix the navigator (``navigation/pad.py``) starts its filter; after ``settle_s`` the
reference (a "white rabbit" for the PALACE position loop of ``control/rmax.py``) moves over the pad
centre at ``approach_speed_mps`` while sinking at ``descent_rate_mps``, and at ``final_rate_mps``
below ``slow_height_m`` (heights of the *estimate*), until the skids touch. Nothing switches when
the pattern leaves the view near the ground: the fixes stop, the filter dead-reckons and the same
reference carries on (mode ``blind`` only labels the log).

Integrity (issue #18, ``mission/integrity.py``): the navigator ``unusable`` for ``integrity_unusable_s``
above ``integrity_abort_height_m`` (estimated height) -> ``go-around``: the reference climbs back to
``start_height_m`` over where it was and the approach starts again once the integrity has been ``ok``
for 2 s; after ``max_go_arounds`` the landing is aborted (hold, mission over). Below that height the
landing goes on on dead reckoning (the pattern leaves the view near the ground by design).

``build(sim)`` is the mission builder registered as ``pad-landing`` in ``app/missions.py``.
"""

from __future__ import annotations


import numpy as np

from visnav.measurements import Health, NavEstimate, PositionReference
from visnav.mission.integrity import IntegrityWatch
from visnav.log_schema import register_stream

register_stream("nav_cov", cov=("mixed", "position (m, NED), velocity (m/s, NED)", "navigator covariance of the "
                                "logged estimate (NEES in the metrics)"))



class PadLandingMission:
    def __init__(self, cfg, recorder=None):
        self.cfg = cfg
        self.record = recorder or (lambda *a, **k: None)
        self.mode = "wait"
        self.done = False
        self.t_mode = 0.0
        self.ref_p: np.ndarray | None = None
        self.ref_v = np.zeros(3)
        self._last_t: float | None = None
        self.touchdown_t: float | None = None
        self._centred_since: float | None = None
        self.integrity = IntegrityWatch(self.record)
        self.go_arounds = 0
        self._dr_logged = False

    def start_position(self) -> np.ndarray:
        c = self.cfg
        return np.array([c.start_ne_m[0], c.start_ne_m[1], -c.start_height_m])

    def _set(self, mode: str, t: float, why: str) -> None:
        self.record("mode", t, mode=mode, previous=self.mode, reason=why)
        self.mode, self.t_mode = mode, t

    def step(self, t: float, nav: NavEstimate, health: Health):
        c = self.cfg
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        if nav.valid:  # the filter's covariance beside the logged estimate (NEES in the metrics)
            self.record("nav_cov", t, cov=np.asarray(nav.covariance, float))
        self.integrity.update(t, health)
        flying = ("approach", "blind", "gate", "final-descent")
        if self.mode in flying and self.integrity.unusable_for(t) >= c.integrity_unusable_s:
            h = -float(nav.position[2])
            if h > c.integrity_abort_height_m:
                self.go_arounds += 1
                if self.go_arounds > c.max_go_arounds:
                    self.integrity.react(t, "abort", f"unusable at {h:.1f} m after {c.max_go_arounds} go-arounds")
                    self._set("abort", t, f"integrity unusable ({self.integrity.reason}) after "
                                          f"{c.max_go_arounds} go-arounds")
                    self.done = True
                else:
                    self.integrity.react(t, "go-around", f"unusable at {h:.1f} m")
                    self._set("go-around", t, f"integrity unusable ({self.integrity.reason}) at {h:.1f} m")
            elif not self._dr_logged:
                self._dr_logged = True
                self.integrity.react(t, "land on dead reckoning", f"unusable at {h:.1f} m")
        elif self.mode == "go-around" and self.integrity.ok_for(t) >= 2.0 and \
                -self.ref_p[2] >= c.start_height_m - 0.5:
            self._set("approach", t, "integrity ok again: approach again")
        if self.mode == "wait":
            if nav.valid:
                self.ref_p = np.asarray(nav.position, float).copy()
                self._set("settle", t, "first vision fix: filter started")
            elif t > 10.0:
                self._set("abort", t, "no vision fix in 10 s")
                self.done = True
        elif self.mode == "settle" and t - self.t_mode >= c.settle_s:
            self._set("approach", t, "approach and descent over the pad")
        elif self.mode in ("approach", "blind", "gate", "final-descent"):
            if self.mode in ("approach", "blind") and c.gate_height_m > 0 and -self.ref_p[2] <= c.gate_height_m + 1e-6:
                self._set("gate", t, f"hold at {c.gate_height_m} m until centred")
            elif self.mode == "approach" and health.source == "inertial":
                self._set("blind", t, "no vision fix: dead reckoning")
            elif self.mode == "blind" and health.source == "vision":
                self._set("approach", t, "vision fixes again")
            elif self.mode == "gate":
                err = float(np.hypot(*nav.position[:2]))
                spd = float(np.hypot(*nav.velocity[:2]))
                centred = err <= c.gate_tolerance_m and spd <= c.gate_tolerance_m
                self._centred_since = (self._centred_since if self._centred_since is not None else t) \
                    if centred else None
                if (centred and t - self._centred_since >= c.gate_time_s) or t - self.t_mode >= c.gate_max_s:
                    self._set("final-descent", t, f"centred within {err:.2f} m, {spd:.2f} m/s" if centred
                              else "gate time out")
            if t > c.timeout_s:
                self._set("abort", t, "timeout")
                self.done = True
        if self.ref_p is None:
            ref = PositionReference(t=t, position=self.start_position(), velocity=np.zeros(3), source="vision")
            return ref, self.mode
        v = np.zeros(3)
        if self.mode in ("approach", "blind", "gate", "final-descent"):
            d = -self.ref_p[:2]
            n = float(np.hypot(*d))
            if n > 1e-9:
                v[:2] = d / n * min(c.approach_speed_mps, n / max(dt, 1e-3))
            h_est = -float(nav.position[2])
            v[2] = c.final_rate_mps if h_est < c.slow_height_m else c.descent_rate_mps
            if h_est < c.flare_height_m:
                v[2] = c.flare_rate_mps
            if self.mode != "final-descent" and c.gate_height_m > 0 and -self.ref_p[2] - v[2] * dt < c.gate_height_m:
                v[2] = 0.0  # the reference stops at the gate height
                self.ref_p[2] = -c.gate_height_m
            self.ref_p = self.ref_p + v * dt
            self.ref_p[2] = min(self.ref_p[2], 1.0)  # the reference keeps sinking until the skids touch
        if self.mode == "go-around":  # climb back over where the reference was
            v[2] = -c.descent_rate_mps if -self.ref_p[2] < c.start_height_m else 0.0
            self.ref_p = self.ref_p + v * dt
        self.ref_v = v
        return PositionReference(t=t, position=self.ref_p.copy(), velocity=v, yaw=0.0, source="vision"), self.mode

    def camera_wanted(self, t: float) -> bool:
        """Frames until touch-down or an abort (near the ground the pattern leaves the view by itself)."""
        return self.mode not in ("landed", "abort")

    def on_touchdown(self, t: float) -> None:
        self.touchdown_t = t
        self._set("landed", t, "touch-down")
        self.done = True
