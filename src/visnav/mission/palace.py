"""PALACE mission manager (seed 000 Fig. 1.1, §3.1.2, §3.2, §4.1).

GPS at the start height on the 60 deg glide slope to the designated point -> start tracking it
(Förstner near the point) -> descend on GPS with MPE running open loop -> at the switch height
hold until the tracker has been coherent for 2 s and MPE updates at 10 Hz -> switch to MPE
(ground reference re-based on the last GPS fix, as the thesis' mission manager did) -> descend on
MPE, re-initialising on a point near the image centre when the tracked point nears the image edge
(each re-init carries its drift, §4.1) -> below 1 m finish on inertial + sonar to touchdown.

Safety (§3.2): back to GPS when MPE jumps or stops updating at 10 Hz (then re-verify before
switching again); soft abort (climb 5 m on GPS) when the laser return is lost above 1 m.

Integrity (issue #18, ``mission/integrity.py``): the navigator's state ``unusable`` for
``integrity_unusable_s`` while flying on MPE counts as an MPE failure (back to GPS, re-verify; after
``max_fallbacks`` a soft abort); while flying on GPS (settle to verify) it aborts the landing and goes
around (climb ``abort_climb_m`` from where the vehicle is). Below 1 m (final, inertial + sonar) the
landing carries on: the dead-reckoning HPL grows there by design.
"""

from __future__ import annotations

import numpy as np

from visnav.measurements import Health, NavEstimate, PositionReference
from visnav.mission.base import NavigatorRequests, mode_gate
from visnav.mission.integrity import IntegrityWatch
from visnav.log_schema import register_stream

register_stream("reinit", x=("px", "image, OpenCV (x right)", "new point tracked after a re-initialisation"),
                y=("px", "image, OpenCV (y down)", "new point tracked after a re-initialisation"))
register_stream("reacquire")  # a time only: the tracker was re-acquired
register_stream("mpe_end")  # a time only: MPE stopped (below 1 m)
register_stream("palace_progress",
                vision_time=("s", "", "time flown with MPE as the navigation source so far (the mission's clock)"),
                reinitializations=("1", "", "tracker re-initialisations requested so far"),
                fallbacks=("1", "", "fall-backs from MPE to GPS so far"))


