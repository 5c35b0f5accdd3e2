"""The ship-deck landing mission (seed 003 §5.3): manual, hover, approach, descend, landed / missed.

``DeckMission.step(t, estimate, health) -> (DeckReference, mode)`` at the controller's rate. Modes
(logged in the ``mode`` stream with the reason of each change):

* ``manual`` - before the hand-over (in §5.3.2 and §5.3.5 the vehicle was flown by hand while the
  estimator started and converged): with ``start.pilot = "imu"`` a level hover on the IMU alone
  (reference ``level``), with ``"truth"`` the safety pilot holds the start point on what he sees (the
  ``RelativeStateSample`` of the pilot sensor, ``sensors/deck_observer.py``, passed to the controller
  as ``pilot_view``). After ``start.manual_s`` the hand-over waits for the operator's check (§5.3.1),
  which the navigator's ``health.converged`` reports (every frame of the last second with >= 3 lights
  and an RMS bearing innovation below ``filter.converged_bearing_rms_deg``); failing it the filter is
  restarted (the thesis' operator reset it, Fig. 5.7): with the eq. 5.12 start from the next relative
  yaw of ``filter.yaw_hypotheses_deg`` (``NavCommand("restart")``), with the Vicon start from the newest
  motion-capture sample (``NavInit``); the hold goes on. On hand-over the navigator is told to track
  (``NavCommand("track")``: the sensor's own R);
* ``hover`` (moving deck) - autonomous hold on the estimates for at least ``hover_min_s``, until the
  start conditions of §5.3.5 hold (near the start point; predicted approach path within
  ``lambda_max_deg`` of the start azimuth and at least ``gamma_min_deg`` from vertical);
* ``approach`` - the tau trajectory (static: three straight gaps, k = 0.3, 15 s; moving: alpha,
  beta, rho gaps of ch. 4, re-aimed at every step at the latest touchdown prediction through a
  first-order filter); a moving-deck trajectory ends with the flare (``control/deck.flare``); one that
  ends without contact goes around (back to ``hover``) up to ``guidance.go_arounds`` times;
* ``descend`` - past the trajectory's end without contact: thrust along the estimated deck normal,
  sink at ``final_descent_mps`` (not in the thesis, whose runs end at the trajectory's end); the navigator
  unusable for ``guidance.integrity_unusable_s`` in it, the descent goes on blind as a blind end's (below);
* ``landed`` / ``missed`` - ``on_touchdown``: the gear met the deck on / off the plate.

Integrity (issue #18, ``mission/integrity.IntegrityWatch``; not in the thesis, whose safety pilot took
over): on a moving deck the navigator ``unusable`` (no frame fused for ``filter.integrity_stale_s``) for
``guidance.integrity_unusable_s`` during an approach with more than ``guidance.integrity_commit_s`` to go
is a go-around (back to ``hover``, one of ``guidance.go_arounds``); no approach starts while it is
unusable (the hover holds). On a static deck (``guidance.static_integrity``) the same unusable mid-approach
holds (the blind hold) and a new straight approach starts from where the vehicle is once the fix has been
``ok`` for ``go_around_hover_s``. In the approach's last ``integrity_commit_s``, or its last
``integrity_commit_m`` of the planned path, the landing goes on (the lights leave the view near the deck); a
trajectory that then ends without contact and without a trusted fix lands on (``guidance.blind_end = "land"``:
``descend`` level, the horizontal velocity arrested, sinking at ``final_descent_mps`` on the IMU, at most
``blind_land_s``) instead of going around over the heaving deck.
A hover without a fix holds blind (:meth:`DeckMission._blind_hold`): it climbs ``blind_climb_m`` at
``blind_climb_mps`` on the IMU with the horizontal velocity arrested, then steers back to the start point on
the dead-reckoned estimate. Each reaction is logged in ``integrity_reaction``.
"""

from __future__ import annotations

import numpy as np

from visnav.geometry.rotations import euler_to_dcm3
from visnav.guidance.deck_approach import (StraightApproach, TauGapApproach, level_deck_geometry, rot_z,
                                           touchdown_acceleration, touchdown_target)
