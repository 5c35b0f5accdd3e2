"""CONDOR's mission (seed 004 ch. 6-7): GPS loiter round the tent -> switch -> GPS-free vision orbit.

* ``gps_loiter``: the autopilot's loiter of ``loiter_radius_m`` round the surveyed tent, the
  coordinated logic on the navigator's GPS range (base rate ``V_GS / R_loiter`` from a 0.5 s mean of
  the GPS ground speed);
* at ``switch_time_s``, once the vision radius is coming in (``health.tracking``), the custom mode
  takes over: ``set_source("vision")`` to the navigator, and the configured orbit logic (eq. 5.1-5.3,
  7.1) flies ``radius_m`` on the vision range alone; while the radius is stale the base rate is held
  (never a NaN to the controller).
* integrity (issue #18, ``mission/integrity.IntegrityWatch``): the navigator ``unusable`` (no vision
  radius for its ``stale_s``, or a protection level past its alert limit) for ``integrity_unusable_s`` on
  the vision orbit -> back to the GPS loiter (``set_source("gps")``: the autopilot's own navigation,
  which never stopped); vision again after ``integrity_ok_s`` ok, at most ``max_fallbacks`` times.
  Each reaction is logged in ``integrity_reaction``, the mode change in ``mode``.

``step(t, estimate, health) -> (TurnReference, mode)`` at the autopilot's rate; ``info`` holds the
outer loop's internals for the log; ``recorder(stream, t, **fields)`` gets the mode changes.
"""

from __future__ import annotations

from visnav.guidance.orbit import OrbitGains, OrbitGuidance
from visnav.measurements import FixedWingEstimate, Health, NavCommand, TurnReference
from visnav.mission.integrity import IntegrityWatch


class CondorMission:
    def __init__(self, cfg, gains, navigator, airspeed_mps: float, recorder=None) -> None:
        """``cfg``: the scenario's ``mission`` block (``config_condor.CondorMissionConfig``); ``gains``: the orbit
        controller's logic and gains (``control.condor.orbit``); ``airspeed_mps``: the aircraft's
        (``vehicle.airspeed_mps``)."""
        self.cfg, self.nav, self.airspeed = cfg, navigator, airspeed_mps
        self.record = recorder or (lambda *a, **k: None)
        o, k, va = cfg.orbit, gains, airspeed_mps
        g_orig, g_mod = OrbitGains(k.kp_original, k.kd_original), OrbitGains(k.kp_modified, k.kd_modified)
        self.guidance = OrbitGuidance(k.logic, o.radius_m, va, g_orig, g_mod, k.base_limit)
        # the GPS loiter knows its ground speed: base rate V_GS / R_loiter from a 0.5 s mean of it
        self.loiter = OrbitGuidance("coordinated", o.loiter_radius_m, va, g_orig, g_mod, k.base_limit, v_avg_tau_s=0.5)
        self.mode = "gps_loiter"
        self.done = False
        self.switched_at: float | None = None
        self.info: dict = {}
        self._t: float | None = None
        self.watch = IntegrityWatch(self.record)
        self.fallbacks = 0

    def start(self, t: float) -> None:
        self.record("mode", t, mode=self.mode,
                    reason=f"GPS loiter at {self.cfg.orbit.loiter_radius_m:.0f} m, tracker started on the tent")

    def on_touchdown(self, t: float) -> None:
        """A fixed wing on an orbit has no touchdown."""

    def step(self, t: float, estimate: FixedWingEstimate, health: Health) -> tuple[TurnReference, str]:
        cfg, o = self.cfg, self.cfg.orbit
        dt = 1.0 / 50.0 if self._t is None else t - self._t
        self._t = t
        e = estimate
        self.watch.update(t, health)
        if self.mode == "vision_orbit" and self.watch.unusable_for(t) >= o.integrity_unusable_s:
            self.fallbacks += 1
            self.mode = "gps_loiter"
            self.nav.command(NavCommand(t, "set_source", {"source": "gps"}))
            self.watch.react(t, "fallback to GPS", f"unusable {self.watch.unusable_for(t):.1f} s on the vision orbit "
                                                   f"(fallback {self.fallbacks} of {o.max_fallbacks})")
            self.record("mode", t, mode=self.mode, reason=f"integrity unusable: back to the GPS loiter "
                                                          f"({self.watch.reason})")
            e = self.nav.estimate(t)
        elif self.mode == "gps_loiter" and t >= o.switch_time_s and health.tracking and (
                self.fallbacks == 0 or (self.fallbacks < o.max_fallbacks and self.watch.ok_for(t) >= o.integrity_ok_s)):
            self.mode = "vision_orbit"
            self.switched_at = t if self.switched_at is None else self.switched_at
            self.nav.command(NavCommand(t, "set_source", {"source": "vision"}))
            why = "custom mode switched on (vision radius in)"
            if self.fallbacks:
                why = f"vision again after {self.watch.ok_for(t):.1f} s ok (fallback {self.fallbacks})"
                self.watch.react(t, "back to vision", why)
            self.record("mode", t, mode=self.mode, reason=why)
            e = self.nav.estimate(t)
        if self.mode == "gps_loiter":
            if e.radius_valid and e.ground_speed == e.ground_speed:
                ref = self.loiter.update(dt, e.radius, e.radius_rate, e.ground_speed)
            else:  # no GPS fix yet (or lost): the loiter's base rate
                base = self.loiter.v_avg / self.loiter.r_des
                ref = {"psidot_ref_ail": base, "psidot_ref_rud": None, "base": base, "err": 0.0,
                       "v_bank": self.loiter.v_avg}
        else:
            ref = self.guidance.update(dt, e.radius, e.radius_rate, e.airspeed)
            if not e.radius_valid:  # no vision: hold the base rate (never a NaN to the controller)
                ref = {**ref, "psidot_ref_ail": ref["base"], "err": 0.0,
                       "psidot_ref_rud": None if ref["psidot_ref_rud"] is None else ref["base"]}
        self.info = {"R": e.radius, "Rdot": e.radius_rate, "base": ref["base"], "err": ref["err"],
                     "psidot_ref": ref["psidot_ref_ail"]}
        return TurnReference(t, ref["psidot_ref_ail"], ref["psidot_ref_rud"], ref["v_bank"], cfg.altitude_m,
                             self.airspeed), self.mode


class GroundTestMission:
    """The static ground test of ch. 4 (Tables 4.1-4.2): nothing flies; ``finish`` marks it done."""

    def __init__(self) -> None:
        self.mode, self.done, self.info = "ground_test", False, {}

    def step(self, t: float, estimate=None, health=None) -> tuple[None, str]:
        return None, self.mode

    def on_touchdown(self, t: float) -> None:
        """Nothing flies."""

    def finish(self, t: float) -> None:
        self.mode, self.done = "done", True
