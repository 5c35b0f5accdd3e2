"""CONDOR navigator (seed 004 ch. 2-4, 6-7): everything the gimbal-camera orbit estimates, from modelled
sensors only.

Two halves, as on the real system:

* the ground station's vision (§2.4, §4): frames from the gimbal camera go to the blob tracker
  (started on the tent by the operator's ``OperatorClick``), the tent pixel through the distortion
  table and rectification (``vision/condor_pipeline.VisionRange``) with the camera AHRS' tilt and
  roll (``AttitudeSample(sensor="camera")``) and the barometric height gives the ground range R and
  the bearing Psi_VB. Each fix (``TargetRangeSample``, stamped with the frame's instant, carrying the
  pan potentiometer reading of that frame) waits in ``uplink``: the simulation sends it through the
  telemetry link (a latency + drop channel) and delivers it back with ``update``;
* on board: the autopilot's state (``navigation/fixedwing.AutopilotNavigator``: AHRS, gyros,
  accelerometers, pitot, baro), the ``RadiusFilter`` of the uplinked radii (alpha-beta, holds across
  dropouts), the GPS (a complementary filter on position, velocity as measured) and the compass.

``estimate(t)`` (``FixedWingEstimate``): attitude / rates / specific force / airspeed / height as the
autopilot measures them; position and the range to the target from the GPS while ``source == "gps"``
(the loiter: range = |GPS position - surveyed tent|, rate from the GPS velocity); after the mission's
``set_source("vision")`` the range and rate from the radius filter, and the position of eq. 3.23-3.24:
tent - R (cos b, sin b) with b = compass heading + pan potentiometer + Psi_VB of the last fix, carried
to ``t`` along the compass heading at the measured airspeed. The tent's position reaches the
navigator as a ``NavInit(source="survey")``.

``health(t)``: the radius filter's innovations go to an ``IntegrityMonitor`` (NIS with the
innovation variance ``sigma_R^2 / (1 - alpha)``, sigma_R = ``radius_sigma_pct`` of R: the steady
alpha-beta filter's innovation variance for white range noise), stale after ``stale_s`` without a fix.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from visnav.estimation.integrity import IntegrityConfig, IntegrityMonitor
from visnav.measurements import (read_only, AttitudeSample, FixedWingEstimate, Frame, GpsSample, HeadingSample,
                                 Health, NavInit, OperatorClick, PanSample, TargetRangeSample)
from visnav.navigation.base import FrozenFrameCheck
from visnav.navigation.fixedwing import AutopilotNavigator
from visnav.vision.blob_tracker import BlobTracker


class RadiusFilter:
    """Alpha-beta filter of the radius messages (value, rate); holds across dropouts."""

    def __init__(self, alpha: float = 0.5, beta: float = 0.1, stale_s: float = 3.0) -> None:
        self.alpha, self.beta, self.stale_s = alpha, beta, stale_s
        self.R: float | None = None
        self.Rdot = 0.0
        self.t = -math.inf
        self.t_last_meas = -math.inf

    def update(self, t_meas: float, R: float) -> float | None:
        """Fuse one radius; returns the innovation (None when not used)."""
        if not math.isfinite(R) or R <= 0:
            return None  # "no estimate" never reaches the controller
        if self.R is None:
            self.R, self.t, self.t_last_meas = R, t_meas, t_meas
            return None
        dt = t_meas - self.t
        if dt <= 0:
            return None
        pred = self.R + self.Rdot * dt
        res = R - pred
        self.R = pred + self.alpha * res
        self.Rdot += self.beta * res / dt
        self.t = self.t_last_meas = t_meas
        return res

    def predict(self, t: float) -> tuple[float, float]:
        if self.R is None:
            return math.nan, 0.0
        return self.R + self.Rdot * min(t - self.t, self.stale_s), self.Rdot

    def stale(self, t: float) -> bool:
        return self.R is None or t - self.t_last_meas > self.stale_s


_NAN3 = np.full(3, np.nan)
_NAN3.setflags(write=False)
_NAN66 = np.full((6, 6), np.nan)
_NAN66.setflags(write=False)
_COV_POS3 = _NAN66.copy()  # the GPS covariance's template: NaN, zeros off the position block's diagonal
_COV_POS3[:3, :3] = 0.0
_COV_POS3.setflags(write=False)
_EYE2 = np.eye(2)
_EYE2.setflags(write=False)


def centred(camera, u: float, v: float) -> tuple[float, float]:
    """Seed 004 image coordinates (X right, Y up) [px] from the image centre of an OpenCV pixel."""
    return u - (camera.width - 1) / 2.0, (camera.height - 1) / 2.0 - v


class CondorNavigator(AutopilotNavigator):
    def __init__(self, vision, camera, altimeter: tuple[float, float, float], tracker: BlobTracker | None = None,
                 radius_filter: RadiusFilter | None = None, gps_gain: float = 0.3, gps_stale_s: float = 1.0,
                 radius_sigma_pct: float = 1.0, heading_sigma_deg: float = 3.0, gps_sigma_m: float = 1.0,
                 integrity: IntegrityConfig | None = None, carry_sigma_mps: float = 5.0,
                 gps_accel_mps2: float = 3.0, reject_repeated_frames: bool = True) -> None:
        """``vision``: a ``VisionRange``; ``camera``: its ``PinholeCamera``; ``altimeter``: (measured outside
        temperature [C], c0, c1) of eq. 2.1; ``gps_gain``: the complementary filter's weight of a GPS fix;
        ``radius_sigma_pct``, ``heading_sigma_deg``, ``gps_sigma_m``: what the navigator assumes of its
        sensors (integrity and the protection level); ``carry_sigma_mps``: 1-sigma per axis of the rate at which the
        vision position carried from its fix along the compass heading at airspeed drifts (the unknown wind,
        the turn); ``gps_accel_mps2``: the acceleration the GPS smoother does not see (it holds the fix's
        velocity: the orbit's centripetal v^2/R, 2.7 m/s^2 on the 120 m loiter at 18 m/s);
        ``reject_repeated_frames``: no fix from a frame bit-identical to the previous one (a frozen link)."""
        super().__init__(altimeter)
        self.vision, self.camera = vision, camera
        self.tracker = tracker or BlobTracker()
        self.radius = radius_filter or RadiusFilter()
        self.gps_gain, self.gps_stale_s = float(gps_gain), float(gps_stale_s)
        self.radius_sigma, self.heading_sigma = radius_sigma_pct / 100.0, math.radians(heading_sigma_deg)
        self.gps_sigma = float(gps_sigma_m)
        self.carry_sigma, self.gps_accel = float(carry_sigma_mps), float(gps_accel_mps2)
        self.integrity = IntegrityMonitor(integrity or IntegrityConfig(window=20, stale_s=self.radius.stale_s))
        self.source = "gps"
        self.target: np.ndarray | None = None
        self.tracker_started = False
        # ground station
        self.cam_att: AttitudeSample | None = None
        self.pan: PanSample | None = None
        self.uplink: list[TargetRangeSample] = []
        self.last_vision: dict | None = None
        self._frozen = FrozenFrameCheck()  # the previous frame's image (the frozen-link check)
        self.reject_repeated_frames = bool(reject_repeated_frames)
        # on board
        self.gps_pos: np.ndarray | None = None
        self.gps_vel = np.zeros(3)
        self.gps_t = -math.inf
        self.headings: deque = deque(maxlen=64)
        self.fix: tuple | None = None  # (t, R, Psi_VB, pan, heading at t)
        self.fixes = self.radius_updates = 0
        self._gps_var = math.nan  # the GPS smoother's variance per axis (white fix noise; sigma^2 at the first fix)
        self._gps_dt = 0.0  # the last interval between fixes
        self.health_period_s = 0.1
        self._assess: dict | None = None
        self._assess_key: tuple | None = None
        self._assess_t = -math.inf
        self._handlers: dict = {}  # message type -> update's handler
        self._version = 0  # counts what can change the estimate (update, initialize, command)
        self._memo: tuple | None = None  # (t, version, estimate) of the last estimate
        self._fix_cov: tuple | None = None  # (fix, sigmas) -> the fix's radial / cross-bearing covariance (2, 2)

    # ------------------------------------------------------------------ measurements
    def update(self, m) -> None:
        self._version += 1
        fn = self._handlers.get(type(m))
        if fn is None:  # (the isinstance chain below, once per message type)
            fn = self._handlers[type(m)] = self._handler(type(m))
        fn(m)

    def _handler(self, kind: type):
        """What ``update`` does with a message of type ``kind``."""
        for base, fn in ((Frame, self._frame), (TargetRangeSample, self._fix), (AttitudeSample, self._attitude),
                         (PanSample, self._pan), (GpsSample, self._gps), (HeadingSample, self._heading),
                         (OperatorClick, self._click)):
            if issubclass(kind, base):
                return fn
        return super().update  # AHRS, IMU, pitot, baro

    def _attitude(self, m: AttitudeSample) -> None:
        if m.sensor == "camera":
            self.cam_att = m
        else:
            super().update(m)

    def _pan(self, m: PanSample) -> None:
        self.pan = m

    def _heading(self, m: HeadingSample) -> None:
        self.headings.append((float(m.t), float(m.heading)))

    def _click(self, m: OperatorClick) -> None:
        self.tracker.start(float(m.pixel[0]), float(m.pixel[1]))
        self.tracker_started = True

    def command(self, request) -> None:
        self._version += 1
        super().command(request)

    def initialize(self, init: NavInit) -> None:
        """``NavInit(source="survey", position=tent NED)``: where the tent is (the loiter's centre)."""
        if init.position is None:
            raise ValueError("CondorNavigator.initialize needs the tent's surveyed position")
        self._version += 1
        self.target = np.asarray(init.position, float)[:3].copy()

    def _cmd_set_source(self, t: float, source: str) -> None:
        if source not in ("gps", "vision"):
            raise ValueError(f"CondorNavigator source must be gps or vision, got {source!r}")
        self.source = source

    def pop_uplink(self) -> list[TargetRangeSample]:
        out, self.uplink = self.uplink, []
        return out

    # ------------------------------------------------------------------ ground station
    def _frame(self, f: Frame) -> None:
        """Track the tent, range it (eq. 3.9-3.24); a valid fix goes to ``uplink``."""
        rec = {"t": f.t, "tracked": False, "valid": False, "radius": math.nan, "bearing": math.nan, "X": math.nan,
               "Y": math.nan, "tilt": math.nan, "roll": math.nan, "pan_pot": math.nan, "reason": "target not tracked"}
        self.last_vision = rec
        if not self.tracker_started:
            rec["reason"] = "tracker not started"
            return
        # a live camera's noise never repeats an image bit for bit: a repeat is a frozen video link (issue #18),
        # no fix is made from it (the radius goes stale -> unusable -> the mission's GPS fallback)
        same = self._frozen.repeated(f.image)
        if same and self.reject_repeated_frames:
            rec["reason"] = "frozen video (the image repeats the previous one)"
            return
        tr = self.tracker.track(f.image)
        if self.cam_att is not None:
            rec["roll"], rec["tilt"] = float(self.cam_att.euler[0]), float(self.cam_att.euler[1])
        if self.pan is not None:
            rec["pan_pot"] = float(self.pan.pan)
        if not tr.ok:
            return
        rec["tracked"] = True
        rec["X"], rec["Y"] = centred(self.camera, float(tr.u), float(tr.v))
        if self.cam_att is None or not math.isfinite(self.baro_raw):
            rec["reason"] = "no camera attitude or height yet"
            return
        a = self.altimeter
        est = self.vision.estimate(rec["X"], rec["Y"], self.baro_raw, rec["tilt"], rec["roll"], a[0], a[1], a[2])
        rec["valid"], rec["reason"] = bool(est.valid), est.reason
        if est.valid:
            rec["radius"], rec["bearing"] = float(est.ground_range), float(est.bearing)
            self.uplink.append(TargetRangeSample(t=f.t, range=rec["radius"], bearing=rec["bearing"],
                                                 pan=rec["pan_pot"]))

    # ------------------------------------------------------------------ on board
    def _heading_at(self, t: float) -> float:
        """Compass heading at ``t``: the last sample at or before it (the oldest one kept otherwise)."""
        best = math.nan
        for tm, h in self.headings:
            if tm <= t + 1e-9 or not math.isfinite(best):
                best = h
            if tm > t + 1e-9:
                break
        return best

    def _fix(self, m: TargetRangeSample) -> None:
        R_pred = self.radius.predict(m.t)[0]
        res = self.radius.update(m.t, float(m.range))
        self.fixes += 1
        if res is not None:
            self.radius_updates += 1
            S = (self.radius_sigma * max(R_pred, 1.0)) ** 2 / (1.0 - self.radius.alpha)
            self.integrity.record(m.t, "radius", res * res / S, 1, True)
        if math.isfinite(m.range) and m.range > 0 and math.isfinite(m.pan):
            self.fix = (float(m.t), float(m.range), float(m.bearing), float(m.pan), self._heading_at(m.t))

    def _gps(self, m: GpsSample) -> None:
        p = np.asarray(m.position, float)
        if self.gps_pos is None:
            self.gps_pos = p.copy()
            self._gps_var = self.gps_sigma ** 2
        else:
            pred = self.gps_pos + self.gps_vel * (m.t - self.gps_t)
            self.gps_pos = pred + self.gps_gain * (p - pred)
            g = self.gps_gain  # -> sigma^2 g / (2 - g), the steady variance
            self._gps_var = (1.0 - g) ** 2 * self._gps_var + g * g * self.gps_sigma ** 2
            self._gps_dt = float(m.t - self.gps_t)
        self.gps_vel = np.asarray(m.velocity, float).copy()
        self.gps_t = float(m.t)

    def _heading_now(self) -> float:
        return self.headings[-1][1] if self.headings else math.nan

    def estimate(self, t: float) -> FixedWingEstimate:
        """The estimate at ``t`` (the same object again for the same ``t`` until the next ``update``,
        ``command`` or ``initialize``: the loop and its logger ask at the same step)."""
        m = self._memo
        if m is not None and m[0] == t and m[1] == self._version:
            return m[2]
        e = read_only(self._estimate(t))  # handed out again at the same step: nobody may write into it
        self._memo = (t, self._version, e)
        return e

    def _estimate(self, t: float) -> FixedWingEstimate:
        base = self._base(t)
        pos, vel, R, Rdot, valid, gs = _NAN3, _NAN3, math.nan, 0.0, False, math.nan
        cov = _NAN66
        if self.source == "gps":
            if self.gps_pos is not None:
                pos = self.gps_pos + self.gps_vel * (t - self.gps_t)  # the last fix carried at its velocity
                vel = self.gps_vel
                gs = math.hypot(vel[0], vel[1])
                cov = self._position_cov(t)
                if self.target is not None:
                    r = (pos - self.target)[:2]  # horizontal, from the tent
                    R = math.hypot(r[0], r[1])
                    Rdot = float(r @ vel[:2]) / max(R, 1.0)
                    valid = t - self.gps_t <= self.gps_stale_s
        else:
            R, Rdot = self.radius.predict(t)
            valid = not self.radius.stale(t)
            if self.fix is not None and self.target is not None and math.isfinite(self.fix[4]):
                tf, Rf, psi_vb, pan, head = self.fix
                b = head + pan + psi_vb  # eq. 3.24: bearing of the tent from the aircraft
                pos = self.target - Rf * np.array([math.cos(b), math.sin(b), 0.0])  # eq. 3.23-3.24
                h_now = self._heading_now()
                if math.isfinite(self.va) and math.isfinite(h_now):  # carried along the heading at airspeed
                    pos = pos + self.va * (t - tf) * np.array([math.cos(h_now), math.sin(h_now), 0.0])
                pos[2] = -base["height"]
                cov = self._position_cov(t)
        return FixedWingEstimate(t=t, position=pos, velocity=vel, covariance=cov,
                                 valid=math.isfinite(pos[0]) and math.isfinite(pos[1]), source=self.source, ground_speed=gs,
                                 radius=R, radius_rate=Rdot, radius_valid=bool(valid), **base)

    def _position_cov(self, t: float) -> np.ndarray:
        """Covariance (6, 6) of ``estimate(t)``'s position (NaN where unknown).

        GPS (the loiter): the smoother's variance per axis (``_gps_var``) plus, as a bias, what holding the
        fix's velocity misses in a turn: ``gps_accel`` (T^2 / (2 g) + tau^2 / 2) (T: the interval between
        fixes, the smoother's lag; tau: the time carried since the fix). Vision (eq. 3.23-3.24): sigma_R
        along the bearing, R sigma_heading across it, plus ``(carry_sigma (t - t_fix))^2`` per axis for the
        carry along the compass heading at airspeed since the fix (the wind and the turn it does not know)."""
        if self.source == "gps":
            if self.gps_pos is None:
                return _NAN66
            tau = max(t - self.gps_t, 0.0)
            b = self.gps_accel * (self._gps_dt ** 2 / (2.0 * self.gps_gain) + 0.5 * tau * tau)
            var = self._gps_var + b * b
            cov = _COV_POS3.copy()  # (np.full NaN with np.diag([var] * 3) in the position block)
            cov[0, 0] = cov[1, 1] = cov[2, 2] = var
            return cov
        if self.fix is not None and self.target is not None and math.isfinite(self.fix[4]):
            tf, Rf, psi_vb, pan, head = self.fix
            b = head + pan + psi_vb  # eq. 3.24: bearing of the tent from the aircraft
            # radial: sigma_R; across: R sigma_heading; rotate to NED
            key = (self.fix, self.radius_sigma, self.heading_sigma)
            if self._fix_cov is None or self._fix_cov[0] != key:  # once per fix (read-only, shared)
                c, s = math.cos(b), math.sin(b)
                Rot = np.array([[c, -s], [s, c]])
                P0 = Rot @ np.diag([(self.radius_sigma * Rf) ** 2, (Rf * self.heading_sigma) ** 2]) @ Rot.T
                P0.setflags(write=False)
                self._fix_cov = (key, P0)
            P = self._fix_cov[1] + (self.carry_sigma * max(t - tf, 0.0)) ** 2 * _EYE2
            cov = _NAN66.copy()
            cov[:2, :2] = P
            return cov
        return _NAN66

    def health(self, t: float) -> Health:
        """``tracking``: the vision radius is coming in (not stale); integrity of the radius filter and the
        protection level of the position (re-assessed at most every ``health_period_s`` or on a new fix)."""
        h = Health(source=self.source, tracking=not self.radius.stale(t))
        key = (self.radius_updates, self.source)
        if self._assess is None or key != self._assess_key or t - self._assess_t >= self.health_period_s:
            m = self._memo  # what estimate(t).covariance holds: the estimate's when it is this one's
            P_h = (m[2].covariance if m is not None and m[0] == t and m[1] == self._version
                   else self._position_cov(t))[:2, :2]
            ok = math.isfinite(P_h[0, 0]) and math.isfinite(P_h[1, 1])
            self._assess = self.integrity.assess(t, P_h if ok else None)
            self._assess_key, self._assess_t = key, t
        h.set_integrity(self._assess)  # (copies each value into h)
        if self.source == "vision" and self.radius.stale(t):
            h.notes.append("vision radius stale")
        return h