from visnav.measurements import DeckReference, NavCommand, NavInit, RelativeStateSample
from visnav.mission.integrity import IntegrityWatch

BLIND_GAIN_PER_S = 2.0  # the blind hold's vertical-speed loop on the IMU [1/s]
BLIND_ACCEL_MAX = 2.0  # ... and its largest vertical acceleration command [m/s^2]
V_UP_TAU_S = 1.0  # the IMU's vertical speed follows a trusted fix's with this time constant [s]
# a blind hold this long [s] climbs at BLIND_DRIFT_CLIMB_MPS instead of holding: on the IMU alone its vertical speed
# drifts by a few cm/s (IMU drops seed 3: 0.04 m/s down, onto the sea 3.4 m off after 40 s): away from the deck
BLIND_LONG_S, BLIND_DRIFT_CLIMB_MPS = 5.0, 0.1
# a hover whose navigator has been degraded (its own consistency tests failing) this long [s] holds blind and level:
# a filter re-acquired after a black-out flapped between fixes with velocities 4 m/s off while its HPL said
# 0.04-0.2 m, and the hover followed it off the plate (black-out seed 8); fault-free episodes last 0.02-0.3 s
DEGRADED_HOLD_S = 0.5
BLIND_FOLLOW_HPL_M = 1.0  # above this HPL the hold is level (no horizontal loop on the estimate either)
G = 9.81


