"""The vision + INS navigator of the WITAS landing (seed 002 ch. 6, Fig. 6.4; filter of appendix A).

* IMU (gyros 200 Hz, accelerometers 66 Hz held, ``sensors/split_imu.py``) -> strapdown INS and
  error-state KF propagation at every sample (``estimation/eskf.py``, eq. A.1-A.8);
* every frame (20 Hz) -> ``vision/pad.PadDetector`` -> camera centre c in the pad frame (pad centre
  = NED origin) -> vehicle position  p = c - C_bn (l + C_cb(pan, tilt) h)  (lever arm l of the
  pan-tilt unit, head offset h of the camera centre, encoder angles, the filter's attitude at the
  frame instant) -> position update (eq. 5.23 first rows) with the pose covariance; the fix
  describes the frame instant and reaches the filter ``latency`` later: it is moved forward by the
  filter velocity over the difference (as navigation/witas.py does). Only the position is used
  (§6.2); the vision attitude C_bn = C_cn C_cb^T is kept for the comparison of Figs. 6.9-6.10;
* output: the filter state sampled at ``output_hz`` (50 Hz), held in between;
* the pan-tilt tracking controller (on the image-processing computer in Fig. 6.4) points the
  optical axis at the imaged pad centre; with no detection it points at the pad as predicted by the
  filter (re-acquisition after a black-out);
* no fix: the filter dead-reckons on the INS, its covariance grows (``health.source = "inertial"``).
* IMU faults (issue #18, docs/pad.md "IMU faults"): the gyros against the autopilot's attitude
  (``GyroAttitudeCheck``), the filter's attitude against the autopilot's, and fixes gated out in a row
  that agree with each other (the filter is re-initialised on them); any of them -> the autopilot's
  attitude is fused from then on and the bias states learn the fault. A frozen frame is no fix.

No GPS. Before the first fix the estimate is invalid (the controller holds the trim); the filter
starts from that fix with zero velocity and the attitude of the R-MAX's attitude system.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from visnav.estimation.eskf import BA_, BG_, EskfConfig, ErrorStateKF
from visnav.estimation.history import History
from visnav.estimation.ins import NavState, euler_to_quat
from visnav.geometry.mounts import PanTiltMount
from visnav.geometry.rotations import dcm_to_euler, euler_to_dcm
from visnav.measurements import AttitudeSample, Frame, Health, ImuSample, NavEstimate, NavInit, PanTiltFrame
from visnav.navigation.base import CommandDispatch, FrozenFrameCheck
from visnav.navigation.integrity import NavIntegrity, gyro_check_from
from visnav.vision.pad import PadDetector
from visnav.log_schema import register_stream

_NED = "NED world (origin at the scenario's home)"
_EUL = "3-2-1 Euler angles (roll, pitch, yaw) of body FRD relative to NED world"
register_stream("pad_filter_start", position=("m", _NED, "vision position the filter started from"),
                euler=("rad", _EUL, "attitude the filter started from"))
register_stream("pad_fault", reason=("text", "", "what the filter found wrong (a failed gyro check, fixes gated out "
                                                 "that agree with each other) and what it did"),
                position=("m", _NED, "filter position after (the re-initialisation's start)"),
                velocity=("m/s", _NED, "filter velocity after"),
                euler=("rad", _EUL, "filter attitude after"))
register_stream("pad_attitude_check", angle=("deg", "", "rotation from the autopilot's attitude to the filter's "
                                                         "(the attitude check, 10 Hz until an IMU fault is flagged)"))
register_stream("pad_lost", reason=("text", "", "why the frame gave no pad pose"), rings=("1", "", "rings detected"))
register_stream("pad_vision", position=("m", _NED, "body position from the pad pose (lever arm and pan-tilt removed)"),
                camera=("m", "pad frame = NED world at the pad", "camera position from the pad pose"),
                euler=("rad", _EUL, "body attitude from the pad pose alone (vision-only, carries the mount bias)"),
                sigma=("m", "camera position axes", "1-sigma of the pose position (first-order, from detection noise)"),
                config=("1", "", "index of the three-circle configuration used (0 = largest)"),
                rms_px=("px", "", "reprojection RMS of the pose"),
                accepted=("bool", "", "the filter accepted the update (chi-square gate)"),
                nis=("1", "", "normalised innovation squared of the update (NaN for the first fix)"),
                pan=("rad", "pan-tilt unit", "pan encoder reading"), tilt=("rad", "pan-tilt unit", "tilt encoder reading"))


Recorder = Callable[..., None]


def pointing_angles(d_body: np.ndarray, current: tuple[float, float], tilt_max: float) -> tuple[float, float]:
    """(pan, tilt) that put the optical axis along ``d_body``; of the two solutions (pan, tilt) and
    (pan + pi, pi - tilt) the one nearer ``current`` within the tilt range."""
    pan = math.atan2(d_body[1], d_body[0])
    tilt = math.atan2(d_body[2], math.hypot(d_body[0], d_body[1]))
    alt = (pan + math.pi + math.pi) % (2 * math.pi) - math.pi, math.pi - tilt
    best = None
    for p, t in ((pan, tilt), alt):
        if t > tilt_max:
            continue
        cost = abs((p - current[0] + math.pi) % (2 * math.pi) - math.pi) + abs(t - current[1])
        if best is None or cost < best[0]:
            best = (cost, p, t)
    return (pan, tilt) if best is None else (best[1], best[2])


class PadNavigator(CommandDispatch):
    """The ``navigation/base.Navigator`` of seed 002 ch. 6. It takes no commands: the filter starts at the
    first vision fix (or at a ``NavInit``)."""

    def __init__(self, cfg, detector: PadDetector, ptu, recorder: Recorder | None = None):
        """``cfg``: a ``PadFilterConfig``; ``ptu``: the pan-tilt command link (``point_at(t, pan,
        tilt)``, ``mount`` geometry, ``head_offset``, ``mount.tilt_limits``)."""
        self.cfg = cfg
        self.det = detector
        self.K = detector.K
        self.Kinv = np.linalg.inv(self.K)
        self.ptu = ptu
        geo = ptu.mount
        self._geom = PanTiltMount(0.0, 0.0, geo.pan_limits, geo.tilt_limits, geo.lever_arm)
        self.lever_arm = np.asarray(geo.lever_arm, float)
        self.head_offset = np.asarray(ptu.head_offset, float)
        self.recorder = recorder or (lambda *a, **k: None)
        self.kf: ErrorStateKF | None = None
        self.ahrs: np.ndarray | None = None
        self.hist = History(6, 256, angles=(5,), tolerance=0.05)  # filter (position, euler) for the frame instants
        self.h = Health(source="none")
        self._out: NavEstimate | None = None
        self._next_out = -math.inf
        self.t_fix: float | None = None
        self.fixes = 0
        self._floor_var = 0.0  # variance [m^2] per axis of the last accepted fix's floor (HPL)
        self.rejected = 0
        self._last_imu_t = -math.inf
        # integrity (issue #18): NIS of every vision position update (3 dof, gated by the filter)
        self.integrity = NavIntegrity(getattr(cfg, "integrity", None), self.recorder, inflation_streams=("vision",))
        # IMU faults (issue #18): the gyros against the autopilot's attitude (None: off, or failed already)
        self.gyro_check = gyro_check_from(getattr(cfg, "integrity", None))
        self.att = History(3, 256, angles=(2,))  # the autopilot's attitude (the gyro check's other side)
        self._gyro = [np.zeros(3), 0, -math.inf]  # gyro sum, samples, time of the last 50 Hz step
        self._gyro_steps = 0
        self.ahrs_aid = False  # fuse the autopilot's attitude (once an IMU fault is flagged)
        self._next_aid = -math.inf
        self._gated: list[tuple[float, np.ndarray, np.ndarray]] = []  # fixes gated out in a row: (t, p, R)
        self._agree = 0  # fixes accepted in a row since the last IMU fault (clears its suspicion)
        self.reinits = 0
        self._frozen = FrozenFrameCheck()  # a frame repeating the previous one (a frozen link) is no fix

    # ------------------------------------------------------------------ helpers
    def _R_cb(self, pan: float, tilt: float) -> np.ndarray:
        self._geom.set(pan, tilt)
        return self._geom.R_cam_to_body

    def _start(self, t: float, position: np.ndarray, velocity: np.ndarray | None = None,
               sigmas: tuple | None = None) -> None:
        """``sigmas``: (position, velocity, accel bias, gyro bias) 1-sigmas of a re-initialisation (the biases
        estimated so far are kept); None: the first start's."""
        c = self.cfg
        e = np.zeros(3) if self.ahrs is None else self.ahrs
        v = np.zeros(3) if velocity is None else velocity.copy()
        s = NavState(t=float(t), position=position.copy(), velocity=v, quat=euler_to_quat(e))
        sa = math.radians(c.init_attitude_sigma_deg)
        if sigmas is None:
            sp, sv, sba, sbg = [c.init_position_sigma_m] * 3, [c.init_velocity_sigma_mps] * 3, 0.02, math.radians(0.05)
        else:
            sp, sv, sba, sbg = sigmas
            s.accel_bias, s.gyro_bias = self.kf.x.accel_bias.copy(), self.kf.x.gyro_bias.copy()
        P0 = list(sp) + list(sv) + [sa, sa, 3 * sa] + [sba] * 3
        if c.gyro_bias_states:
            P0 += [sbg] * 3
        cfg = EskfConfig(accel_noise=c.accel_noise, gyro_noise=c.gyro_noise, accel_bias_noise=c.accel_bias_noise,
                         gyro_bias_noise=c.gyro_bias_noise, gyro_bias=c.gyro_bias_states, gravity_mps2=9.81,
                         earth_rotation=False, gate_probability=c.gate_probability)
        self.kf = ErrorStateKF(s, np.array(P0), cfg)
        if sigmas is None:
            self.recorder("pad_filter_start", t, position=position.copy(), euler=e.copy())

    def initialize(self, init: NavInit) -> None:
        """Start the filter at an explicit pose instead of the first vision fix (zero velocity unless given)."""
        if init.position is None:
            raise ValueError("the pad navigator needs a position to start from (NavInit.position)")
        if init.attitude is not None:
            self.ahrs = np.asarray(init.attitude, float)
        v = np.zeros(3) if init.velocity is None else np.asarray(init.velocity, float)
        self._start(init.t, np.asarray(init.position, float), v)

    # ------------------------------------------------------------------ measurements
    def update(self, m) -> None:
        if isinstance(m, ImuSample):
            self._on_imu(m)
        elif isinstance(m, AttitudeSample):
            if np.all(np.isfinite(m.euler)):
                self.ahrs = np.asarray(m.euler, float)
                if m.t > self.att.newest_t:
                    self.att.push(m.t, self.ahrs)
                if self.ahrs_aid and self.kf is not None and m.t >= self._next_aid - 1e-9 \
                        and abs(m.t - self.kf.x.t) < 1e-6:
                    # the gyros are not trusted: the autopilot's attitude (of the filter's instant) holds the
                    # attitude, the gyro bias states follow it
                    self._next_aid = max(self._next_aid + 1.0 / self.cfg.ahrs_hz, m.t)
                    self.kf.update_attitude(self.ahrs, math.radians(self.cfg.ahrs_sigma_deg), gate=False)
        elif isinstance(m, PanTiltFrame):
            self._on_frame(m)
        elif isinstance(m, Frame):
            self.h.rejected_samples += 1  # a frame without encoder angles cannot be used

    def _on_imu(self, m: ImuSample) -> None:
        if not (np.all(np.isfinite(m.accel)) and np.all(np.isfinite(m.gyro))) or m.t <= self._last_imu_t:
            self.h.rejected_samples += 1
            return
        self._last_imu_t = m.t
        if self.kf is None:
            return
        self.kf.predict(m)
        self._checks(m)
        x = self.kf.x
        self.hist.push(m.t, np.concatenate((x.position, x.euler)))
        if m.t >= self._next_out - 1e-9:  # the 50 Hz output
            self._next_out = max(self._next_out + 1.0 / self.cfg.output_hz, m.t)
            self._out = NavEstimate(t=m.t, position=x.position.copy(), velocity=x.velocity.copy(),
                                    attitude=x.euler.copy(), covariance=self.kf.P[:6, :6].copy(), valid=True,
                                    source=self.h.source)

    def _on_frame(self, f: PanTiltFrame) -> None:
        R_cb = self._R_cb(f.pan, f.tilt)
        if self._frozen.repeated(f.image) and int(f.image.max()) != int(f.image.min()):
            # a frozen link (a blank frame repeats by nature: it goes to the detector and gives no pose): the
            # same pose again is no fix of a still vehicle
            self.integrity.suspect("frozen", f"frozen camera ({self._frozen.count} frames repeated the previous "
                                   "one: not fused)", lambda _t: 0.0)
            if self.kf is not None and (self.t_fix is None or f.t - self.t_fix > self.cfg.fix_timeout_s):
                self.h.source = "inertial"
            self.recorder("pad_lost", f.t, reason="frozen frame", rings=0)
            self._track(f, R_cb, None)
            return
        self.integrity.clear("frozen")
        det = self.det.detect(f.image)
        pose = det.pose
        now = self._last_imu_t
        if pose is None:
            self.h.tracking = False
            if self.kf is not None and (self.t_fix is None or f.t - self.t_fix > self.cfg.fix_timeout_s):
                self.h.source = "inertial"
            self.recorder("pad_lost", f.t, reason=det.reason, rings=len(det.rings))
            self._track(f, R_cb, None)
            return
        C_cn = pose.C_cn
        C_bn_vis = C_cn @ R_cb.T
        offset = self.lever_arm + R_cb @ self.head_offset
        look = self.hist.at(f.t) if self.kf is not None else None
        e_f = look[3:] if look is not None else (self.ahrs if self.ahrs is not None else dcm_to_euler(C_bn_vis))
        C_bn = euler_to_dcm(e_f)
        p_vis = pose.position - C_bn @ offset
        # floor: a constant plus a part proportional to the range (the 27 points share 6 ellipses,
        # so a size error of the fits moves them together: a scale error J^T J does not see)
        floor = self.cfg.position_floor_m + self.cfg.range_floor * float(np.linalg.norm(pose.position))
        R = pose.cov + np.eye(3) * floor**2
        accepted, nis = False, float("nan")
        if self.kf is None:
            self._start(now if math.isfinite(now) else f.t, p_vis)
            self.integrity.start(f.t)
            accepted = True
        else:
            lag = max(self.kf.x.t - f.t, 0.0)
            res = self.kf.update_position(p_vis + self.kf.x.velocity * lag, R)
            accepted, nis = res.accepted, res.nis
            self.integrity.record(f.t, "vision", nis, 3, accepted)
        if accepted:
            self.t_fix = f.t
            self.fixes += 1
            self._floor_var = floor * floor
            self.h.source = "vision"
            if self._gated:
                self._gated.clear()
                self.integrity.clear("gated")
            self._agree += 1
            if self._agree == self.integrity.monitor.config.window:  # a window of fixes agrees with the filter
                for name in ("gyro", "attitude", "reinit"):
                    self.integrity.clear(name)
                if self.kf.cfg.accel_bias_noise != self.cfg.accel_bias_noise:
                    # the bias is learnt: back to the nominal random walk (a noisier bias estimate would
                    # carry the blind last half metre off: seed 13 climbed away from 0.3 m with 0.1 kept)
                    self.kf.retune(accel_bias_noise=self.cfg.accel_bias_noise)
        else:
            self.rejected += 1
            self._gated.append((f.t, p_vis, R))
            self._agree = 0
            # the filter and the camera disagree: one of them is wrong, the estimate is not "ok" until a fix is
            # taken again (fault-free no fix is gated out: 0 in 20 seeds)
            self.integrity.suspect("gated", f"{len(self._gated)} fixes in a row gated out", lambda _t: 0.0)
            if self.cfg.reinit_fixes and len(self._gated) >= self.cfg.reinit_fixes:
                self._reinit(f.t, floor)
        self.h.tracking = True
        self.recorder("pad_vision", f.t, position=p_vis, camera=pose.position, euler=dcm_to_euler(C_bn_vis),
                      sigma=np.sqrt(np.diag(pose.cov)), config=pose.config, rms_px=pose.rms_px, accepted=accepted,
                      nis=nis, pan=f.pan, tilt=f.tilt)
        self._track(f, R_cb, det.pad_centre_px)

    # ------------------------------------------------------------------ IMU faults
    def _imu_fault(self, t: float, name: str, why: str) -> None:
        """An IMU fault is flagged (``name``: "gyro", "attitude" or "reinit"): from now on the autopilot's
        attitude is fused (the gyros no longer hold the attitude, and a horizontal accelerometer bias can no
        longer hide as a tilt) and the accelerometer bias random walk is ``fault_accel_bias_noise`` (its
        states learn the fault); the state is degraded, and the random walk that large, until a window of
        fixes agrees with the filter again."""
        self.ahrs_aid = True
        self._next_aid = -math.inf
        self._agree = 0
        # the faulty IMU's bias is to be learnt: its states follow faster until the fixes agree again
        self.kf.retune(accel_bias_noise=max(self.cfg.accel_bias_noise, self.cfg.fault_accel_bias_noise))
        self.integrity.suspect(name, why, lambda _t: 0.0)
        x = self.kf.x
        self.recorder("pad_fault", t, reason=why, position=x.position.copy(), velocity=x.velocity.copy(),
                      euler=x.euler.copy())

    def _checks(self, m: ImuSample) -> None:
        """The IMU checks: the gyro / autopilot-attitude test (``GyroAttitudeCheck`` on the gyros less the
        filter's bias estimate, fed at 50 Hz, tested at 10 Hz) and the attitude check (10 Hz,
        ``_check_attitude``). On a gyro failure the gyros no longer hold the attitude (the autopilot's is
        fused, ``_imu_fault``), the gyro bias states start again from ``reinit_gyro_bias_sigma_dps`` (they
        learn the faulty bias) and the test starts again (a bias that changes again, or ends, fails it
        again)."""
        a = self._gyro
        a[0] = a[0] + m.gyro
        a[1] += 1
        if not math.isfinite(a[2]):
            a[:] = [np.zeros(3), 0, m.t]
            return
        if m.t - a[2] < 0.02 - 1e-6:
            return
        g = self.gyro_check
        if g is not None:
            g.gyro(m.t, a[0] / a[1] - self.kf.x.gyro_bias, m.t - a[2])  # (the rates the filter uses)
        a[:] = [np.zeros(3), 0, m.t]
        self._gyro_steps += 1
        if self._gyro_steps % 5:
            return
        if not self.ahrs_aid and self._check_attitude(m.t):
            return
        if g is None:
            return
        newest = self.att.newest_t
        failed = g.check(lambda ti: self.att.at(ti) if ti <= newest + 1e-9 else None)
        self.recorder("gyro_check", m.t, stat=g.last_stat)
        if not failed:
            return
        self.gyro_check = gyro_check_from(getattr(self.cfg, "integrity", None))  # again, on the new bias estimate
        if self.cfg.gyro_bias_states:
            s = math.radians(self.cfg.reinit_gyro_bias_sigma_dps)
            self.kf.P[BG_, BG_] += np.eye(3) * s * s
        self._imu_fault(m.t, "gyro", f"gyros turned {math.degrees(float(np.linalg.norm(g.d))):.2f} deg more than "
                                     f"the autopilot's attitude over {g.detected_t - g.t0:.1f} s (chi2(3) "
                                     f"{g.last_stat:.0f} > {g.bound:.0f}): the autopilot's attitude is fused")

    def _check_attitude(self, t: float) -> bool:
        """The filter's attitude against the autopilot's (absolute, 10 Hz): a filter that folds an IMU fault
        into its attitude (an accelerometer bias taken for a tilt or a heading error: the lever arm then
        moves the fixes with it and they agree with the wrong estimate) leaves the autopilot's by more than
        ``attitude_check_deg``: an IMU fault (``_imu_fault``). True when flagged."""
        a = self.att.at(t) if t <= self.att.newest_t + 1e-9 else self.ahrs
        if a is None:
            return False
        d = Rotation.from_matrix(euler_to_dcm(a).T @ self.kf.x.dcm).as_rotvec()
        ang = math.degrees(float(np.linalg.norm(d)))
        self.recorder("pad_attitude_check", t, angle=ang)
        lim = getattr(getattr(self.cfg, "integrity", None), "attitude_check_deg", math.inf)
        if ang <= lim:
            return False
        if self.cfg.gyro_bias_states:
            s = math.radians(self.cfg.reinit_gyro_bias_sigma_dps)
            self.kf.P[BG_, BG_] += np.eye(3) * s * s
        s = self.cfg.reinit_accel_bias_sigma_mps2
        self.kf.P[BA_, BA_] += np.eye(3) * s * s
        self._imu_fault(t, "attitude", f"filter attitude {ang:.1f} deg from the autopilot's (> {lim:g}): an IMU "
                                       "fault taken into the attitude; the autopilot's attitude is fused")
        return True

    def _reinit(self, t: float, floor: float) -> None:
        """The last ``reinit_fixes`` fixes were all gated out. If they agree with each other (one smooth
        track: chi-square of their residuals about a constant-acceleration fit per axis below the ``1 -
        reinit_alpha`` quantile) the filter, not the camera, is wrong (an IMU fault has driven it off):
        it starts again from the fitted track (position and velocity of the newest fix with the fit's
        covariance, the autopilot's attitude, the biases estimated so far with ``reinit_*_bias_sigma``)."""
        c = self.cfg
        run = self._gated[-c.reinit_fixes:]
        ts = np.array([r[0] for r in run]) - t
        A = np.stack([np.ones_like(ts), ts, 0.5 * ts * ts], axis=1)
        p, v, var_p, var_v, stat = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), 0.0
        for k in range(3):
            z = np.array([r[1][k] for r in run])
            w = 1.0 / np.array([r[2][k, k] for r in run])
            C = np.linalg.inv(A.T @ (A * w[:, None]))
            coef = C @ (A.T @ (w * z))
            stat += float(np.sum(w * (z - A @ coef) ** 2))
            p[k], v[k], var_p[k], var_v[k] = coef[0], coef[1], C[0, 0], C[1, 1]
        dof = 3 * (len(run) - 3)
        bound = float(chi2.ppf(1.0 - c.reinit_alpha, dof))
        if stat > bound:
            return  # the fixes disagree with each other: not a filter fault (keep waiting)
        now = self.kf.x.t
        lag = max(now - t, 0.0)
        sp = np.sqrt(var_p + floor * floor + var_v * lag * lag)
        self._start(now, p + v * lag, v, (sp, np.sqrt(var_v), c.reinit_accel_bias_sigma_mps2,
                                          math.radians(c.reinit_gyro_bias_sigma_dps)))
        self.hist = History(6, 256, angles=(5,), tolerance=0.05)  # the old filter's track is not the new one's
        self._next_out = -math.inf
        self._gated.clear()
        self.integrity.clear("gated")
        self.reinits += 1
        self.t_fix = t
        self.h.source = "vision"
        self.integrity.restart(t)
        self._imu_fault(t, "reinit", f"{len(run)} fixes in a row gated out agree with each other (chi2({dof}) {stat:.1f} "
                           f"<= {bound:.1f}): filter re-initialised on them (#{self.reinits})")

    def _track(self, f: PanTiltFrame, R_cb: np.ndarray, uv) -> None:
        """Pan-tilt tracking: aim at the imaged pad centre (or the filter's prediction of it)."""
        if uv is not None:
            d_b = R_cb @ (self.Kinv @ np.array([uv[0], uv[1], 1.0]))
        elif self.kf is not None:
            look = self.hist.at(f.t)
            if look is None:
                return
            p, e = look[:3], look[3:]
            C_bn = euler_to_dcm(e)
            cam = p + C_bn @ (self.lever_arm + R_cb @ self.head_offset)
            d_b = C_bn.T @ (np.zeros(3) - cam)
        else:
            return
        d_b = d_b / np.linalg.norm(d_b)
        axis = R_cb[:, 2]
        if math.degrees(math.acos(float(np.clip(axis @ d_b, -1.0, 1.0)))) < self.cfg.track_deadband_deg:
            return
        pan, tilt = pointing_angles(d_b, (f.pan, f.tilt), self._geom.tilt_limits[1])
        self.ptu.point_at(self._last_imu_t if math.isfinite(self._last_imu_t) else f.t, pan, tilt)

    # ------------------------------------------------------------------ outputs
    def estimate(self, t: float) -> NavEstimate:
        if self._out is None:
            return NavEstimate(t=t, position=np.zeros(3), velocity=np.zeros(3), attitude=np.zeros(3), valid=False,
                               source="none")
        o = self._out  # the latest 50 Hz output, moved to t along its velocity
        return NavEstimate(t=t, position=o.position + o.velocity * (t - o.t), velocity=o.velocity,
                           attitude=o.attitude, covariance=o.covariance, valid=True, source=self.h.source)

    def health(self, t: float | None = None) -> Health:
        if t is not None:
            # the fixes' floor (a size error of the ellipse fits moves all 27 points together) is the same
            # in every fix: fusing many does not average it out, the filter's P does as if it did; it goes
            # into the HPL as an error the filter cannot see (fault-free 20 seeds: 52 of 8.6k ok steps had
            # the true error, 6-7 mm at 1.2 m height, above the HPL without it)
            self.integrity.fill(self.h, t, self.kf.P[:2, :2] if self.kf is not None else None, self._floor_var)
        return self.h
