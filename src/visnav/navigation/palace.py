"""The PALACE navigator: GPS or monocular position estimation (MPE) or inertial, behind one interface.

It wires the JPL tracking algorithms (Förstner + pseudo-normalized correlation) and MPE
(seed 000 §2.2) to an IMU-driven position filter, and answers the flight controller as a GPS
receiver would. The mission manager decides *when* to track, switch and re-initialise; this
class decides *how*. It never sees truth.

Time alignment (DESIGN §3, seed 000 ch. 5): a frame is processed only when the attitude and the
laser samples that describe the frame's instant (its stamp plus the configured compensation
``navigation.mpe.attitude_delay_s`` / ``laser_delay_s``) have arrived.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace
from typing import Callable

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.estimation.history import History
from visnav.estimation.mpe import MonocularPositionEstimator
from visnav.estimation.position_filter import PositionFilter, accel_ned
from visnav.measurements import (
    AttitudeSample,
    Frame,
    GpsSample,
    Health,
    ImuSample,
    NavEstimate,
    NavInit,
    RangeSample,
)
from visnav.navigation.base import CommandDispatch, propagate
from visnav.navigation.integrity import NavIntegrity, StuckRangeCheck, gps_check_from, watch_gps
from visnav.vision.correlation import PnccTracker, distinct_points
from visnav.vision.interest import forstner, forstner_top_k
from visnav.log_schema import register_stream

_NED = "NED world (origin at the scenario's home)"
register_stream("attitude_samples", euler=("rad", "3-2-1 Euler angles (roll, pitch, yaw) of body FRD relative to NED",
                                           "IMU attitude solution as stamped (delay identification)"))
register_stream("laser", range=("m", "along the beam", "laser range (NaN: no return)"),
                beam_offset=("rad", "from the camera axis, towards image-down", "angle of the beam that returned"))
register_stream("tracker", x=("px", "image, OpenCV (x right)", "tracked point"),
                y=("px", "image, OpenCV (y down)", "tracked point"),
                coherence=("1", "", "coherence of the match, eq. 2.3 of seed 000 (0..1)"),
                ok=("bool", "", "the match was accepted"))
register_stream("track_init", x=("px", "image, OpenCV (x right)", "point the track started on"),
                y=("px", "image, OpenCV (y down)", "point the track started on"),
                init_position=("m", _NED, "vehicle position the ground reference was initialised with"),
                kind=("1", "", "0: from GPS at the start of tracking, 1: re-based on MPE's own estimate"))
register_stream("mpe", position=("m", _NED, "MPE position fix of the vehicle (Alg. 3/4, eq. 2.5)"),
                camera_position=("m", _NED, "camera position of the fix"),
                range=("m", "along the beam", "laser range used"),
                sigma=("m", "horizontal", "pixel-quantisation noise of the fix, R/(f sqrt 12) (eq. 3.3)"),
                jump=("bool", "", "the fix jumped (not fed to the filter)"))

Recorder = Callable[..., None]


class PalaceNavigator(CommandDispatch):
    """The ``navigation/base.Navigator`` of seed 000. Commands (``command(NavCommand(t, name, args))``):
    ``request-tracking`` (``target_ned``, ``init_from``), ``request-tracking-rebase`` (``init_from``),
    ``stop-tracking``, ``set-source`` (``source``: gps | mpe | inertial)."""

    def __init__(self, cfg, camera: PinholeCamera, mount: FixedMount, recorder: Recorder | None = None):
        self.cfg = cfg
        self.camera = camera
        self.mount = mount
        self.mpe = MonocularPositionEstimator(camera, mount, model=cfg.mpe.model)
        tc = cfg.tracker
        # "anchored-subpixel" (issue #3): re-correlate against the track's first template and
        # refine the peak below a pixel: the two remedies for the drift the thesis names (§2.2.2, ch. 6)
        anchored_sub = tc.mode == "anchored-subpixel"
        self.tracker_kwargs = dict(
            template_size=tc.template_px, search_radius=tc.search_radius_px, subpixel=tc.subpixel or anchored_sub,
            min_coherence=tc.min_coherence, mode="anchored" if anchored_sub else tc.mode,
        )
        self.tracker: PnccTracker | None = None
        # with an accelerometer-bias state per axis (issue #30; navigation.accel_bias_noise = 0: without)
        self.filter = PositionFilter(accel_noise=cfg.accel_noise, accel_bias_noise=getattr(cfg, "accel_bias_noise", 0.0),
                                     sigma_b=getattr(cfg, "accel_bias_sigma", 0.0))
        # stuck laser / sonar (issue #30): identical ranges while the height changes
        n, dz = getattr(cfg, "range_stuck_samples", 3), getattr(cfg, "range_stuck_min_change_m", 0.05)
        self.stuck = {"laser": StuckRangeCheck(n, dz), "sonar": StuckRangeCheck(n, dz)}
        self.att = History(3, 256, angles=(2,), tolerance=0.02)  # attitude samples (roll, pitch, yaw)
        self.lasers: deque[RangeSample] = deque(maxlen=64)
        self.frames: deque[Frame] = deque(maxlen=8)
        self.last_gps: GpsSample | None = None
        self.source = "gps"
        self.recorder = recorder or (lambda *a, **k: None)
        self._request: dict | None = None
        self._rebase: str | None = None
        self._mpe_times: deque[float] = deque(maxlen=64)
        self.last_fix = None
        self.last_fix_time = -np.inf
        self.last_sonar: RangeSample | None = None
        self._last_imu_t = -np.inf
        self.h = Health()
        # integrity (issue #18): NIS of every GPS / MPE position update (horizontal, 2 dof) and sonar height
        self.integrity = NavIntegrity(getattr(cfg, "integrity", None), self.recorder, inflation_streams=("gps", "mpe"))
        self.gps_check = gps_check_from(getattr(cfg, "integrity", None))  # GPS walk-off onset
        self._reference_t: float | None = None  # when MPE's ground reference was last set (HPL drift budget)
        self._reference_var = 0.0  # its error variance then (a re-init from the estimate carries the drift)

    # ---------------------------------------------------------------- commands (mission manager)
    def request_tracking(self, target_ned=None, init_from: str = "gps") -> None:
        """Start (or restart) tracking on the next frame: Förstner near ``target_ned`` projected into
        the image, or near the image centre when None; initialise the ground reference from the GPS
        fix or from the current estimate (``init_from`` = "gps" | "estimate")."""
        self._request = {"target": None if target_ned is None else np.asarray(target_ned, float), "init": init_from}
        self.h.tracking_pending = True

    def request_tracking_rebase(self, init_from: str = "gps") -> None:
        """Keep the tracked point but re-base its ground reference (Algorithm 3) on the next frame
        from the GPS fix or the current estimate, as the mission manager does at the MPE switch."""
        self._rebase = init_from
        self.h.tracking_pending = True

    def stop_tracking(self) -> None:
        self.tracker = None
        self.h.tracking = False

    @property
    def tracking_pending(self) -> bool:
        return self._request is not None or self._rebase is not None

    def set_source(self, source: str) -> None:
        if source not in ("gps", "mpe", "inertial"):
            raise ValueError(f"unknown navigation source {source!r}")
        self.source = source
        self.h.source = source

    def _cmd_request_tracking(self, t: float, target_ned=None, init_from: str = "gps") -> None:
        self.request_tracking(target_ned, init_from)

    def _cmd_request_tracking_rebase(self, t: float, init_from: str = "gps") -> None:
        self.request_tracking_rebase(init_from)

    def _cmd_stop_tracking(self, t: float) -> None:
        self.stop_tracking()

    def _cmd_set_source(self, t: float, source: str) -> None:
        self.set_source(source)

    def initialize(self, init: NavInit) -> None:
        """Start the position filter at an explicit pose (otherwise it starts at the first GPS fix); an
        attitude, when given, stands as the attitude solution until the IMU's arrives."""
        if init.position is None:
            raise ValueError("PALACE needs a position to start from (NavInit.position)")
        v = np.zeros(3) if init.velocity is None else np.asarray(init.velocity, float)
        self.filter.reset(init.t, np.asarray(init.position, float), v)
        if init.attitude is not None:
            self.att.push(init.t, np.asarray(init.attitude, float))

    # ---------------------------------------------------------------- measurements
    def update(self, m) -> None:
        if isinstance(m, ImuSample):
            self._on_imu(m)
        elif isinstance(m, AttitudeSample):
            e = m.euler
            if math.isfinite(e[0] + e[1] + e[2]):
                self.att.push(m.t, e)
                self.recorder("attitude_samples", m.t, euler=e)
            else:
                self.h.rejected_samples += 1
        elif isinstance(m, RangeSample):
            self._on_range(m)
        elif isinstance(m, GpsSample):
            self._on_gps(m)
        elif isinstance(m, Frame):
            self.frames.append(m)
        self._process_frames()

    def _on_imu(self, m: ImuSample) -> None:
        a, g = m.accel, m.gyro
        if not math.isfinite(a[0] + a[1] + a[2] + g[0] + g[1] + g[2]) or m.t <= self._last_imu_t:
            self.h.rejected_samples += 1
            return
        self._last_imu_t = m.t
        if not self.filter.initialized or self.att.k == 0:
            return
        e = self.att.newest()
        self.filter.predict(m.t, a_ned := accel_ned(euler_to_dcm(e), m.accel))
        self.gps_check.imu(m.t, a_ned)

    def _on_range(self, m: RangeSample) -> None:
        r = m.range
        if np.isfinite(r) and r < 0:
            self.h.rejected_ranges += 1
            return
        stuck = self._stuck(m) if m.sensor in self.stuck else False
        if m.sensor == "laser":
            self.recorder("laser", m.t, range=r, beam_offset=m.beam_offset)  # laser delay identification
            self.lasers.append(replace(m, range=math.nan) if stuck else m)  # a stuck laser gives no MPE fix
            self.h.laser_ok = bool(np.isfinite(r)) and not stuck
            return
        if not np.isfinite(r) or stuck:
            return
        self.last_sonar = m
        if self.source == "inertial" and self.att.k:
            e = self.att.at(m.t)
            if e is None:
                return
            C = euler_to_dcm(e)
            z = -r * C[2, 2]
            self.filter.update_position(np.array([0.0, 0.0, z]), 0.03, axes=(2,))
            self.integrity.record(m.t, "sonar", float(self.filter.last_nis[0]), 1, True)

    def _stuck(self, m: RangeSample) -> bool:
        """The stuck-range test of the sensor (``navigation/integrity.StuckRangeCheck``); its detection latches a
        suspicion: the MPE fixes (laser) or heights (sonar) used since the onset carry the range error it
        bounds, the HPL grows by it."""
        c = self.stuck[m.sensor]
        was = c.stuck
        now = c.add(m.t, m.range, float(self.filter.v[2]) if self.filter.initialized else 0.0)
        if now and not was:
            why = f"{m.sensor} range stuck at {c.value:.2f} m since {c.onset:.1f} s while the height changes"
            self._note(f"{m.t:.1f}s {why}")
            self.integrity.suspect(f"{m.sensor}_stuck", why, c.error_bound)
        return now

    def _on_gps(self, m: GpsSample) -> None:
        if not (np.all(np.isfinite(m.position)) and np.all(np.isfinite(m.velocity))):
            self.h.rejected_samples += 1
            return
        self.last_gps = m
        if not self.filter.initialized:
            self.filter.reset(m.t, m.position, m.velocity)
            self.integrity.start(m.t)
            return
        if self.source == "gps":
            # the fix describes m.t, the filter is at its last IMU time: carry the fix forward over the
            # lag with the velocity (position) and the acceleration the filter integrated (velocity)
            lag = (self.filter.t or m.t) - m.t
            self.filter.update_position(m.position + m.velocity * lag, max(m.sigma, 0.01))
            self.integrity.record(m.t, "gps", float(np.sum(self.filter.last_nis[:2])), 2, True)
            zv = m.velocity + self.filter.accel * lag
            watch_gps(self.gps_check, self.integrity, m.t, zv)
            self.filter.update_velocity(zv, 0.05)

    # ---------------------------------------------------------------- vision
    def _laser_at(self, t: float) -> RangeSample | None:
        best, dbest = None, 0.051
        for s in self.lasers:
            d = abs(s.t - t)
            if d < dbest:
                best, dbest = s, d
        return best

    def _position_at(self, t: float, init: str) -> np.ndarray | None:
        if init == "gps":
            g = self.last_gps
            if g is None:
                return None
            return g.position + g.velocity * (t - g.t)
        if self.filter.t is None:
            return None
        return self.filter.p - self.filter.v * (self.filter.t - t)

    def _process_frames(self) -> None:
        cfg = self.cfg.mpe
        while self.frames:
            f = self.frames[0]
            ta, tl = f.t + cfg.attitude_delay_s, f.t + cfg.laser_delay_s
            if self.att.newest_t < ta or not self.lasers or self.lasers[-1].t < tl - 1e-9:
                return  # the samples that describe this frame have not arrived yet
            self.frames.popleft()
            euler = self.att.at(ta)
            laser = self._laser_at(tl)
            if euler is None:
                continue
            self._vision(f, euler, laser)

    def _vision(self, f: Frame, euler: np.ndarray, laser: RangeSample | None) -> None:
        C_bn = euler_to_dcm(euler)
        rng_ok = laser is not None and np.isfinite(laser.range) and laser.range > 0
        if self._request is not None:
            self._start_track(f, C_bn, laser if rng_ok else None)
            return
        if self.tracker is None:
            return
        res = self.tracker.track(f.image)
        self.h.coherence = float(res.coherence)
        self.h.tracked_px = (float(res.x), float(res.y))
        self.recorder("tracker", f.t, x=res.x, y=res.y, coherence=res.coherence, ok=res.ok)
        if not res.ok:  # track lost: the mission manager decides how to re-acquire
            self._note(f"{f.t:.1f}s tracker: {res.reason}")
            self.stop_tracking()
            return
        if not rng_ok:
            return
        if self._rebase is not None:
            pos = self._position_at(f.t, self._rebase)
            if pos is not None:
                self.recorder("track_init", f.t, x=res.x, y=res.y, init_position=pos, kind=1)
                self.mpe.initialize((res.x, res.y), laser.range, C_bn, pos, laser.beam_offset)
                self._set_reference(f.t, self._rebase)
                self._rebase = None
                self.h.tracking_pending = self.tracking_pending
        fix = self.mpe.estimate(f.t, (res.x, res.y), laser.range, C_bn, laser.beam_offset)
        self._mpe_times.append(f.t)
        pred = self._position_at(f.t, "estimate")
        jump = pred is not None and np.linalg.norm(fix.position - pred) > self.cfg.mpe.jump_limit_m
        self.h.mpe_jump = bool(jump)
        self.last_fix, self.last_fix_time = fix, f.t
        self.recorder("mpe", f.t, position=fix.position, camera_position=fix.camera_position,
                      range=laser.range, sigma=fix.sigma_px_m, jump=jump)
        if self.source == "mpe":
            lag = (self.filter.t or f.t) - f.t
            sigma = self._fix_sigma(fix, laser.range)
            z = fix.position + self.filter.v * lag
            if not jump:
                self.filter.update_position(z, sigma)
                nis = float(np.sum(self.filter.last_nis[:2]))
            else:  # the jump check is this navigator's gate: the fix is counted as rejected
                sig2 = np.broadcast_to(np.asarray(sigma, float) ** 2, (3,))[:2]
                nis = float(np.sum((z[:2] - self.filter.p[:2]) ** 2 / (np.diag(self.filter.P)[:2] + sig2)))
            self.integrity.record(f.t, "mpe", nis, 2, not jump)

    def _fix_sigma(self, fix, range_m: float):
        """σ of the fix per axis for the filter: eq. 3.3's pixel share (``sigma_px_m``, floored at
        2 cm) plus, when configured, the laser's σ_L = σ0 + k·R carried along the offset (the offset
        is linear in R) and the attitude noise times the offset's length (seed 000 Figs. 3.4, 4.5-4.7)."""
        c = self.cfg.mpe
        q = max(fix.sigma_px_m, 0.02)
        if c.range_sigma0_m == 0 and c.range_sigma_per_m == 0 and c.attitude_sigma_deg == 0:
            return q
        off = np.abs(np.asarray(fix.ground_offset, float))
        sl = (c.range_sigma0_m + c.range_sigma_per_m * range_m) * off / max(range_m, 1e-6)
        sa = math.radians(c.attitude_sigma_deg) * float(np.linalg.norm(off))
        return np.sqrt(q * q + sl * sl + sa * sa)

    def _start_track(self, f: Frame, C_bn: np.ndarray, laser: RangeSample | None) -> None:
        req = self._request
        pos = self._position_at(f.t, req["init"])
        if laser is None or pos is None:
            return  # try again on the next frame
        W, H = self.camera.width, self.camera.height
        if req["target"] is not None:
            cam_pos, C_cn = self.mount.camera_pose(pos, C_bn)
            uv = self.camera.project((C_cn.T @ (req["target"] - cam_pos)).reshape(1, 3))[0]
            if not np.all(np.isfinite(uv)):
                uv = np.array([self.camera.cx, self.camera.cy])
        else:
            uv = np.array([self.camera.cx, self.camera.cy])
        half = 40
        margin = self.tracker_kwargs["template_size"] // 2 + self.tracker_kwargs["search_radius"] + 2
        x0 = int(np.clip(uv[0] - half, margin, W - margin - 1))
        y0 = int(np.clip(uv[1] - half, margin, H - margin - 1))
        x1 = int(np.clip(uv[0] + half, margin + 1, W - margin))
        y1 = int(np.clip(uv[1] + half, margin + 1, H - margin))
        tc = self.cfg.tracker
        pt = forstner(f.image, feature_size=tc.feature_size, region=(x0, y0, x1, y1), min_isotropy=tc.min_isotropy)
        if pt is not None and tc.max_self_coherence < 1.0:  # distinctness guard: strongest point with no copy near
            cands = forstner_top_k(f.image, 8, feature_size=tc.feature_size, region=(x0, y0, x1, y1),
                                   min_isotropy=tc.min_isotropy, min_distance=5.0)
            ok = distinct_points(f.image, cands, tc.template_px, tc.search_radius_px, tc.max_self_coherence)
            if not ok:
                self._note(f"{f.t:.1f}s no distinct Förstner point near {uv.round(0)} (self-coherence guard)")
            pt = ok[0] if ok else pt
        if pt is None:
            self._note(f"{f.t:.1f}s Förstner found no point near {uv.round(0)}")
            return
        self.tracker = PnccTracker(**self.tracker_kwargs)
        self.tracker.init(f.image, pt.x, pt.y)
        uv0 = (float(self.tracker.x), float(self.tracker.y))
        self.mpe.initialize(uv0, laser.range, C_bn, pos, laser.beam_offset)
        self._set_reference(f.t, req["init"])
        self._request = None
        self.h.tracking_pending = self.tracking_pending
        self.h.tracking = True
        self.h.tracked_px = uv0
        self.h.coherence = 1.0
        self.recorder("track_init", f.t, x=uv0[0], y=uv0[1], init_position=pos, kind=0)

    def _note(self, text: str) -> None:
        if len(self.h.notes) < 200:  # keep the first ones; counters carry the rest
            self.h.notes.append(text)

    # ---------------------------------------------------------------- outputs
    def estimate(self, t: float) -> NavEstimate:
        """The filter's state carried from its last IMU update to ``t`` with that update's acceleration
        (the filter itself is not changed); the latest attitude solution."""
        e = self.att.newest() if self.att.k else np.zeros(3)
        f = self.filter
        p, v = propagate(f.p, f.v, f.accel, t - f.t if f.t is not None else 0.0)
        return NavEstimate(t=t, position=p, velocity=v, attitude=e.copy(),
                           covariance=f.covariance(), valid=f.initialized, source=self.source)

    def mpe_rate(self, t: float, window: float = 1.0) -> float:
        return sum(1 for s in self._mpe_times if t - window < s <= t) / window

    def _mpe_unobserved_var(self, t: float) -> float:
        """Off GPS the position comes from MPE (then inertial from it): its ground reference's error and the
        tracker's drift since it was set are in no covariance; the integrity block's budget for them."""
        ic = getattr(self.cfg, "integrity", None)
        if self.source == "gps" or self._reference_t is None or ic is None:
            return 0.0
        return self._reference_var + (ic.mpe_drift_mps * max(t - self._reference_t, 0.0)) ** 2

    def _set_reference(self, t: float, init: str) -> None:
        ic = getattr(self.cfg, "integrity", None)
        if ic is None:
            return
        carried = self._mpe_unobserved_var(t) if init == "estimate" and self.source != "gps" else 0.0
        self._reference_var = ic.reference_sigma_m**2 + carried
        self._reference_t = t

    def _watch_bias(self) -> None:
        """An estimated horizontal accelerometer bias above ``accel_bias_alarm_mps2`` is reported (integrity
        degraded, no HPL term: the filter compensates it and its covariance holds its uncertainty); below
        half of it the report ends."""
        f, limit = self.filter, getattr(self.cfg, "accel_bias_alarm_mps2", math.inf)
        if not f.has_bias:
            return
        b = float(np.hypot(f.b[0], f.b[1]))
        if b > limit and "accel_bias" not in self.integrity.suspicions:
            self.integrity.suspect("accel_bias", f"accelerometer bias {b:.2f} m/s^2 estimated (compensated)",
                                   lambda t: 0.0)
        elif b < 0.5 * limit:
            self.integrity.clear("accel_bias")

    def health(self, t: float | None = None) -> Health:
        if t is not None:
            self.h.mpe_rate_hz = self.mpe_rate(t)
        self.h.source = self.source
        if t is not None:
            f = self.filter
            self._watch_bias()
            self.integrity.fill(self.h, t, f.covariance()[:2, :2] if f.initialized else None,
                                self._mpe_unobserved_var(t))
        return self.h

