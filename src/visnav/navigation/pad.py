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

No GPS. Before the first fix the estimate is invalid (the controller holds the trim); the filter
starts from that fix with zero velocity and the attitude of the R-MAX's attitude system.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from visnav.estimation.eskf import EskfConfig, ErrorStateKF
from visnav.estimation.history import History
from visnav.estimation.ins import NavState, euler_to_quat
from visnav.geometry.mounts import PanTiltMount
from visnav.geometry.rotations import dcm_to_euler, euler_to_dcm
from visnav.measurements import AttitudeSample, Frame, Health, ImuSample, NavEstimate, NavInit, PanTiltFrame
from visnav.navigation.base import CommandDispatch
from visnav.navigation.integrity import NavIntegrity
from visnav.vision.pad import PadDetector
from visnav.log_schema import register_stream

_NED = "NED world (origin at the scenario's home)"
_EUL = "3-2-1 Euler angles (roll, pitch, yaw) of body FRD relative to NED world"
register_stream("pad_filter_start", position=("m", _NED, "vision position the filter started from"),
                euler=("rad", _EUL, "attitude the filter started from"))
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

    # ------------------------------------------------------------------ helpers
    def _R_cb(self, pan: float, tilt: float) -> np.ndarray:
        self._geom.set(pan, tilt)
        return self._geom.R_cam_to_body

    def _start(self, t: float, position: np.ndarray, velocity: np.ndarray | None = None) -> None:
        c = self.cfg
        e = np.zeros(3) if self.ahrs is None else self.ahrs
        v = np.zeros(3) if velocity is None else velocity.copy()
        s = NavState(t=float(t), position=position.copy(), velocity=v, quat=euler_to_quat(e))
        sa = math.radians(c.init_attitude_sigma_deg)
        P0 = [c.init_position_sigma_m] * 3 + [c.init_velocity_sigma_mps] * 3 + [sa, sa, 3 * sa] + [0.02] * 3
        if c.gyro_bias_states:
            P0 += [math.radians(0.05)] * 3
        cfg = EskfConfig(accel_noise=c.accel_noise, gyro_noise=c.gyro_noise, accel_bias_noise=c.accel_bias_noise,
                         gyro_bias_noise=c.gyro_bias_noise, gyro_bias=c.gyro_bias_states, gravity_mps2=9.81,
                         earth_rotation=False, gate_probability=c.gate_probability)
        self.kf = ErrorStateKF(s, np.array(P0), cfg)
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
        x = self.kf.x
        self.hist.push(m.t, np.concatenate((x.position, x.euler)))
        if m.t >= self._next_out - 1e-9:  # the 50 Hz output
            self._next_out = max(self._next_out + 1.0 / self.cfg.output_hz, m.t)
            self._out = NavEstimate(t=m.t, position=x.position.copy(), velocity=x.velocity.copy(),
                                    attitude=x.euler.copy(), covariance=self.kf.P[:6, :6].copy(), valid=True,
                                    source=self.h.source)

    def _on_frame(self, f: PanTiltFrame) -> None:
        det = self.det.detect(f.image)
        R_cb = self._R_cb(f.pan, f.tilt)
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
        else:
            self.rejected += 1
        self.h.tracking = True
        self.recorder("pad_vision", f.t, position=p_vis, camera=pose.position, euler=dcm_to_euler(C_bn_vis),
                      sigma=np.sqrt(np.diag(pose.cov)), config=pose.config, rms_px=pose.rms_px, accepted=accepted,
                      nis=nis, pan=f.pan, tilt=f.tilt)
        self._track(f, R_cb, det.pad_centre_px)

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