class DeckMission:
    def __init__(self, cfg, navigator, hold_point, gear_offset: float, period_s: float, recorder=None, *, filter_cfg,
                 deck, gains):
        """``cfg``: the ``DeckMissionConfig``; ``filter_cfg``: the navigator's (``navigation``, its start and yaw
        hypotheses for restarts); ``deck``: the world's deck (``world.deck``); ``gains``: the trajectories' tau
        couplings and the follower's spring-damper (``control.deck``); ``hold_point``: the start point held in ``manual`` and ``hover``
        (level-deck frame, vehicle relative to the deck); ``period_s``: the interval ``step`` is called at."""
        self.cfg, self.nav, self.filter_cfg = cfg, navigator, filter_cfg
        self.period = period_s
        self.start_rel_ld = np.asarray(hold_point, float)
        self.gear_offset = gear_offset
        self.recorder = recorder
        self.gains = gains
        self.moving = deck.motion == "moving"
        self.landing_point = np.asarray(cfg.guidance.landing_point_m, float)
        self.approach = None
        self._a_td = np.zeros(3)
        self._c0 = np.zeros(3)
        self._go_arounds = 0
        self._n_restarts = 0
        self._seen: dict[str, RelativeStateSample] = {}
        self.watch = IntegrityWatch(recorder)
        self._held = False  # an approach start is being held for integrity (logged once per hold)
        self._blind_t: float | None = None  # start of the hover's level hold without a fix
        self._v_up: float | None = None  # vertical speed (up) the level hold flies on (_vertical_speed)
        self._climbed = 0.0  # height gained on the IMU since the blind hold began
        self._climb_to = 0.0  # ... and what it climbs to before steering back to the start point
        self._blind_land_t: float | None = None  # start of a blind end's descent (blind_end = "land")
        self._v_land = 0.0  # its vertical speed (up): the level hold's at its start, the IMU alone since
        self.mode, self.t_mode, self.done = "", 0.0, False
        self._set_mode(0.0, "manual", "pilot holds the start while the filter starts")

    # --- inputs besides the navigator --------------------------------------------------------
    def observe(self, m: RelativeStateSample) -> None:
        """The safety pilot's / motion capture's view (``m.source``: pilot | mocap); the newest is kept."""
        self._seen[m.source] = m

    def on_touchdown(self, t: float, on_deck: bool = True, reason: str = "gear contact") -> None:
        self._set_mode(t, "landed" if on_deck else "missed", reason)
        self.done = True

    # --- the state machine -------------------------------------------------------------------
    def _set_mode(self, t, mode, reason):
        if self.recorder is not None:
            self.recorder("mode", t, mode=mode, previous=self.mode, reason=reason)
        self.mode, self.t_mode = mode, t

    def target(self, Cd0, wd, psi_d, t_go, along=None):
        """The touchdown target and the deck normal (``touchdown_target``); ``along``: the final path's direction."""
        g = self.cfg.guidance
        return touchdown_target(Cd0, wd, psi_d, t_go, self.landing_point, self.gear_offset,
                                g.overshoot_moving_m if self.moving else g.overshoot_m, self.moving, along)

    def step(self, t: float, est, health) -> tuple[DeckReference, str]:
        cfg, g = self.cfg, self.cfg.guidance
        # the rules below act on the filter's own share of the HPL (``DeckHealth.hpl_noise_m``): what grows in an
        # outage or a fault. The LED survey's constant share is a property of the installation that no rule in
        # flight can change; taken at the contact range it held 5 more of 100 moving-deck fault runs' approaches,
        # and their go-arounds ended off the plate (issue 30)
        self.watch.update(t, health, getattr(health, "hpl_noise_m", None))
        mode = self.mode
        pilot_view = None
        if mode == "manual" and cfg.start.pilot == "truth" and "pilot" in self._seen:
            pilot_view = self._seen["pilot"].state  # the safety pilot flies on what he sees
        x = pilot_view if pilot_view is not None else est.state
        p, vel, Cd0, psi_d, wd = level_deck_geometry(x, est.gyro, est.roll, est.pitch)
        p_ld = rot_z(psi_d).T @ p
        self._vertical_speed(est, -(rot_z(psi_d).T @ vel)[2])
        tm = t - self.t_mode
        if mode in ("manual", "hover"):
            if mode == "manual" and tm >= cfg.start.manual_s:
                if health.converged:
                    self._begin(t, p_ld, Cd0, wd, psi_d)
                else:
                    self._restart(t)
            elif mode == "hover":
                if self.moving:
                    self._maybe_start(t, tm, p_ld, Cd0, wd, psi_d)
                elif tm >= g.go_around_hover_s and self.watch.ok_for(t) >= g.go_around_hover_s:
                    # static deck after an integrity hold: a new straight approach from where the vehicle is
                    self._straight(t, p_ld, Cd0, wd, psi_d, f"fix good for {g.go_around_hover_s:g} s: straight tau "
                                                            f"gaps again")
                if self.mode == "hover" and (self.watch.unusable_for(t) >= g.blind_hold_s or (
                        self.watch.seen_ok and self.watch.state != "unusable" and self.watch.hpl_m > g.hover_hpl_m)
                        or self._degraded_for(t) >= DEGRADED_HOLD_S):
                    return self._blind_hold(t, p_ld), self.mode
                self._blind_t = None
            if self.mode == "manual" and cfg.start.pilot == "imu":
                return self._manual_level(t, est, health), self.mode
            return DeckReference(t=t, kind="follow", position=self.start_rel_ld, velocity=np.zeros(3),
                                 accel=np.zeros(3), pilot_view=pilot_view), self.mode
        tau = isinstance(self.approach, TauGapApproach)
        if mode == "approach":
            n_up = None
            if tau:
                # the overshoot along the final path (the last aim's a_td): contact at the landing point
                c, n_up = self.target(Cd0, wd, psi_d, max(self.approach.T - tm, 0.0), along=self._a_td)
                try:
                    a_td, _, _ = touchdown_acceleration(n_up, g.touchdown_accel_mps2)
                    # the prediction is noisy (deck rates x time to go): re-aim through a first-order filter
                    w = min(self.period / g.retarget_tau_s, 1.0) if g.retarget_tau_s > 0 else 1.0
                    self._a_td = self._a_td + w * (a_td - self._a_td)
                    self.approach.retarget(self._a_td)
                except ValueError as exc:  # predicted deck too steep to match: keep the last aim, say so
                    if self.recorder is not None:
                        self.recorder("retarget_skipped", t, reason=str(exc))
            else:
                c = self._c0
            pd, vd, a_now = self.approach.desired(tm)
            # the horizontal channel moves by tilting, through the attitude loop's lag: its acceleration feed-forward
            # is taken feedforward_lead_s ahead, its position and velocity reference_lead_s ahead (without, the
            # vehicle reached the deck 2-4 cm behind its reference and landed behind the point, 19 of 20 seeds); the
            # vertical channel (thrust, fast) as it is
            T = self.approach.T
            p_h, v_h, _ = self.approach.desired(min(tm + self.gains.reference_lead_s, T))
            _, _, a_lead = self.approach.desired(min(tm + self.gains.feedforward_lead_s, T))
            ref = DeckReference(t=t, kind="follow", position=c + np.array([p_h[0], p_h[1], pd[2]]),
                                velocity=np.array([v_h[0], v_h[1], vd[2]]),
                                accel=np.array([a_lead[0], a_lead[1], a_now[2]]), target=c, normal=n_up,
                                flare_time_left=self.approach.T - tm if tau else None)
            # committed in the last integrity_commit_s or the last integrity_commit_m of the planned path (the
            # lights leave the view 7-11 cm above the deck, with up to 2.8 s of the slow static tau end to fly)
            committed = self.approach.T - tm <= g.integrity_commit_s or np.linalg.norm(pd) <= g.integrity_commit_m
            why = self._no_commit(t, hpl=tau) if (tau or g.static_integrity) and not committed else ""
            if why:
                # no touchdown without a fix: go around even with the go-arounds used up (the hover holds and
                # starts again when the fix is good; no landing is safe, a blind one is not)
                self._go_arounds += 1
                self.watch.react(t, "go-around", f"{why}, {self.approach.T - tm:.1f} s to go")
                self._set_mode(t, "hover", f"integrity: {why}: go-around {self._go_arounds}")
                return ref, self.mode
            if tm >= self.approach.T:
                blind = self._no_commit(t, persist=False) if tau and g.blind_end == "land" else ""
                if blind:
                    # no contact and no fix: the vehicle is at the deck by construction (its estimate a few cm
                    # off); a go-around from there blind swept it over the heaving deck (black-out seed 7):
                    # finish the landing on the deck UKF's prediction, gently
                    self._blind_land_t = t
                    self._v_land = self._v_up if self._v_up is not None else 0.0
                    self.watch.react(t, "land on", f"{blind}: trajectory ended without contact, descend on the "
                                                   f"prediction for at most {g.blind_land_s:g} s")
                    self._set_mode(t, "descend", f"trajectory ended without contact, no fix ({blind}): land on")
                elif tau and self._go_arounds < g.go_arounds:
                    # no contact at the trajectory's end: back to the start point, a new approach when the
                    # start conditions hold again (the descend mode would hold the matched tilt for too long)
                    self._go_arounds += 1
                    self._set_mode(t, "hover", f"trajectory ended without contact: go-around {self._go_arounds}")
                else:
                    self._set_mode(t, "descend", "trajectory ended without contact")
            return ref, self.mode
        # descend
        blind = self._no_commit(t, hpl=False) if self._blind_land_t is None else ""
        if blind:
            # the fix lost in the descent (no frame fused: the lights leave the view near the deck): finish it on the
            # IMU as a blind end does, for at most blind_land_s, then climb away. Descending on the last estimate
            # instead, a static deck's IMU-drop run hovered 28 s without contact and flew off at 8 m/s (round 18)
            self._blind_land_t = t
            self._v_land = self._v_up if self._v_up is not None else 0.0
            self.watch.react(t, "land on", f"{blind} in the descent: on the IMU for at most {g.blind_land_s:g} s")
        if self._blind_land_t is not None and t - self._blind_land_t >= g.blind_land_s:
            # the blind end found no deck within blind_land_s: its height estimate is off, climb away
            self._blind_land_t = None
            self._go_arounds += 1
            self.watch.react(t, "go-around", f"no contact after {g.blind_land_s:g} s of blind descent")
            self._set_mode(t, "hover", f"blind descent without contact: go-around {self._go_arounds}")
            self._blind_t = None
            return self._blind_hold(t, p_ld), self.mode
        c, n_up = self.target(Cd0, wd, psi_d, 0.0)
        if self._blind_land_t is not None:
            # blind: thrust level, the horizontal velocity arrested (no spring to the predicted point, no tilt
            # onto the predicted normal, no flare: they swept it sideways at 0.4 m/s over the last 3 cm, seed 7),
            # the sink rate on the IMU from the last good fix (a filter re-acquired near the deck had the
            # vehicle sinking while it hovered 4 cm above the deck, seed 5)
            self._v_land += self._imu_up_accel(est) * self.period
            a_up = float(np.clip(self.gains.damper_per_s * (-g.final_descent_mps - self._v_land), -BLIND_ACCEL_MAX,
                                 BLIND_ACCEL_MAX))
            return DeckReference(t=t, kind="descend", target=np.array([p_ld[0], p_ld[1], c[2]]),
                                 normal=np.array([0.0, 0.0, -1.0]), vertical_accel=-a_up), self.mode
        return DeckReference(t=t, kind="descend", target=c, normal=n_up,
                             flare_time_left=np.inf if tau else None), self.mode

    def _no_commit(self, t: float, persist: bool = True, hpl: bool = True) -> str:
        """Why the relative position is not known well enough to commit to a touchdown ('' if it is):
        the navigator unusable (for ``integrity_unusable_s`` with ``persist``), or (with ``hpl``) usable with its
        protection level above ``commit_hpl_m``."""
        g, w = self.cfg.guidance, self.watch
        if not w.seen_ok:
            return ""
        if w.state == "unusable":  # (its own persistence: a short outage is ridden through)
            return f"navigator unusable {w.unusable_for(t):.1f} s" if (
                not persist or w.unusable_for(t) >= g.integrity_unusable_s) else ""
        if hpl and w.hpl_m > g.commit_hpl_m:
            return f"HPL {w.hpl_m:.2f} m above {g.commit_hpl_m:g} m"
        return ""

    def _degraded_for(self, t: float) -> float:
        """How long the navigator has been ``degraded`` (0 when it is not)."""
        w = self.watch
        return t - w.since if w.state == "degraded" and w.seen_ok else 0.0

    def _vertical_speed(self, est, v_up_fix: float) -> None:
        """The vertical speed (up) the blind hold and the blind landing fly on: the IMU's vertical acceleration
        integrated, pulled towards the navigator's vertical speed with ``V_UP_TAU_S`` while its fix is trusted
        (``ok``, HPL within ``commit_hpl_m`` on a moving deck, ``hover_hpl_m`` on a static one, whose approach the
        HPL does not gate; the first such fix sets it: with ``commit_hpl_m`` the static deck's 0.2 m HPL never set
        it, and its holds flew without a vertical-speed loop, black-out seed 5). Only a trusted fix: the HPL bounds
        the horizontal error, and a degraded fix whose HPL was still below ``hover_hpl_m`` had the vertical speed
        0.4-0.6 m/s off (IMU drops seed 11, accelerometer bias seed 20), which the hold then flew for good.
        The time constant averages the deck's heave out of the relative speed."""
        g, w = self.cfg.guidance, self.watch
        trusted = (w.state == "ok" and w.hpl_m <= (g.commit_hpl_m if self.moving else g.hover_hpl_m)
                   and np.isfinite(v_up_fix))
        if self._v_up is None:
            if trusted:
                self._v_up = float(v_up_fix)
            return
        self._v_up += self._imu_up_accel(est) * self.period
        if trusted:
            self._v_up += (float(v_up_fix) - self._v_up) * min(self.period / V_UP_TAU_S, 1.0)

    @staticmethod
    def _imu_up_accel(est) -> float:
        """The vertical acceleration (up) from the IMU's specific force and the autopilot's roll and pitch."""
        if not (np.isfinite(est.roll) and np.isfinite(est.pitch)):
            return 0.0
        f = np.asarray(est.accel, float) - est.accel_bias  # the navigator's accelerometer-bias estimate taken off
        return float(-(euler_to_dcm3(float(est.roll), float(est.pitch), 0.0) @ f)[2] - G)

    def _blind_hold(self, t: float, p_ld: np.ndarray) -> DeckReference:
        """Hover without a fix (unusable for ``blind_hold_s``, or its HPL above ``hover_hpl_m``): a go-around
        flown on the IMU. The vertical loop never flies on the estimate's height (it may lead it onto the deck):
        it climbs at ``blind_climb_mps`` by ``blind_climb_m`` (the vertical speed of the last good fix plus the
        IMU since, :meth:`_vertical_speed`), with the horizontal velocity arrested (no sweep over a heaving
        deck a few cm below: black-out seed 7), then holds the height while the horizontal loop steers back to
        the start point on the dead-reckoned estimate (it brings the lights back into view: a level hold on the
        IMU alone drifted out of view for good), until the fix is good again. The climb goes no higher than the
        start height by the estimate (straight up from 0.8 m the lights came back at the bottom of the image and
        the filter re-acquired 0.3 m off, blur seed 11); level when the HPL is above ``BLIND_FOLLOW_HPL_M`` or the
        navigator has been degraded for ``DEGRADED_HOLD_S`` (its updates are suspect, so is the estimate). After
        ``BLIND_LONG_S`` without a fix it climbs at ``BLIND_DRIFT_CLIMB_MPS``: the IMU's drift away from the deck."""
        g, w = self.cfg.guidance, self.watch
        if self._blind_t is None:
            self._blind_t, self._climbed = t, 0.0
            # up to the start height by the estimate, at most blind_climb_m (all of it if the estimate is no guide)
            below = -self.start_rel_ld[2] + p_ld[2] if w.hpl_m <= BLIND_FOLLOW_HPL_M else np.inf
            self._climb_to = float(np.clip(below, 0.0, g.blind_climb_m))
            w.react(t, "hold height", f"hover without a fix (HPL {w.hpl_m:.2f} m): height on the IMU, climb "
                                      f"{self._climb_to:.2f} m at {g.blind_climb_mps:g} m/s")
        v_up = self._v_up if self._v_up is not None else 0.0
        climbing = self._climbed < self._climb_to
        v_ref = g.blind_climb_mps if climbing else BLIND_DRIFT_CLIMB_MPS if t - self._blind_t >= BLIND_LONG_S else 0.0
        a_up = float(np.clip(BLIND_GAIN_PER_S * (v_ref - v_up), -BLIND_ACCEL_MAX, BLIND_ACCEL_MAX))
        self._climbed += v_up * self.period
        if w.hpl_m > BLIND_FOLLOW_HPL_M or self._degraded_for(t) >= DEGRADED_HOLD_S:  # no guide: level
            return DeckReference(t=t, kind="level", accel=np.array([0.0, 0.0, -a_up]))
        # climbing: the position loop on where the vehicle is (its damper arrests the horizontal velocity)
        pos = np.asarray(p_ld, float).copy() if climbing else self.start_rel_ld
        return DeckReference(t=t, kind="follow", position=pos, velocity=np.zeros(3), accel=np.zeros(3),
                             vertical_accel=-a_up)

    def _manual_level(self, t: float, est, health) -> DeckReference:
        """The hover before the hand-over (``start.pilot = "imu"``): level on the autopilot's attitude, the vertical
        channel holding zero vertical speed. On the IMU alone an accelerometer bias b is a vertical acceleration
        that runs it off (0.08 m/s^2: 1 m in 5 s, deck-static seed 4; 0.2: 5 m, seed 11): while the filter uses at
        least 3 lights its vertical speed (level-deck frame, with the deck attitude it has) damps it with
        ``start.level_damping_per_s`` (issue 30; the bias states take the rest off the specific force,
        ``DeckEstimate``)."""
        a_up, k = 0.0, self.cfg.start.level_damping_per_s
        if k > 0 and getattr(health, "lights_used", 0) >= 3:
            _, vel, _, psi_d, _ = level_deck_geometry(est.state, est.gyro, est.roll, est.pitch)
            v_up = -float((rot_z(psi_d).T @ vel)[2])  # the vehicle's velocity relative to the deck, z down
            if np.isfinite(v_up):
                a_up = float(np.clip(-k * v_up, -BLIND_ACCEL_MAX, BLIND_ACCEL_MAX))
        return DeckReference(t=t, kind="level", accel=np.array([0.0, 0.0, -a_up]))

    def _restart(self, t: float) -> None:
        f = self.filter_cfg
        hyp = f.yaw_hypotheses_deg
        if self._n_restarts >= len(hyp):
            raise RuntimeError("the deck filter did not converge from any initial yaw hypothesis")
        if f.init == "truth":  # the Vicon start again, from where the vehicle is now
            seen = self._seen.get("mocap")
            if seen is None:
                raise RuntimeError("filter.init = truth needs the motion-capture sample to restart from")
            self.nav.initialize(NavInit(t=t, source="truth+noise (restart)", state=seen.state,
                                        covariance=np.diag(seen.sigma**2)))
            why = "restart from the truth"
        else:
            self.nav.command(NavCommand(t, "restart", {"yaw_deg": float(hyp[self._n_restarts])}))
            why = f"restart from relative yaw {hyp[self._n_restarts]:.0f} deg"
        self._n_restarts += 1
        self._set_mode(t, "manual", f"filter not converged: {why}")

    def _begin(self, t, p_ld, Cd0, wd, psi_d):
        g = self.cfg.guidance
        self.nav.command(NavCommand(t, "track"))  # converged: from now on the sensor's own noise
        if not self.moving:
            self._straight(t, p_ld, Cd0, wd, psi_d, f"manual hold over; straight tau gaps, k={self.gains.k_static}, "
                                                    f"T={g.duration_s}s")
        else:
            self._set_mode(t, "hover", "handed over to the autonomy")

    def _straight(self, t, p_ld, Cd0, wd, psi_d, why: str) -> None:
        """Static deck: the straight tau approach from where the vehicle is to the landing point."""
        g = self.cfg.guidance
        # the overshoot along the normal, as the thesis: the straight path meets the deck 4-6 cm short of the
        # landing point, but along the path (the moving deck's) it meets it at the deck origin, where the camera
        # of eq. 5.9 loses every light: seed 11 lost them 2.8 s before contact and never landed (issue 30 round 10)
        self._c0, _ = self.target(Cd0, wd, psi_d, 0.0)
        self.approach = StraightApproach(p_ld - self._c0, g.duration_s, self.gains.k_static)
        self._set_mode(t, "approach", why)

    def _maybe_start(self, t, tm, p_ld, Cd0, wd, psi_d):
        g = self.cfg.guidance
        if tm < (g.go_around_hover_s if self._go_arounds else g.hover_min_s):
            return
        rho0 = float(np.linalg.norm(p_ld))
        T = np.sqrt(18.0 * rho0 / g.touchdown_accel_mps2)
        c, n_up = self.target(Cd0, wd, psi_d, T)
        try:
            a_td, lam, gam = touchdown_acceleration(n_up, g.touchdown_accel_mps2)
        except ValueError:
            return
        az = np.arctan2(p_ld[1] - c[1], p_ld[0] - c[0])
        dl = abs((lam - az + np.pi) % (2 * np.pi) - np.pi)
        near = np.linalg.norm(p_ld - self.start_rel_ld) <= g.start_tolerance_m
        ok = (near and dl <= np.radians(g.lambda_max_deg)
              and np.radians(g.gamma_min_deg) <= gam <= np.radians(g.gamma_max_deg))
        relaxed = tm >= g.max_wait_s and gam <= np.radians(g.gamma_max_deg)  # late: any heading, never too flat
        why = self._no_commit(t, persist=False)
        if (ok or relaxed) and why:
            if not self._held:
                self._held = True
                self.watch.react(t, "hold", f"no approach: {why}")
            return
        self._held = False
        if ok or relaxed:
            self.approach = TauGapApproach(p_ld - c, a_td, self.gains.k_rho, self.gains.k_alpha_beta)
            self._a_td = a_td
            why = "conditions met" if ok else "waited max_wait_s"
            self._set_mode(t, "approach", f"{why}: lambda={np.degrees(lam):.0f} deg, gamma={np.degrees(gam):.0f} deg, "
                                          f"T={self.approach.T:.2f}s")