class PalaceMission(NavigatorRequests):
    def __init__(self, cfg, navigator, yaw: float = 0.0, image_size=(640, 480), recorder=None):
        self.cfg = cfg
        self.nav = navigator
        self.source = "gps"  # the navigation source this mission set (the navigator starts on GPS)
        self.yaw = float(yaw)
        self.W, self.H = image_size
        self.point = np.array([cfg.landing_point_m[0], cfg.landing_point_m[1], 0.0])
        g = np.deg2rad(cfg.glide_slope_deg)
        self.back = -np.array([np.cos(yaw), np.sin(yaw), 0.0]) / np.tan(g) if g < np.pi / 2 - 1e-9 else np.zeros(3)
        self.sin_g = np.sin(g)
        self.h_ref = cfg.start_height_m
        self.mode = "settle"
        self.t_mode = 0.0
        self.good_since: float | None = None
        self.bad_since: float | None = None
        self.laser_lost_since: float | None = None
        self.abort_hold = None
        self.reinitializations = 0
        self.fallbacks = 0
        self.switch_time: float | None = None
        self.vision_time = 0.0
        self.done = False
        self.aborted = False
        self.record = recorder or (lambda *a, **k: None)
        self._last_t: float | None = None
        self.final_xy = self.point[:2].copy()
        self.integrity = IntegrityWatch(self.record)

    def start_position(self) -> np.ndarray:
        return self.slope_point(self.cfg.start_height_m)

    def slope_point(self, h: float) -> np.ndarray:
        """Point of the glide slope at height ``h`` above the designated point."""
        return self.point + self.back * max(h, 0.0) + np.array([0.0, 0.0, -h])

    def _set(self, mode: str, t: float, why: str = "") -> None:
        self.record("mode", t, mode=mode, previous=self.mode, reason=why)
        self.mode = mode
        self.t_mode = t

    # ------------------------------------------------------------------------------------
    def step(self, t: float, nav: NavEstimate, health: Health) -> tuple[PositionReference, str]:
        out = self._step(t, nav, health)
        self.record("palace_progress", t, vision_time=self.vision_time, reinitializations=self.reinitializations,
                    fallbacks=self.fallbacks)
        return out

    def _step(self, t: float, nav: NavEstimate, health: Health) -> tuple[PositionReference, str]:
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        c = self.cfg
        h_est = -float(nav.position[2])
        self._last_pos = np.array(nav.position, dtype=float)
        descent_rate = 0.0
        if self.source == "mpe":
            self.vision_time += dt
        self.integrity.update(t, health)
        on_gps = self.mode in ("settle", "acquire", "descend_gps", "verify")
        wait = c.integrity_unusable_s
        if on_gps and self.integrity.unusable_for(t) >= wait and t - self.t_mode >= wait:
            self.integrity.react(t, "abort", "unusable on GPS: abort the landing, go around")
            self._abort(t, f"integrity unusable on GPS ({self.integrity.reason})")

        if self.mode == "settle":
            if t - self.t_mode >= c.settle_s:
                self._ask(t, "request-tracking", target_ned=self.point, init_from="gps")
                self._set("acquire", t, "start tracking the designated point")
        elif self.mode == "acquire":
            if health.tracking and not self._pending(health, t):
                self._set("descend_gps", t, "tracking")
        elif self.mode in ("descend_gps", "verify") and not health.tracking and not self._pending(health, t):
            # the correlation tracker reported a failure: repeat the initialisation (§4.1)
            self._ask(t, "request-tracking", target_ned=self.point, init_from="gps")
            self.record("reacquire", t)
            self.good_since = None
        if self.mode == "descend_gps":
            descent_rate = c.descent_speed_mps * self.sin_g
            if self.h_ref <= c.switch_height_m:
                self.h_ref = c.switch_height_m
                descent_rate = 0.0
                self.good_since = None
                self._set("verify", t, "at switch height")
        elif self.mode == "verify":
            good = (health.tracking and health.coherence >= c.coherence_threshold and health.mpe_rate_hz >= 8.0
                    and health.laser_ok and not self._pending(health, t))
            if not good:
                self.good_since = None
            elif self.good_since is None:
                self.good_since = t
            elif t - self.good_since >= c.coherence_time_s:
                self._ask(t, "request-tracking-rebase", init_from="gps")
                self._ask(t, "set-source", source="mpe")
                self.switch_time = t
                self._set("hold" if c.hold_s > 0 else "descend_mpe", t, "2 s of good coherence: switch to MPE")
        elif self.mode == "hold":
            if self._vision_checks(t, health, h_est) and t - self.t_mode >= c.hold_s:
                self._set("descend_mpe", t, "hold complete")
        elif self.mode == "descend_mpe":
            descent_rate = self._flare(c.descent_speed_mps * self.sin_g)
            if self._vision_checks(t, health, h_est) and h_est <= c.inertial_height_m:
                self._ask(t, "set-source", source="inertial")
                self.record("mpe_end", t)
                self._ask(t, "stop-tracking")
                self.final_xy = self.slope_point(self.h_ref)[:2].copy()
                self._set("final", t, "below 1 m: inertial + sonar")
        elif self.mode == "final":
            descent_rate = c.final_descent_mps
        elif self.mode == "abort":
            if self.abort_hold is not None and t - self.t_mode > 8.0:
                self.done = True
        elif self.mode == "landed":
            self.done = True

        if self.mode == "abort":
            pos = self.abort_hold
            vel = np.zeros(3)
        elif self.mode in ("final", "landed"):
            # last metre: slide over the point at the final rate, then settle vertically onto it
            step = self.point[:2] - self.final_xy
            dist = float(np.linalg.norm(step))
            v_xy = np.zeros(2)
            if dist > 1e-6:
                move = min(dist, c.final_descent_mps * dt)
                self.final_xy = self.final_xy + step / dist * move
                v_xy = step / dist * c.final_descent_mps if dist > move else np.zeros(2)
            # rate control on the way down: the height reference follows the (sonar) estimate, so
            # no height error winds up and the sink rate is the commanded one at touchdown
            self.h_ref = min(self.h_ref, h_est) - descent_rate * dt
            pos = np.array([self.final_xy[0], self.final_xy[1], -self.h_ref])
            vel = np.array([v_xy[0], v_xy[1], descent_rate])
        else:
            floor = c.inertial_height_m * 0.5
            self.h_ref = max(self.h_ref - descent_rate * dt, floor)
            pos = self.slope_point(self.h_ref)
            moving = descent_rate > 0 and self.h_ref > floor
            vel = (self.back * -1.0 + np.array([0.0, 0.0, 1.0])) * descent_rate if moving else np.zeros(3)
        ref = PositionReference(t=t, position=pos, velocity=vel, yaw=self.yaw, source=self.source)
        return ref, self.mode

    def _flare(self, rate: float) -> float:
        """Below ``flare_height_m`` the sink rate eases linearly to the final rate at 1 m AGL."""
        c = self.cfg
        lo, hi = c.inertial_height_m, max(c.flare_height_m, c.inertial_height_m + 1e-6)
        f = float(np.clip((self.h_ref - lo) / (hi - lo), 0.0, 1.0))
        return min(rate, c.final_descent_mps + f * (rate - c.final_descent_mps))

    def _vision_checks(self, t: float, health: Health, h_est: float) -> bool:
        """Safety rules while flying on MPE; returns False when the mode changed."""
        c = self.cfg
        # laser lost above 1 m -> soft abort (after the +-3 deg search failed for laser_loss_s)
        if not health.laser_ok and h_est > 1.0:
            if self.laser_lost_since is None:
                self.laser_lost_since = t
            elif t - self.laser_lost_since >= c.laser_loss_s:
                self._abort(t, "laser return lost above 1 m")
                return False
        else:
            self.laser_lost_since = None
        if self._pending(health, t):
            return True
        # MPE jumps or stops updating at 10 Hz, or the navigator's integrity is unusable -> back to GPS, re-verify
        lost = self.integrity.unusable_for(t) >= c.integrity_unusable_s
        bad = health.mpe_jump or lost or (t - (self.switch_time or t) > 1.0 and health.mpe_rate_hz < 8.0)
        if bad:
            if self.bad_since is None:
                self.bad_since = t
            elif t - self.bad_since >= 0.3 or health.mpe_jump or lost:
                self.fallbacks += 1
                if lost:
                    self.integrity.react(t, "fallback", "unusable on MPE: back to GPS")
                if self.fallbacks > c.max_fallbacks:
                    self._abort(t, f"MPE failed {self.fallbacks} times: soft abort on GPS")
                    return False
                self._ask(t, "set-source", source="gps")
                self._ask(t, "request-tracking", target_ned=None, init_from="gps")
                self.reinitializations += 1
                self.bad_since = None
                self.h_ref = h_est
                self._set("verify", t, "integrity unusable on MPE: back to GPS" if lost
                          else "MPE jump or rate below 10 Hz: back to GPS")
                return False
        else:
            self.bad_since = None
        # tracked point near the image edge -> re-initialise near the image centre (from MPE)
        x, y = health.tracked_px
        m = c.edge_margin_px
        if np.isfinite(x) and not (m <= x <= self.W - 1 - m and m <= y <= self.H - 1 - m):
            self._ask(t, "request-tracking", target_ned=None, init_from="estimate")
            self.reinitializations += 1
            self.record("reinit", t, x=x, y=y)
        return True

    def _abort(self, t: float, why: str) -> None:
        self._ask(t, "set-source", source="gps")
        self._ask(t, "stop-tracking")
        self.aborted = True
        # soft abort (§3.2): climb abort_climb_m straight up from where the vehicle is
        self.abort_hold = self._last_pos + np.array([0.0, 0.0, -self.cfg.abort_climb_m])
        self._set("abort", t, why)

    @mode_gate
    def camera_wanted(self, t: float) -> bool:
        """Frames are needed until MPE ends (below 1 m: inertial + sonar), and not during an abort."""
        return self.mode not in ("final", "landed", "abort")

    def on_touchdown(self, t: float) -> None:
        if self.mode != "landed":
            self._set("landed", t, "weight on wheels")
            self.done = True
