"""The WITAS vision-based navigator (seed 002 Fig. 5.3): INS + Kalman filter, fed by a point-mass filter
that fuses visual odometry (§5.6) and registration to a reference map (§5.7).

Phases. Until GPS is lost the navigator is a GPS-aided position filter (as the R-MAX's own INS/GPS).
When GPS samples stop arriving (``gps_timeout_s``) the vision filter is engaged "with the initial UAV
state taken from the last GPS reading" (§5.9.1): the Kalman filter backend starts from the GPS-era
estimate (plus an optional attitude error, the §5.9.1 experiment), the PMF grid is centred on it, and
from then on:

* every camera frame at ``odometry_hz``: KLT + RANSAC + eq. 5.9 -> displacement u (odometry) with the
  filter's attitude at the frame's instant and its height (barometer-aided) -> PMF time update;
* every ``registration_every``-th frame: NCC registration around the PMF estimate, window from the PMF
  covariance -> likelihood -> PMF measurement update;
* the PMF MV estimate -> Kalman filter horizontal position update (constant 2 m, §5.8.4, or eq. 5.30);
* barometer -> altitude update (4 m, §5.8.4); optional compass -> heading update.

It also keeps, for comparison only, an odometry-only track and an INS-only track (free inertial from
the same initial state). It never sees truth.

Backends: ``eskf`` is the 12-state INS error-state filter of appendix A (``estimation/eskf.py``);
``ahrs`` is the flight computer's position filter on the autopilot's attitude solution (no attitude
estimation: the attitude errors of Fig. 5.19 are the AHRS's).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Callable

import numpy as np

from visnav.estimation.history import History
from visnav.estimation.pmf import PointMassFilter
from visnav.estimation.position_filter import PositionFilter, accel_ned
from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import (AttitudeSample, BaroSample, Frame, GpsSample, HeadingSample, Health, ImuSample,
                                 NavEstimate, NavInit)
from visnav.navigation.base import CommandDispatch, FrozenFrameCheck, propagate
from visnav.navigation.integrity import (HandoverCheck, NavIntegrity, TiltCheck, gps_check_from, gyro_check_from,
                                        watch_gps)
from visnav.vision.odometry import OdometryStep, VisualOdometry
from visnav.vision.registration import MapRegistration
from visnav.log_schema import register_stream
from visnav.scalar import finite
from visnav.estimation.eskf import BA_
from visnav.estimation.eskf import EskfConfig, ErrorStateKF
from visnav.estimation.ins import NavState, StrapdownINS, euler_to_quat

_NED = "NED world (origin at the scenario's home)"
register_stream("vision_engaged", position=("m", _NED, "filter position when GPS was lost"),
                velocity=("m/s", _NED, "filter velocity when GPS was lost"),
                euler=("rad", "3-2-1 Euler angles (roll, pitch, yaw) of body FRD relative to NED",
                       "filter attitude when GPS was lost"))
register_stream("ins_only", position=("m", _NED, "stand-alone INS track (comparison, not used)"))
register_stream("odometry", ok=("bool", "", "the odometry step was used"),
                n_tracked=("1", "", "KLT features tracked"), n_inliers=("1", "", "RANSAC inliers"),
                n_outliers=("1", "", "RANSAC outliers"),
                displacement=("m", "NED north, east", "camera displacement of the step (eq. 5.5-5.10)"),
                position=("m", _NED, "odometry-only track (steps summed from the engagement)"),
                height=("m", "", "height above ground that scaled the step"))
register_stream("handover_check", offset=("m", "NED north, east", "PMF mean minus the odometry track from the "
                                                                 "GPS hand-over"),
                sigma=("m", "", "its expected 1-sigma (hand-over, odometry steps, PMF)"),
                stat=("1", "", "|offset|^2 / sigma^2, against chi-square(2)"),
                latched=("m", "NED north, east", "the latched offset (NaN until latched)"))
register_stream("pmf", position=("m", "NED north, east", "point-mass filter mean (eq. 5.24-5.31)"),
                cov=("m^2", "NED north, east", "point-mass filter covariance"),
                registered=("bool", "", "a map registration was used (eq. 5.14-5.15)"),
                ncc_peak=("1", "", "NCC peak of the registration (NaN: none)"),
                window_m=("m", "", "side of the registration search window (NaN: none)"))

Recorder = Callable[..., None]


class _AhrsBackend:
    """Position/velocity filter driven by the IMU and the AHRS attitude."""

    def __init__(self, t, position, velocity, euler, sigma_p=0.5, sigma_v=0.2):
        self.f = PositionFilter(accel_noise=0.3)
        self.f.reset(t, position, velocity, sigma_p, sigma_v)
        self.euler = np.asarray(euler, float).copy()
        self.offset = np.zeros(3)  # initial attitude error (the §5.9.1 experiment), kept constant
        self.last = (float("nan"), 0, True)  # (NIS, dof, accepted) of the last update (integrity monitor)

    def propagate(self, t, accel, gyro, dt, ahrs_euler) -> None:
        if ahrs_euler is not None:
            self.euler = np.asarray(ahrs_euler, float) + self.offset
        self.f.predict(t, accel_ned(euler_to_dcm(self.euler), accel))

    def update_position(self, ne, cov) -> bool:
        ok = self.f.update_position(np.r_[ne, 0.0], np.sqrt(np.diag(cov)), axes=(0, 1))
        self.last = (float(np.sum(self.f.last_nis)), 2, ok)
        return ok

    def update_baro(self, alt, sigma) -> None:
        self.f.update_position(np.array([0.0, 0.0, -alt]), sigma, axes=(2,))
        self.last = (float(self.f.last_nis[0]), 1, True)

    def update_heading(self, yaw, sigma) -> None:
        """No-op by design: this backend takes its heading from the AHRS attitude solution; only the
        ESKF backend fuses compass samples (seed 002 §5.8.3)."""
        self.last = (float("nan"), 0, True)
        return None

    def state(self):
        return self.f.t, self.f.p.copy(), self.f.v.copy(), self.euler.copy(), self.f.covariance()

    def covariance(self) -> np.ndarray:
        """``state()[4]`` alone."""
        return self.f.covariance()


class _EskfBackend:
    """The 12-state error-state KF of appendix A (estimation/eskf.py)."""

    def __init__(self, t, position, velocity, euler, sigma_p=0.5, sigma_v=0.2, sigma_att_deg=1.0,
                 gate_probability=1.0):
        s = NavState(t=float(t), position=np.asarray(position, float).copy(),
                     velocity=np.asarray(velocity, float).copy(), quat=euler_to_quat(euler))
        sa = math.radians(sigma_att_deg)
        P0 = np.r_[np.broadcast_to(sigma_p, 3), [sigma_v] * 3, [sa, sa, 3 * sa], [0.02] * 3]
        cfg = EskfConfig(accel_noise=0.05, gyro_noise=2e-3, accel_bias_noise=1e-3, gravity_mps2=9.81,
                         earth_rotation=False, gate_probability=gate_probability)
        self.kf = ErrorStateKF(s, P0, cfg)
        self.last = (float("nan"), 0, True)  # (NIS, dof, accepted) of the last update (integrity monitor)

    def _keep(self, res):
        self.last = (float(res.nis), int(np.size(res.innovation)), bool(res.accepted))
        return res.accepted

    def propagate(self, t, accel, gyro, dt, ahrs_euler) -> None:
        self.kf.propagate(accel, gyro, dt)

    def update_position(self, ne, cov) -> bool:
        return self._keep(self.kf.update_position(ne, cov))

    def update_baro(self, alt, sigma) -> None:
        self._keep(self.kf.update_baro(alt, sigma))

    def update_heading(self, yaw, sigma) -> None:
        self._keep(self.kf.update_heading(yaw, sigma))

    def open_accel_bias(self, sigma: float, noise: float) -> None:
        """An accelerometer fault flagged (issue #30): the bias states are opened by ``sigma`` [m/s^2] and follow
        a random walk of ``noise`` from now on (they learn the faulty bias, and its end)."""

        self.kf.P[BA_, BA_] += np.eye(3) * sigma * sigma
        self.kf.retune(accel_bias_noise=max(self.kf.cfg.accel_bias_noise, noise))

    def aid_attitude(self, euler, sigma) -> None:
        """The autopilot's attitude fused (``sigma``: [rad] per NED axis), not gated and not in the integrity
        windows (an aid of the filter's attitude, not of its position)."""
        self.kf.update_attitude(euler, sigma, gate=False)

    def state(self):
        x = self.kf.x
        return x.t, x.position.copy(), x.velocity.copy(), x.euler.copy(), self.kf.P[:6, :6].copy()

    def covariance(self) -> np.ndarray:
        """``state()[4]`` alone (without the attitude's Euler angles)."""
        return self.kf.P[:6, :6].copy()


class WitasNavigator(CommandDispatch):
    """The ``navigation/base.Navigator`` of seed 002 ch. 5. It takes no commands: the vision filter engages
    by itself when GPS samples stop (``gps_timeout_s``)."""

    def __init__(self, cfg, K: np.ndarray, mount, reference, recorder: Recorder | None = None,
                 rng: np.random.Generator | None = None, gps_timeout_s: float = 0.5):
        """``cfg``: a ``WitasFilterConfig``; ``K``, ``mount``: the camera; ``reference``: the
        navigator's reference map (a north-up GeoImage-like raster)."""
        self.cfg = cfg
        self.K = np.asarray(K, float)
        self.mount = mount
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.recorder = recorder or (lambda *a, **k: None)
        self.gps_timeout = gps_timeout_s
        self.vo = VisualOdometry(self.K, max_features=cfg.max_features, sigma_px=cfg.sigma_px,
                                 min_inliers=cfg.min_inliers, use_ransac=cfg.ransac, rng=self.rng)
        self.reg = MapRegistration(reference, self.K, mount, min_template_std=cfg.min_template_std)
        self.gps_filter = PositionFilter(accel_noise=0.3)
        self.att = History(3, 256, angles=(2,), tolerance=0.02)  # AHRS attitude samples
        self.hist = History(6, 128, angles=(5,), tolerance=0.05)  # filter (position, euler) for the frame instants
        self.backend = None
        self.pmf: PointMassFilter | None = None
        self.ins_only = None
        self.odo_track: np.ndarray | None = None
        self.last_gps: GpsSample | None = None
        self.baro: BaroSample | None = None
        self.frames: deque[tuple[Frame, str]] = deque(maxlen=8)  # (frame, why it is a camera gap; "": live)
        self.n_frames = 0
        self.t_vision: float | None = None
        self.h = Health(source="gps")
        self._last_imu: ImuSample | None = None
        self.skipped_odometry = 0
        self.registrations = 0
        self._last_u = np.zeros(2)
        self._acc: list = [np.zeros(3), np.zeros(3), 0, 0.0]
        self._ins_log_t = -np.inf
        # integrity (issue #18): NIS of the GPS-phase position updates, of the PMF -> KF position updates
        # ("vision", horizontal, 2 dof), of the baro and compass updates
        self.integrity = NavIntegrity(getattr(cfg, "integrity", None), self.recorder,
                                      inflation_streams=("gps", "vision"))
        ic = getattr(cfg, "integrity", None)
        self.gps_check = gps_check_from(ic)  # GPS walk-off onset
        self.handover = (HandoverCheck(ic.handover_alpha, ic.handover_updates)
                         if ic is not None and getattr(ic, "handover_check", False) else None)
        self._odo_var = 0.0  # variance [m^2] per axis of the odometry track from the hand-over
        self._frozen = FrozenFrameCheck()  # frames repeating the previous one (a frozen link): dropped
        # the ESKF's gyros against the autopilot's attitude solution (a gyro bias step): None when off
        self.gyro_check = gyro_check_from(ic)
        self._gyro_steps = 0
        # the ESKF's tilt against the autopilot's (an accelerometer bias taken for a tilt, issue #30): None when off;
        # after a flag the autopilot's attitude is fused at 10 Hz (ahrs_aid)
        self.tilt_check = (TiltCheck(ic.tilt_check_deg, ic.tilt_check_persist_s)
                           if ic is not None and getattr(ic, "tilt_check", False) else None)
        self.ahrs_aid = False
        self._tilt_t = -math.inf

    def initialize(self, init: NavInit) -> None:
        """Start the GPS-phase filter at an explicit pose (otherwise it starts at the first GPS fix)."""
        if init.position is None:
            raise ValueError("WITAS needs a position to start from (NavInit.position)")
        v = np.zeros(3) if init.velocity is None else np.asarray(init.velocity, float)
        self.gps_filter.reset(init.t, np.asarray(init.position, float), v)
        if init.attitude is not None:
            self.att.push(init.t, np.asarray(init.attitude, float))

    # ------------------------------------------------------------------ measurements
    def update(self, m) -> None:
        if isinstance(m, ImuSample):
            self._on_imu(m)
        elif isinstance(m, AttitudeSample):
            if finite(np.asarray(m.euler, float)):
                self.att.push(m.t, m.euler)
            else:
                self.h.rejected_samples += 1
        elif isinstance(m, GpsSample):
            self._on_gps(m)
        elif isinstance(m, BaroSample):
            if not math.isfinite(m.altitude):
                self.h.rejected_samples += 1
                return
            self.baro = m
            if self.backend is not None:  # (in the GPS phase the GPS gives the height)
                self.backend.update_baro(m.altitude, self.cfg.baro_sigma_m)
                self.integrity.record(m.t, "baro", *self.backend.last)
        elif isinstance(m, HeadingSample):
            if self.backend is not None and math.isfinite(m.heading):
                self.backend.update_heading(m.heading, math.radians(self.cfg.compass_sigma_deg))
                self.integrity.record(m.t, "heading", *self.backend.last)
        elif isinstance(m, Frame):
            # a frame bit-identical to the previous one is a frozen video link (issue #18): not a view of
            # no motion. It is a camera gap (no odometry, no registration, the filter runs on INS + baro and
            # its HPL grows) and the state is degraded until a live frame comes
            frozen = self._frozen.repeated(m.image)
            if frozen:
                self.integrity.suspect("frozen", f"frozen camera ({self._frozen.count} frames repeated the "
                                       "previous one: not fused)", lambda _t: 0.0)
            else:
                self.integrity.clear("frozen")
            # a frame stamped ahead of the IMU clock (a camera clock jump, issue #30): its stamp cannot be the
            # instant it shows (it came before its own time), so the filter state it is matched with would be
            # the wrong one: a camera gap too, degraded while it lasts
            ahead = m.t - self._last_imu.t if self._last_imu is not None else 0.0
            lim = getattr(getattr(self.cfg, "integrity", None), "frame_ahead_s", math.inf)
            if ahead > lim:
                self.integrity.suspect("clock", f"frame stamped {ahead:.2f} s ahead of the IMU clock (a camera clock "
                                       "jump?): not fused", lambda _t: 0.0)
            else:
                self.integrity.clear("clock")
            if self.backend is not None:
                gap = "frozen camera (frame repeated)" if frozen else (
                    f"frame stamped {ahead:.2f} s ahead of the IMU clock" if ahead > lim else "")
                self.frames.append((m, gap))
                self._process_frames()

    def frame_prework(self):
        """The KLT tracking of the next frame, run where the frame is rendered as soon as it is (``app/loop.py``;
        ``vision/klt.KltTracker.prework``): its result is used when the frame reaches the odometry with the
        tracker as it was when the frame was taken, as it is unless a camera gap restarted it; the same
        numbers either way. None before the vision phase (no frame is used)."""
        return None if self.backend is None else self.vo.klt.prework()

    def _ahrs(self):
        return self.att.newest()

    def _on_imu(self, m: ImuSample) -> None:
        if not finite(np.asarray(m.accel, float), np.asarray(m.gyro, float)) or (
                self._last_imu is not None and m.t <= self._last_imu.t):
            self.h.rejected_samples += 1
            return
        e = self._ahrs()
        if self.backend is None and self.last_gps is not None and m.t - self.last_gps.t > self.gps_timeout:
            self._engage_vision(self._last_imu.t if self._last_imu is not None else m.t)
        self._last_imu = m
        if self.backend is not None:
            # the INS is integrated at ins_rate_hz (50 Hz in §5.9.1) on the mean of the samples in between
            a = self._acc
            a[0] += m.accel
            a[1] += m.gyro
            a[2] += 1
            dt = m.t - a[3]
            if dt < 1.0 / self.cfg.ins_rate_hz - 1e-6:
                return
            acc, gyr = a[0] / a[2], a[1] / a[2]
            self._acc = [np.zeros(3), np.zeros(3), 0, m.t]
            self.backend.propagate(m.t, acc, gyr, dt, e)
            t, p, v, eul, _ = self.backend.state()
            self.hist.push(t, np.concatenate((p, eul)))
            if self.gyro_check is not None and isinstance(self.backend, _EskfBackend):
                self._check_gyro(m.t, gyr, dt)
            if isinstance(self.backend, _EskfBackend) and (self.tilt_check is not None or self.ahrs_aid) \
                    and m.t - self._tilt_t >= 0.1 - 1e-6:
                self._tilt_t = m.t
                self._check_tilt(m.t)
            self._ins_only_step(m.t, acc, gyr, dt, e)
        elif self.gps_filter.initialized and e is not None:
            self.gps_filter.predict(m.t, a_ned := accel_ned(euler_to_dcm(e), m.accel))
            self.gps_check.imu(m.t, a_ned)

    def _on_gps(self, m: GpsSample) -> None:
        if not (np.all(np.isfinite(m.position)) and np.all(np.isfinite(m.velocity))):
            self.h.rejected_samples += 1
            return
        if self.backend is not None:
            return  # the vision filter is engaged: GPS is not used again
        self.last_gps = m
        f = self.gps_filter
        if not f.initialized:
            f.reset(m.t, m.position, m.velocity)
            self.integrity.start(m.t)
            return
        lag = (f.t or m.t) - m.t
        f.update_position(m.position + m.velocity * lag, max(m.sigma, 0.05))
        self.integrity.record(m.t, "gps", float(np.sum(f.last_nis[:2])), 2, f.last_accepted)
        watch_gps(self.gps_check, self.integrity, m.t, m.velocity)
        f.update_velocity(m.velocity, 0.05)

    def _engage_vision(self, t: float) -> None:
        c = self.cfg
        f = self.gps_filter
        e = self._ahrs()
        e = np.zeros(3) if e is None else e.copy()
        err = np.radians(np.asarray(c.init_attitude_error_deg, float))
        # a GPS walk-off flagged before the loss: the hand-over position may be off by what it can have
        # built (GpsInertialCheck.extra_hpl); the filter and the PMF start that uncertain, so that the
        # registration moves the position (not the attitude) back
        walk = self.gps_check.extra_hpl(t)
        sp = math.hypot(0.5, walk)
        if c.backend == "eskf":
            self.backend = _EskfBackend(f.t, f.p, f.v, e + err, sigma_p=[sp, sp, 0.5],
                                        gate_probability=c.kf_gate_probability)
        else:
            self.backend = _AhrsBackend(f.t, f.p, f.v, e + err, sigma_p=sp)
            self.backend.offset = err
        self.t_vision = t
        self._acc = [np.zeros(3), np.zeros(3), 0, f.t]
        self.pmf = PointMassFilter(f.p[:2], c.pmf_size_m, c.pmf_resolution_m, math.hypot(c.pmf_sigma0_m, walk))
        self.odo_track = f.p.copy()
        self._odo_var = float(np.linalg.eigvalsh(f.covariance()[:2, :2]).max()) + walk * walk
        self._init_ins_only(f.t, f.p, f.v, e + err)
        self.h.source = "vision"
        self.integrity.start(t)
        self.recorder("vision_engaged", t, position=f.p.copy(), velocity=f.v.copy(), euler=e + err)

    def _check_gyro(self, t: float, gyr, dt: float) -> None:
        """The gyro / autopilot-attitude test (10 Hz); on a failure the gyros are excluded: the navigator goes
        on with the position filter on the autopilot's attitude (the ``ahrs`` backend), from the ESKF's
        position and velocity, its attitude offset to the autopilot's kept from before the window."""
        g = self.gyro_check
        g.gyro(t, gyr, dt)
        self._gyro_steps += 1
        if self._gyro_steps % max(1, round(self.cfg.ins_rate_hz / 10.0)):
            return
        newest = self.att.newest_t if self.att.k else -math.inf
        failed = g.check(lambda ti: self.att.at(ti) if ti <= newest + 1e-9 else None)
        self.recorder("gyro_check", t, stat=g.last_stat)
        if not failed:
            return
        tb, p, v, eul, P = self.backend.state()
        look, a0 = self.hist.at(g.t0), self.att.at(g.t0)
        off = np.zeros(3)
        if look is not None and a0 is not None:
            off = look[3:] - a0
            off[2] = (off[2] + math.pi) % (2 * math.pi) - math.pi
        T = g.detected_t - g.t0
        # the tilt error grew ~linearly over the window: velocity error g rate T^2 / 2, position g rate T^3 / 6
        dv, dp = 9.81 * g.rate * T * T / 2, 9.81 * g.rate * T**3 / 6
        sp = math.sqrt(float(np.max(np.diag(P)[:3]))) + dp
        sv = math.sqrt(float(np.max(np.diag(P)[3:6]))) + dv
        ahrs = self._ahrs()
        self.backend = _AhrsBackend(tb, p, v, (ahrs if ahrs is not None else eul - off) + off, sigma_p=sp,
                                    sigma_v=sv)
        self.backend.offset = off
        self.gyro_check = None
        why = (f"gyros turned {math.degrees(float(np.linalg.norm(g.d))):.2f} deg more than the autopilot's attitude "
               f"over {T:.1f} s (chi2(3) {g.last_stat:.0f} > {g.bound:.0f} at {g.detected_t:.1f} s): gyros excluded, "
               "navigating on the autopilot's attitude")
        self.integrity.suspect("gyro", why, lambda _t, dp=dp: dp)
        self._note(f"{t:.1f}s {why}")

    def _check_tilt(self, t: float) -> None:
        """10 Hz: the ESKF's roll / pitch against the autopilot's at the autopilot's newest instant
        (``TiltCheck``); on a flag the bias states are opened and the autopilot's attitude is fused from then
        on (the tilt is pinned: a horizontal accelerometer bias becomes observable from the position fixes);
        the state is degraded and the HPL grows by what the bias can have built before the flag."""
        if not self.att.k:
            return
        ta = self.att.newest_t
        if self.ahrs_aid:
            ic = self.cfg.integrity
            s = math.radians(ic.tilt_aid_sigma_deg)
            e = self.att.at(t) if t <= ta + 1e-9 else self.att.newest()
            self.backend.aid_attitude(e, np.array([s, s, math.radians(10.0)]))
            return
        look = self.hist.at(ta)
        if look is None:
            return
        d = look[3:5] - self.att.newest()[:2]
        c = self.tilt_check
        flagged = c.update(t, d)
        self.recorder("tilt_check", t, angle=math.degrees(c.last))
        if not flagged:
            return
        ic = self.cfg.integrity
        self.backend.open_accel_bias(ic.tilt_fault_accel_bias_sigma_mps2, ic.tilt_fault_accel_bias_noise)
        self.ahrs_aid = True
        dp = c.position_bound()
        why = (f"filter tilt {math.degrees(c.angle):.1f} deg from the autopilot's for {ic.tilt_check_persist_s:g} s "
               f"(an accelerometer bias taken for a tilt?): the autopilot's attitude fused, bias states opened")
        self.integrity.suspect("accel_tilt", why, lambda _t, dp=dp: dp)
        self._note(f"{t:.1f}s {why}")

    # ------------------------------------------------------------------ INS-only comparison track
    def _init_ins_only(self, t, p, v, e) -> None:
        self.ins_only = (StrapdownINS(earth_rotation=False, gravity=9.81),
                         NavState(t=float(t), position=p.copy(), velocity=v.copy(), quat=euler_to_quat(e)))

    def _ins_only_step(self, t, acc, gyr, dt, ahrs_euler) -> None:
        ins, state = self.ins_only
        self.ins_only = (ins, ins.propagate(state, acc, gyr, dt))
        pos = self.ins_only[1].position
        if t - self._ins_log_t >= 0.1 - 1e-6:
            self._ins_log_t = t
            self.recorder("ins_only", t, position=pos.copy())

    # ------------------------------------------------------------------ vision
    def _process_frames(self) -> None:
        while self.frames:
            f, gap = self.frames[0]
            if self.hist.k == 0 or self.hist.newest_t < f.t:
                return  # the filter has not reached the frame's instant yet
            self.frames.popleft()
            self._vision(f, gap)

    def _vision(self, f: Frame, gap: str = "") -> None:
        """One frame; a ``gap`` one (a repeat of the previous image, a frame stamped ahead of the IMU clock: the
        reason) is a camera gap: no odometry and no
        registration, the PMF carried on by the filter's own displacement (so that it follows the vehicle),
        the odometry restarted on the next live frame."""
        c = self.cfg
        look = self.hist.at(f.t)
        if look is None:
            return
        p, e = look[:3], look[3:]
        C_bn = euler_to_dcm(e)
        cam, C_cn = self.mount.camera_pose(p, C_bn)
        height = -float(cam[2])
        self.n_frames += 1
        frozen = bool(gap)
        if frozen:
            self.vo.restart()
            step = OdometryStep(f.t, False, np.full(3, np.nan), 0, 0, 0, gap)
        else:
            step = self.vo.step(f.t, f.image, C_cn, height)
        if step is None:  # the tracker (re)started on this frame: no displacement measured
            step = OdometryStep(f.t, False, np.full(3, np.nan), 0, 0, 0, "tracker restarted (no features before)")
        look0 = self.hist.at(f.t - 1.0 / c.odometry_hz)
        u_ins = (p - look0[:3])[:2] if look0 is not None else np.zeros(2)
        if step.ok and np.linalg.norm(step.displacement[:2] - u_ins) > c.odometry_gate_m + 0.15 * np.linalg.norm(u_ins):
            step.reason = (f"displacement {np.round(step.displacement[:2], 1)} m disagrees with the filter's "
                           f"{np.round(u_ins, 1)} m")
            step.ok = False
        self.h.tracking = bool(step.ok)
        if step.ok:
            u = step.displacement[:2]
            self._last_u = u
            self.odo_track = self.odo_track + np.r_[u, 0.0]
            sv = c.process_noise_m + c.process_noise_frac * float(np.linalg.norm(u))
            self.pmf.predict(u, sv)
            self._odo_var += sv * sv
        else:
            self.skipped_odometry += 1
            self._note(f"{f.t:.1f}s odometry skipped: {step.reason}")
            # no displacement measured: predict with the filter's own displacement and a wider noise
            u = u_ins
            sv = c.process_noise_m + 0.2 * float(np.linalg.norm(u)) + 0.5
            self.pmf.predict(u, sv)
            self._odo_var += sv * sv
            # the odometry-only track dead-reckons on its last measured displacement
            self.odo_track = self.odo_track + np.r_[self._last_u, 0.0]
        self.recorder("odometry", f.t, ok=step.ok, n_tracked=step.n_tracked, n_inliers=step.n_inliers,
                      n_outliers=step.n_outliers, displacement=np.nan_to_num(step.displacement[:2]),
                      position=self.odo_track.copy(), height=height)
        registered, peak, window = False, float("nan"), float("nan")
        if self.n_frames % c.registration_every == 0 and not frozen:
            mean, P = self.pmf.estimate()
            sig = math.sqrt(max(np.linalg.eigvalsh(P).max(), 0.0))
            window = float(np.clip(c.window_sigmas * sig + 2.0, c.window_min_m, c.window_max_m))
            reg = self.reg.register(f.image, e, height, mean, window)
            peak = reg.peak
            if reg.ok and reg.peak >= c.min_peak_ncc:
                N, E = np.meshgrid(*self.pmf.grid(), indexing="ij")
                ncc = reg.sample(N, E, fill=-1.0)
                top = float(np.nanmax(reg.ncc))
                L = c.likelihood_floor + np.exp(c.ncc_gain * (ncc - top))
                registered = self.pmf.update(L) > 0
                self.registrations += int(registered)
                self.h.coherence = float(reg.peak)
            elif not reg.ok:
                self._note(f"{f.t:.1f}s no registration: {reg.reason}")
        mean, P = self.pmf.estimate()
        self.recorder("pmf", f.t, position=mean, cov=P, registered=registered, ncc_peak=peak, window_m=window)
        if registered and self.handover is not None:
            self._check_handover(f.t, mean, P)
        if not (step.ok or registered):
            return  # the PMF only carried the filter's own prediction: nothing to feed back
        # PMF -> Kalman filter (position at the frame instant, moved to the filter's time by its velocity);
        # a latched hand-over offset keeps the filter in the hand-over's frame
        t_kf, p_kf, v_kf, _, _ = self.backend.state()
        z = mean + v_kf[:2] * (t_kf - f.t)
        if self.handover is not None and self.handover.offset is not None:
            z = z - self.handover.offset
        R = P + 0.01 * np.eye(2) if c.use_pmf_covariance else np.eye(2) * c.kf_position_sigma_m**2
        self.backend.update_position(z, R)
        self.integrity.record(f.t, "vision", *self.backend.last)

    def _check_handover(self, t: float, mean, P) -> None:
        h = self.handover
        d = np.asarray(mean, float) - self.odo_track[:2]
        var = self._odo_var + float(np.linalg.eigvalsh(P).max())
        if h.add(t, d, var):
            off = float(np.linalg.norm(h.offset))
            self.integrity.suspect("handover", f"map registration {off:.1f} m from the odometry since the GPS "
                                   f"hand-over (offset map or wrong start)", lambda _t, off=off: off)
            self._note(f"{t:.1f}s hand-over offset {np.round(h.offset, 1)} m latched")
        self.recorder("handover_check", t, offset=d, sigma=math.sqrt(var), stat=h.last_stat,
                      latched=h.offset if h.offset is not None else np.full(2, np.nan))

    def _note(self, text: str) -> None:
        if len(self.h.notes) < 200:
            self.h.notes.append(text)

    # ------------------------------------------------------------------ outputs
    def estimate(self, t: float) -> NavEstimate:
        if self.backend is not None:
            tb, p, v, e, P = self.backend.state()
            return NavEstimate(t=t, position=p + v * (t - tb), velocity=v, attitude=e, covariance=P,
                               valid=bool(np.all(np.isfinite(p))), source="vision")
        f = self.gps_filter
        e = self._ahrs()
        p, v = propagate(f.p, f.v, f.accel, t - f.t if f.t is not None else 0.0)
        return NavEstimate(t=t, position=p, velocity=v,
                           attitude=np.zeros(3) if e is None else e.copy(), covariance=f.covariance(),
                           valid=f.initialized and e is not None, source="gps")

    def health(self, t: float | None = None) -> Health:
        if t is not None:
            extra = 0.0
            if self.backend is not None:
                P = self.backend.covariance()
                ic = getattr(self.cfg, "integrity", None)
                if self.pmf is not None and ic is not None and ic.pmf_in_hpl:
                    extra = float(np.linalg.eigvalsh(self.pmf.estimate()[1]).max())
            else:
                P = self.gps_filter.covariance() if self.gps_filter.initialized else None
            self.integrity.fill(self.h, t, None if P is None else P[:2, :2], extra)
        return self.h
