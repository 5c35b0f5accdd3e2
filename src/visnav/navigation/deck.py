"""The deck navigator (seed 003 ch. 3): relative deck UKF fed by the IMU, the autopilot's attitude and LED frames.

It implements the ``Navigator`` interface (``navigation/base.py``) and takes only typed messages:

* ``ImuSample`` - predicts over the time since the previous sample (eq. 3.1-3.5) with the process
  noise of eq. 3.8, ``T_g g`` from the newest ``AttitudeSample`` (roll, pitch); the angular
  acceleration is the numerical derivative of the gyro rates (unfiltered by default: its noise
  telescopes in the velocity, while a low-pass lag biases the Euler term during manoeuvres).
  Samples out of order or with NaN are dropped and counted.
* ``AttitudeSample`` - the autopilot's roll and pitch (yaw unused).
* ``Frame`` - the image (one bit-identical to the previous frame's is a frozen link: dropped, counted in
  ``stats.frames_frozen`` and as a rejected update of the integrity monitor): blobs (``vision/blobs.find_blobs``), their bearings and frame-to-frame rates
  (``BearingTracker``), association with the expected lights (eq. 3.11-3.12, bearings only, the
  covariance of each light's predicted bearings from the unscented transform plus R) and the
  correction with the matched bearings and, for blobs matched to the previous frame, their rates
  (eq. 3.10; new blobs' rates are discarded, §3.1.2). The frame is fused at its own time stamp: a
  frame newer than the filter is predicted to (zero-order hold of the last IMU sample); an older one
  (delivered late) rewinds the filter to its stamp from the stored prediction history (``history_s``),
  is fused there and the IMU samples since are replayed.
* Gate lock-out (every light of ``retie_after_frames`` frames in a row rejected with >= 3 blobs in view):
  re-tie (``_lockout``): position / velocity widened, deck attitude from its prior, the frame fused again,
  the accelerometer noise in Q widened for ``retie_hold_s``. A gap of lost IMU samples is bridged with the
  mean of the samples at its ends.

``initialize(NavInit)``: ``state`` / ``covariance`` given (the thesis' Vicon start, §5.3.5) -> the
sensor's R from the first frame; none -> eq. 5.12-5.17 with the acquisition R (the thesis' 2 deg).
Commands (``NavCommand``): ``restart`` (eq. 5.12 again with relative yaw ``yaw_deg``: the operator's
reset, Fig. 5.7) and ``track`` (hand-over: from now on the sensor's own R). ``estimate(t)`` is the
state propagated to ``t`` with the IMU data the filter has; ``health(t)`` carries the operator's
convergence check (§5.3.1: lights used and RMS bearing innovation over the last second) and the
integrity keys (bearing and bearing-rate NIS, ``estimation/integrity.py``).

Tuning comes from :class:`DeckNavConfig` alone: the ship process noise from ``filter.sea_state`` and
``filter.motion_scale`` (never the world's deck motion), R from the camera's specification.
"""

from __future__ import annotations

import math
from collections import deque
from functools import partial
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from scipy.stats import chi2

from visnav.estimation import deck as dm
from visnav.estimation import kernels as ek
from visnav.estimation.association import associate
from visnav.estimation.integrity import IntegrityConfig, IntegrityMonitor, horizontal_protection_level
from visnav.estimation.ukf import UnscentedKalmanFilter
from visnav.geometry.rotations import euler_to_dcm3, wrap_angle
from visnav.measurements import AttitudeSample, Estimate, Frame, Health, ImuSample, NavInit
from visnav.navigation.base import CommandDispatch, FrozenFrameCheck
from visnav.vision.blobs import BearingTracker, find_blobs

G = 9.81
_GRAVITY_NED = np.array([0.0, 0.0, G])
_GRAVITY_NED.flags.writeable = False
DIVERGED_SIGMA_M, DIVERGED_SIGMA_MPS = 0.5, 0.5  # the restart's least position / velocity sigma per axis
#: centroid error of the rendered spots alone, found by ``find_blobs`` (measured: 0.0033 deg at f = 420 px)
RENDER_CENTROID_PX = 0.025
#: the bias estimate the IMU-only holds take off the specific force (``DeckEstimate.accel_bias``) is clipped at
#: this many prior sigmas
BIAS_CLIP_SIGMAS = 4.0
# a lock-out's frame gives the position (``_relocate``) when its best assignment reprojects within this many bearing
# sigmas RMS (the re-tie's level-prior attitude off by the deck's tilt leaves about 1 deg at 1.5 m)
RELOCATE_RMS_SIGMAS = 3.0
#: the relative yaw's sigma at least after a re-lock took it from a frame (``_relocate_level``) [deg]
RELOCATE_YAW_SIGMA_DEG = 5.0
#: a re-lock's prior on the relative yaw around the lost filter's [deg] (``_relocate_level``): wide, the filter is
#: lost, yet it keeps a turned twin of the layout (180 deg) that fits one frame as well from being taken
RELOCK_YAW_PRIOR_DEG = 45.0
#: a re-lock takes the frame's yaw and position only when the yaw is this many of the filter's yaw sigmas (at least
#: ``RELOCATE_YAW_SIGMA_DEG``) from the filter's
RELOCK_MIN_TURN_SIGMAS = 3.0


@dataclass
class DeckNavStats:
    imu_samples: int = 0
    imu_dropped: int = 0
    frames: int = 0
    frames_dropped: int = 0  # older than the history, or before initialisation
    frames_frozen: int = 0  # bit-identical to the previous frame (a frozen video link): not fused
    clock_steps: int = 0  # steps of the camera's stamps against its frame counter (re-stamped)
    reacquisitions: int = 0  # outages after which the deck's attitude went back to its sea-state prior
    updates_gated: int = 0  # frames whose whole update (with and without rates) was beyond the update gate
    divergences: int = 0  # covariance not positive definite: restarted where it was (``_diverged``)
    empty_frames: int = 0
    blobs: int = 0
    blobs_rejected: int = 0
    lights_used_last: int = 0
    reties: int = 0  # gate lock-outs undone (``DeckNavConfig.retie_after_frames``)
    bias_steps: int = 0  # accelerometer-bias variance widened by the NIS test (``DeckNavigator._bias_test``)
    relocks: int = 0  # the filter lost on a wrong solution, started again from the deck's prior (``_relock``)
    range_relocks: int = 0  # ... of them by the range check (``_range_lost``), at the lights' position
    relocations: int = 0  # re-ties and re-locks that took the position from the frame (``_relocate``, ``_relocate_level``)


@dataclass
class DeckNavConfig:
    """Everything the deck navigator is tuned with (built from the mission config by :meth:`from_mission`)."""

    lights: np.ndarray  # (L, 3) the deck's light layout, deck frame [m] (the vehicle's calibration data)
    cam: dm.CameraGeometry
    camera: object  # PinholeCamera (intrinsics, distortion)
    imu_cov: np.ndarray  # (6, 6) per-sample accel + gyro covariance
    ship_cov: np.ndarray  # (6, 6) per-IMU-step deck accelerations (eq. 3.7-3.8)
    acquisition_sigmas: tuple[float, float]  # bearing [rad], rate [rad/s] before the hand-over
    tracking_sigmas: tuple[float, float]  # the same after it
    imu_period_s: float = 0.01
    gate: float = 13.8
    alpha: float = 0.1
    beta: float = 2.0
    kappa: float = 0.0
    blob_threshold: int = 150
    converged_bearing_rms: float = np.radians(0.2)
    gyro_dot_tau: float = 0.0
    history_s: float = 0.5
    integrity: IntegrityConfig = field(default_factory=IntegrityConfig)
    fix_min_lights: int = 1  # a frame with fewer lights used does not hold off ``integrity.stale_s`` (not a fix)
    # the range check (``_range_lost``): off beyond range_check_sigmas x sigma on range_check_frames frames in a row
    range_check_sigmas: float = 0.0
    range_check_frac: float = 0.05
    range_check_frames: int = 3
    # the tilt check (``_tilt_lost``): the deck's tilt beyond its sea state's bound + tilt_check_sigmas x the filter's
    # attitude sigma on range_check_frames frames in a row -> ``_relock``; 0: off
    tilt_check_sigmas: float = 0.0
    reject_repeated_frames: bool = False  # a frame bit-identical to the previous one is a frozen link
    # the camera's frame interval [s] (its frame counter times this is its own clock); 0: no clock check
    frame_interval_s: float = 0.0
    clock_alarm_s: float = 1.0  # health degraded this long after a camera clock step was found
    # re-acquisition after an outage: no frame fused for this long [s] (inf: never) -> the deck's attitude
    # and rates go back to their sea-state prior (level deck, deck_prior_var) before the next frame is fused
    reacquire_after_s: float = float("inf")
    deck_prior_var: np.ndarray = field(default_factory=lambda: np.full(5, np.radians(1.0) ** 2))
    # a frame's whole update is not applied when its NIS is above the chi2 1 - update_gate_alpha quantile
    # (0: no such gate; each light is gated by ``gate`` in the association anyway)
    update_gate_alpha: float = 0.0
    # gate lock-out: this many frames in a row with >= 3 blobs and every light rejected -> re-tie (0: never):
    # position / velocity sigmas added, deck attitude from its prior, the frame fused again; then the
    # accelerometer noise in Q widened by retie_accel_sigma for retie_hold_s (absorbs an accelerometer bias)
    retie_after_frames: int = 0
    retie_sigmas: tuple[float, float] = (0.05, 0.1)
    retie_accel_sigma: float = 1.0
    retie_hold_s: float = 3.0
    # the calibration's share of each bearing's error (issue 30), added to R: the camera's (misalignment, principal
    # point, focal length) as one angle [rad], and the lights' survey error [m] seen from the light's range
    calibration_bearing_sigma: float = 0.0
    light_survey_sigma: float = 0.0
    # the calibration's errors are constant, not white: after each update the position and attitude variances are
    # kept at least at what they leave (``DeckNavigator._calibration_floor``)
    calibration_floor: bool = True
    # how the calibration's constant errors enter: "inflate" (R and the floor above) or "consider" (Schmidt-Kalman
    # consider parameters: each light's survey error, sigma light_survey_sigma per axis, and the camera's
    # camera_sigmas = (misalignment [rad], focal factor, principal point / focal length); R then has no share)
    calibration_model: str = "inflate"
    camera_sigmas: tuple[float, float, float] = (0.0, 0.0, 0.0)
    time_offset_sigma: float = 0.0  # [s] the camera/IMU time offset's, a consider parameter too
    time_offset_in_r: bool = False  # the inflate model: its share of R (``DeckNavigator._time_offset_var``)
    rates_at_midpoint: bool = False  # the bearing rates predicted at their frame interval's midpoint (``_rate_gyro``)
    deck_omega2: np.ndarray | None = None  # the deck's roll and pitch as oscillators (``process_model``); None: off
    # the accelerometer bias as three more states (issue 30; 0: the thesis' 12 states): its prior sigma per axis
    # [m/s^2] and its random walk [m/s^2/sqrt(s)], from the IMU's specification
    accel_bias_sigma: float = 0.0
    accel_bias_walk: float = 0.0
    # a bias step (NIS test): the NIS of the last ``bias_test_frames`` frames' whole updates (bearings and rates,
    # before the update gate) above the chi2 1 - bias_test_alpha quantile of their summed dof -> the bias variance
    # widened to at least bias_step_sigma^2 per axis; the test then rests for bias_test_rest_s (the bias converging)
    bias_test_frames: int = 6
    bias_test_alpha: float = 1e-5
    bias_step_sigma: float = 0.2
    bias_test_rest_s: float = 1.0
    bias_test_reacquire_rest_s: float = 3.0  # ... and for this long after a re-acquisition
    # lost: the bias test would widen for the lost_widenings-th time within lost_window_s (a bias step's widening
    # brings the NIS back within a rest or two; a filter fitting the lights on a wrong solution fires it at every
    # rest for good) -> the deck attitude from its prior, position / velocity widened, the bias back to its prior
    # (``_relock``); 0: never
    lost_widenings: int = 3
    lost_window_s: float = 6.0
    # lost, too: the integrity monitor's windowed NIS test (bearings or rates over-confident) failing this many
    # times within lost_window_s (a wrong solution fails it, passes for a second, fails again: deck-static blur
    # seed 2, 62 ok steps over the HPL, errors to 1.2 m) -> ``_relock``; 0: never
    lost_nis_failures: int = 0
    # the autopilot's roll and pitch fused as the relative ones after each frame, this sigma per axis [rad]
    # (``_level``): a static, level deck's 2 deg; a moving deck's sea-state tilt spread over the frames of its
    # correlation time (``estimation/deck.sea_state_level_sigma``); 0: off (the thesis' filter)
    level_deck_sigma: float = 0.0

    @classmethod
    def from_mission(cls, sc, frame_interval_s: float) -> "DeckNavConfig":
        """From a deck scenario: ``navigation.*``, the IMU's and camera's specifications (``sensors.imu``,
        ``sensors.camera``), the light layout (``world.deck.lights_m``).

        ``frame_interval_s`` is the interval between the frames the camera delivers (the bearing-rate
        sigma is a two-frame difference). The deck's true motion (``deck.motion``, ``deck.motion_scale``)
        is not read: the ship noise is ``navigation.sea_state`` x ``navigation.motion_scale``.
        """
        f, c, imu = sc.navigation, sc.sensors.camera, sc.sensors.imu
        period = 1.0 / imu.rate_hz
        sea = f.sea_state if f.sea_state is not None else "calm"
        ship_var = dm.ship_process_noise(sea, f.motion_scale, f.ship_accel_scale, period)
        omega2 = None
        if f.deck_oscillator and sea != "calm":
            omega2, ang_var = dm.ship_oscillator(sea, f.motion_scale, f.ship_accel_scale, period)
            ship_var = np.r_[ship_var[:3], ang_var]
        imu_cov = np.diag([imu.accel_noise_mps2**2] * 3 + [imu.gyro_noise_rad_s**2] * 3) * f.imu_noise_scale**2
        imu_cov = imu_cov + np.diag([(G * np.radians(imu.attitude_noise_deg)) ** 2] * 3 + [0.0] * 3)
        sig_b = (np.radians(f.bearing_noise_deg) if f.bearing_noise_deg is not None
                 else np.hypot(c.centroid_noise_px, RENDER_CENTROID_PX) / c.focal_px)
        sig_r = (np.radians(f.bearing_rate_noise_deg_s) if f.bearing_rate_noise_deg_s is not None
                 else np.sqrt(2.0) * sig_b / frame_interval_s)
        acq = (np.radians(f.acquisition_bearing_noise_deg), np.radians(f.acquisition_rate_noise_deg_s))
        # the calibration's specified accuracy (not its draw): misalignment, principal point, focal length at a
        # typical 0.3 rad off the optical axis; the survey's sigma
        cal = (np.radians(f.calibration_bearing_deg) if f.calibration_bearing_deg is not None
               else float(np.hypot(np.hypot(np.radians(c.misalignment_deg), c.principal_point_error_px / c.focal_px),
                                   0.3 * c.focal_error_frac)))
        survey = f.light_survey_sigma_m if f.light_survey_sigma_m is not None else sc.world.deck.light_survey_error_m
        bias = imu.accel_bias_mps2 if f.estimate_accel_bias else 0.0
        cam_sig = (np.radians(c.misalignment_deg), c.focal_error_frac, c.principal_point_error_px / c.focal_px)
        return cls(calibration_bearing_sigma=cal, light_survey_sigma=survey, calibration_floor=f.calibration_floor,
                   bias_test_frames=6 if f.accel_bias_test_alpha > 0 else 0,
                   bias_test_alpha=f.accel_bias_test_alpha or 1e-5, bias_step_sigma=f.accel_bias_step_mps2,
                   calibration_model=f.calibration_model, camera_sigmas=cam_sig, time_offset_sigma=c.time_offset_s,
                   time_offset_in_r=f.time_offset_in_r, rates_at_midpoint=f.rates_at_midpoint, deck_omega2=omega2,
                   accel_bias_sigma=bias, accel_bias_walk=imu.accel_bias_walk_mps2_sqrt_s if bias > 0 else 0.0,
                   lights=np.asarray(sc.world.deck.lights_m, float),
                   cam=dm.CameraGeometry(rho=np.asarray(c.position_m, float), T_cam=c.rotation()),
                   camera=c.pinhole(), imu_cov=imu_cov, ship_cov=np.diag(ship_var),
                   acquisition_sigmas=acq, tracking_sigmas=(float(sig_b), float(sig_r)), imu_period_s=period,
                   gate=f.gate, alpha=f.alpha, beta=f.beta, kappa=f.kappa, blob_threshold=c.blob_threshold,
                   converged_bearing_rms=np.radians(f.converged_bearing_rms_deg),
                   integrity=IntegrityConfig(stale_s=f.integrity_stale_s), fix_min_lights=f.fix_min_lights,
                   range_check_sigmas=(f.range_check_sigmas if f.range_check_sigmas is not None
                                       else 0.0 if sc.world.deck.motion == "moving" else 3.3),
                   range_check_frac=f.range_check_frac,
                   tilt_check_sigmas=(f.tilt_check_sigmas if f.tilt_check_sigmas is not None
                                      else 3.0 if sc.world.deck.motion == "moving" else 0.0),
                   range_check_frames=f.range_check_frames,
                   lost_nis_failures=(f.lost_nis_failures if f.lost_nis_failures is not None
                                      else 0 if sc.world.deck.motion == "moving" else 3),
                   level_deck_sigma=(np.radians(f.level_deck_sigma_deg) if f.level_deck_sigma_deg is not None
                                     else np.radians(2.0) if sc.world.deck.motion != "moving"
                                     else dm.sea_state_level_sigma(sea, f.motion_scale, imu.attitude_noise_deg,
                                                                   frame_interval_s)),
                   reject_repeated_frames=f.reject_repeated_frames,
                   frame_interval_s=frame_interval_s if f.camera_clock_check else 0.0,
                   reacquire_after_s=f.integrity_stale_s if f.reacquire_after_outage else float("inf"),
                   deck_prior_var=dm.deck_prior_variance(sea, f.motion_scale, imu.attitude_noise_deg),
                   update_gate_alpha=f.update_gate_alpha, retie_after_frames=f.retie_after_frames,
                   retie_sigmas=(f.retie_sigma_m, f.retie_sigma_mps), retie_accel_sigma=f.retie_accel_sigma_mps2,
                   retie_hold_s=f.retie_hold_s)


#: the survey's attitude share is computed anew at most this often while the same lights are in view [s]
SURVEY_SHARE_EVERY_S = 0.1
#: the states the level-deck update measures: the relative roll and pitch
_ROLL_PITCH = np.array([3, 4])
_ROLL_PITCH.flags.writeable = False


@dataclass(frozen=True)
class DeckEstimate(Estimate):
    """The navigator's estimate at ``t``: the 12 relative states (``estimation/deck``: position 0-2, Euler
    angles 3-5, velocity 6-8, deck rates 9-11), their (12, 12) covariance, the newest IMU and autopilot
    readings the controller flies on (gyro, specific force, roll, pitch) and the filter's accelerometer-bias
    estimate (``accel_bias``, zero without the bias states) that the IMU-only holds take off the specific force."""

    frame: ClassVar[str] = "deck_body"
    position_index: ClassVar[tuple[int, ...]] = (0, 1, 2)
    velocity_index: ClassVar[tuple[int, ...] | None] = (6, 7, 8)

    t: float
    state: np.ndarray
    covariance: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    roll: float
    pitch: float
    valid: bool = True
    accel_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def position(self) -> np.ndarray:
        """The deck origin relative to the vehicle, body FRD [m] (states 0-2)."""
        return self.state[0:3]

    @property
    def velocity(self) -> np.ndarray:
        """The deck origin's velocity relative to the vehicle, body FRD [m/s] (states 6-8)."""
        return self.state[6:9]


@dataclass
class DeckHealth(Health):
    """``Health`` plus the operator's hand-over check (§5.3.1) over the last second."""

    lights_used: int = 0  # in the newest frame
    frames_1s: int = 0
    min_lights_1s: int = 0
    bearing_rms_1s: float = float("nan")  # RMS bearing innovation over the frames of the last second [rad]
    converged: bool = False
    # the HPL's parts, each the HPL of its own covariance: the filter's P and, growing with the range, the
    # calibration's constant error (``DeckNavigator._calibration_position_cov``); hpl_m, the HPL of their sum, lies
    # between the larger and hypot(hpl_noise_m, hpl_bias_per_m x range)
    hpl_noise_m: float | None = None  # (None: not split)
    hpl_bias_per_m: float = 0.0


@dataclass
class _Step:
    """One IMU prediction: the filter after it, and the input that drove it (for re-fusing a late frame)."""

    t: float
    x: np.ndarray
    P: np.ndarray
    u: dm.ImuInput | None
    fused: list = field(default_factory=list)  # (bearings, rates, gyro) of the frames fused at t


class DeckNavigator(CommandDispatch):
    #: predict through ``estimation/kernels``' compiled eq. 3.1-3.5 and 3.8 where ``visnav.jit`` has numba (the
    #: readable ``estimation/deck.process_model`` / ``process_noise`` otherwise, or with ``kernel = False``; the
    #: tests hold them equal at 1e-12)
    kernel: ClassVar[bool] = True

    def __init__(self, config: DeckNavConfig, recorder=None):
        self.cfg = config
        self.lights = np.asarray(config.lights, float)
        b = self.lights - self.lights.mean(axis=0)
        self._spread = float((b * b).sum())  # S = sum |b_i - b_mean|^2 of the layout (the survey's tilt, 1 / S)
        self._survey_att = np.zeros((3, 3))  # the survey's share of the attitude's error (``_survey_attitude``)
        self._survey_att_add = np.zeros((3, 3))  # what it adds to P's attitude block in ``covariance``
        self._survey_key: tuple = ((), -np.inf)  # (lights, time) the share was last computed for
        self.cam = config.cam  # (with consider parameters below: the UKF's; the geometric solvers take cfg.cam, 12 states)
        c = config
        self._bias_on = c.accel_bias_sigma > 0.0
        # the calibration's consider parameters (Schmidt-Kalman) after the 12 states and the bias
        cam_sig = np.asarray(c.camera_sigmas, float)
        self._consider = c.calibration_model == "consider" and (c.light_survey_sigma > 0 or bool(cam_sig.any())
                                                                or c.time_offset_sigma > 0)
        var = [np.full(3, c.accel_bias_sigma**2)] if self._bias_on else []
        self._consider_slice = None
        if self._consider:
            k = dm.ConsiderLayout(dm.N_STATE + 3 * self._bias_on, len(self.lights))
            self.cam = replace(config.cam, consider=k)
            self._consider_slice = slice(k.start, k.start + k.size)
            var += [np.full(3 * k.n_lights, c.light_survey_sigma**2), np.full(3, cam_sig[0] ** 2),
                    [cam_sig[1] ** 2], np.full(2, cam_sig[2] ** 2), [c.time_offset_sigma**2]]
        self._augmented_var = np.concatenate(var) if var else np.zeros(0)
        self.imu_cov, self.ship_cov = config.imu_cov, config.ship_cov
        self._compiled = self.kernel and ek.njit is not None
        self._process_model = ek.deck_process_model if self._compiled else dm.process_model
        if config.deck_omega2 is not None:  # (the readable model: the kernel has no oscillator)
            self._process_model = partial(dm.process_model, deck_omega2=np.asarray(config.deck_omega2, float))
        self.gate = config.gate
        self.tracker = BearingTracker(config.camera, threshold=config.blob_threshold)
        self.recorder = recorder
        self.stats = DeckNavStats()
        self.integrity = IntegrityMonitor(config.integrity)
        self._frozen = FrozenFrameCheck()  # the previous frame's image (the frozen-link check)
        self.ukf: UnscentedKalmanFilter | None = None
        self.bearing_var, self.rate_var = (s**2 for s in config.acquisition_sigmas)
        self._t: float | None = None  # time of the filter's state
        self._t_imu: float | None = None  # time of the newest IMU sample
        self._gyro: np.ndarray | None = None
        self._gyro_dot = np.zeros(3)
        self._u: dm.ImuInput | None = None
        self._accel = np.zeros(3)
        self._rp: np.ndarray | None = None  # roll, pitch of the newest AttitudeSample
        self.last_gyro = np.zeros(3)
        self._gyro_log: deque = deque(maxlen=64)  # (t, gyro) of the newest IMU samples (``_rate_gyro``)
        self.last_nis, self.last_dof = float("nan"), 0
        self.last_bearing_rms = float("nan")  # RMS bearing innovation of the last update [rad]
        self._calibration_rms = 0.0  # the calibration's RMS share of the last update's bearings [rad]
        self._hist: deque[_Step] = deque(maxlen=max(2, int(np.ceil(config.history_s / config.imu_period_s)) + 1))
        self._frames: deque = deque()  # (t, lights used, bearing rms) of the recent frames
        self.clock_offset_s = 0.0  # the camera stamps' offset found from the frame counter (subtracted)
        self._cam_prev: tuple[int, float] | None = None  # (frame counter, corrected stamp) of the previous frame
        self._clock_alarm: tuple[float, str] | None = None  # (time, reason) of the newest clock step
        self._t_fused: float | None = None  # stamp of the newest frame that was fused
        self._t_reacq = -np.inf  # time of the newest re-acquisition
        self._gates: dict[int, float] = {}  # the update gate's chi2 quantile per dof
        self._locked = 0  # frames in a row with >= 3 blobs and every light rejected
        self._retying = False  # fusing a frame again after a re-tie (it cannot re-tie again)
        self._widen_until = -np.inf  # accelerometer noise widened in Q until then (after a re-tie)
        self._bias_rest_until = -np.inf  # the bias test rests until then (after a widening)
        self._nis_window: deque = deque(maxlen=max(1, config.bias_test_frames))  # (NIS, dof) of whole updates
        self._widened: deque = deque()  # times of the bias test's widenings (``lost``)
        self._nis_failures: deque = deque()  # times the windowed NIS test started failing (``lost_nis_failures``)
        self._nis_failing = False
        self._range_off = 0  # frames in a row the range check failed (``_range_lost``)
        self._blobs: np.ndarray | None = None  # the bearings of the frame being fused (``_relocate_level``)
        self._acquiring = False  # a static start waiting for its first frame of every light (``_acquire_level``)
        self._tilt_off = 0  # frames in a row the tilt check failed (``_tilt_lost``)

    # --- the interface ---------------------------------------------------------------------
    def initialize(self, init: NavInit) -> None:
        """Start from ``init.state`` / ``init.covariance`` (sensor R), or from eq. 5.12-5.17 (acquisition R)."""
        if init.state is not None:
            if init.covariance is None:
                raise ValueError("a deck NavInit with a state needs its covariance")
            self._start(init.t, np.asarray(init.state, float), np.asarray(init.covariance, float),
                        self.cfg.tracking_sigmas, init.source)
        else:
            x0, P0 = dm.initial_state_static()
            self._start(init.t, x0, P0, self.cfg.acquisition_sigmas, init.source)
            self._acquiring = True  # (the first frame of every light places it: ``_acquire_level``)

    def update(self, m) -> None:
        if isinstance(m, ImuSample):
            self._imu(m)
        elif isinstance(m, AttitudeSample):
            self._attitude(m)
        elif isinstance(m, Frame):
            self._frame(m)
        else:
            raise TypeError(f"DeckNavigator takes ImuSample, AttitudeSample or Frame, not {type(m).__name__}")

    def estimate(self, t: float) -> DeckEstimate:
        if self.ukf is None:
            return DeckEstimate(t=t, state=np.full(12, np.nan), covariance=np.full((12, 12), np.nan),
                                gyro=self.last_gyro.copy(), accel=self._accel.copy(), roll=np.nan, pitch=np.nan,
                                valid=False)
        n = dm.N_STATE
        x, P = self.ukf.x.copy(), self.covariance()[:n, :n]
        dt = t - self._t
        if dt > 1e-9 and self._u is not None:  # propagate the mean with the newest input (zero-order hold)
            x = self.ukf.fx(x[None, :], dt, self._u)[0]
            P = P + dm.process_noise(x, dt, self._u, self.imu_cov, self.ship_cov)
        rp = self._rp if self._rp is not None else np.full(2, np.nan)
        # the bias estimate the IMU-only holds take off the specific force: at most BIAS_CLIP_SIGMAS of its prior (an
        # unconverged filter's estimate swung the level hover to 3 m/s, deck-static seed 4)
        lim = BIAS_CLIP_SIGMAS * self.cfg.accel_bias_sigma
        bias = np.clip(x[dm.BIAS], -lim, lim) if self._bias_on else np.zeros(3)
        return DeckEstimate(t=t, state=x[:n], covariance=P, gyro=self.last_gyro.copy(), accel=self._accel.copy(),
                            roll=float(rp[0]), pitch=float(rp[1]), accel_bias=bias)

    def health(self, t: float) -> DeckHealth:
        recent = [f for f in self._frames if f[0] > t - 1.0]
        used = [f[1] for f in recent]
        rms = np.array([f[2] for f in recent], float)
        rms_1s = float("nan")
        if np.isfinite(rms).any():  # np.nanmean's own steps (NaN -> 0, sum, / count): its value, not its overhead
            sq = rms**2
            gone = np.isnan(sq)
            sq[gone] = 0.0
            rms_1s = float(np.sqrt(sq.sum() / (sq.size - int(gone.sum()))))
        # converged: the innovations no larger than the calibration's share of them allows
        limit = float(np.hypot(self.cfg.converged_bearing_rms, self._calibration_rms))
        conv = (len(recent) >= 5 and min(used) >= 3 and bool(rms_1s <= limit))
        h = DeckHealth(source="camera", tracking=conv, rejected_samples=self.stats.imu_dropped,
                       lights_used=self.stats.lights_used_last, frames_1s=len(recent),
                       min_lights_1s=min(used) if used else 0, bearing_rms_1s=rms_1s, converged=conv)
        P_h = C_h = None
        if self.ukf is not None:  # the calibration's constant error as a covariance of its own (not in P: no gain)
            C_h = self._calibration_position_cov()[0:2, 0:2]
            P_h = self.ukf.P[0:2, 0:2] + C_h
        a = self.integrity.assess(t, P_h)
        if C_h is not None and math.isfinite(a["hpl_m"]):
            p, k2 = a["hpl_probability"], a["consistency_k2"]
            rng = float(np.linalg.norm(self.ukf.x[dm.POS]))
            h.hpl_noise_m = horizontal_protection_level(self.ukf.P[0:2, 0:2], p, k2)
            h.hpl_bias_per_m = horizontal_protection_level(C_h, p, k2) / rng if rng > 0.0 else 0.0
        else:
            h.hpl_noise_m = a["hpl_m"]
        if (self._clock_alarm is not None and a["integrity"] == "ok"
                and t - self._clock_alarm[0] <= self.cfg.clock_alarm_s):
            a["integrity"], a["integrity_reason"] = "degraded", self._clock_alarm[1]
        return h.set_integrity(a)

    def _cmd_restart(self, t: float, yaw_deg: float = 0.0) -> None:
        """The operator's reset (Fig. 5.7): eq. 5.12-5.17 again, relative yaw ``yaw_deg``, acquisition R."""
        x0, P0 = dm.initial_state_static()
        x0[5] = np.radians(yaw_deg)
        self._start(t, x0, P0, self.cfg.acquisition_sigmas, f"restart from relative yaw {yaw_deg:.0f} deg")

    def _cmd_track(self, t: float) -> None:
        """Hand-over: the filter has converged; from now on R is the camera's own noise. The bias test rests for
        ``bias_test_rest_s`` (its NIS jumps with the smaller R: a widening there set the approach of deck-static
        seed 5 swinging)."""
        self.bearing_var, self.rate_var = (s**2 for s in self.cfg.tracking_sigmas)
        self._nis_window.clear()
        self._bias_rest_until = t + self.cfg.bias_test_rest_s

    # --- filter ----------------------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        return self.ukf.x

    @property
    def P(self) -> np.ndarray:
        return self.ukf.P

    def _log_init(self, t: float, x, var, source: str) -> None:
        """A (re)start in the ``nav_init`` stream: the 12 relative states and their sigmas (the bias states are
        not part of the stream's order)."""
        if self.recorder is not None:
            n = dm.N_STATE
            self.recorder("nav_init", t, x0=np.array(x[:n], float), sigma=np.sqrt(np.asarray(var, float)[:n]),
                          source=source)

    def _augment(self, x0, P0):
        """The 12 relative states and their covariance with the accelerometer bias (zero, its prior sigma
        ``accel_bias_sigma`` per axis) and the calibration's consider parameters (zero, their specified sigmas)
        appended, uncorrelated, when the filter has them; unchanged otherwise."""
        x0, P0 = np.asarray(x0, float), np.asarray(P0, float)
        var = self._augmented_var
        if var.size == 0 or x0.size > dm.N_STATE:
            return x0, P0
        n, m = dm.N_STATE, dm.N_STATE + var.size
        P = np.zeros((m, m))
        P[:n, :n] = P0
        P[n:, n:] = np.diag(var)
        return np.r_[x0, np.zeros(var.size)], P

    def _start(self, t, x0, P0, sigmas, source) -> None:
        self._widened.clear()
        x0, P0 = self._augment(x0, P0)
        if self.ukf is None:
            c = self.cfg
            self.ukf = UnscentedKalmanFilter(x0, P0, partial(self._process_model, bias=self._bias_on), alpha=c.alpha, beta=c.beta, kappa=c.kappa,
                                             residual_x=dm.residual_x, state_add=dm.state_add)
        else:
            self.ukf.x, self.ukf.P = np.array(x0, float), np.array(P0, float)
        self.bearing_var, self.rate_var = (s**2 for s in sigmas)
        if self._t is None or t > self._t:
            self._t = t
        self._t_fused = None
        self._hist.clear()
        self._hist.append(_Step(self._t, self.ukf.x.copy(), self.ukf.P.copy(), None))
        if self.recorder is not None:
            self._log_init(t, x0, np.diag(P0), source)

    def covariance(self) -> np.ndarray:
        """Covariance of the estimate including the gyro's white noise in the velocity (what NEES should use).

        The numerical angular acceleration telescopes in the velocity (``sum (w_k - w_k-1) x r``), so the
        estimate carries ``-n x r`` with ``n`` the newest gyro sample's noise: a white error that the
        process noise cannot hold (it does not accumulate) and that ``P`` therefore lacks. It adds
        ``[r]x Sigma_gyro [r]x^T`` to the velocity block (``v = (v + w x r) - w x r``, d/dw = ``[r]x``), and the
        calibration's constant share to the position block (``_calibration_position_cov``), which P lacks too.
        """
        r0, r1, r2 = self.ukf.x[0:3].tolist()
        S = np.array([[0.0, -r2, r1], [r2, 0.0, -r0], [-r1, r0, 0.0]])
        P = self.ukf.P.copy()
        P[6:9, 6:9] += S @ self.imu_cov[3:6, 3:6] @ S.T
        P[0:3, 0:3] += self._calibration_position_cov()
        P[3:6, 3:6] += self._survey_att_add
        return P

    def _survey_attitude(self, idx) -> None:
        """The survey's share of the relative attitude's error, reported with the estimate (``covariance``) but
        given no gain, as the calibration's position share: what a fit of the lights ``idx`` seen from here is
        tilted by a constant survey error (``estimation/deck.survey_pose_covariance``: 6 deg per axis at 1.4 m for
        the 1 cm survey of eq. 5.10's layout, where the attitude floor's plane through the lights,
        ``_calibration_floor``, gives 4 deg), with what the level update says of the roll and pitch on every frame
        as a second look at them (information added, ``level_deck_sigma`` per axis; an approximation of the fit
        with both): a static deck's 2 deg holds them, a moving deck's 35 deg per frame hardly does. Kept from the
        last frame of three lights or more. Measured: moving seed 7's approach was 10-22 deg off against a reported
        4.2 deg; over 20 moving seeds the attitude's error is 0.7-0.8 of the sigma now reported (issue 30, round
        17)."""
        c = self.cfg
        if self._consider or c.light_survey_sigma == 0.0:
            return
        # the geometry moves little in a tenth of a second: the share anew when the lights in view change or 0.1 s on
        key = tuple(int(i) for i in idx)
        if key != self._survey_key[0] or self._t - self._survey_key[1] >= SURVEY_SHARE_EVERY_S:
            self._survey_key = (key, self._t)
            S = dm.survey_pose_covariance(self.ukf.x[:dm.N_STATE], self.lights, self.cam, idx, c.light_survey_sigma)
            if S is not None:  # (fewer than three lights fix no pose: the last share stands)
                info = np.linalg.inv(S[3:6, 3:6])
                if c.level_deck_sigma > 0.0:
                    info[0:2, 0:2] += np.eye(2) / c.level_deck_sigma**2
                self._survey_att = np.linalg.inv(info)
        # what the share adds to P's attitude block: the positive part of share - P at this frame, reported until
        # the next one (P only grows in between: then a little more than the share, never less)
        lam, V = np.linalg.eigh(self._survey_att - self.ukf.P[3:6, 3:6])
        self._survey_att_add = (V * np.maximum(lam, 0.0)) @ V.T

    def _calibration_position_cov(self) -> np.ndarray:
        """The calibration's constant share of the relative position's error that the filter's P leaves out (the
        inflate model; zero with the consider model, whose P has it, or an ideal calibration), reported with the
        estimate but given no gain:

            C = (s_m r)^2 diag(1, 1, 0) + r^2 (sigma_survey^2 / S + sigma_f^2) u u^T,   u = p / r,

        the survey's tilt of the fitted deck plane moving the origin sideways (``_survey_sigma_per_m`` s_m, as in
        the protection level) and the error of the layout's apparent size along the line of sight: a light off by
        sigma_survey scales the layout by sigma_survey / sqrt(S) (S = sum |b_i - b_mean|^2; the similarity fit's
        share: cv2.solvePnP's six degrees of freedom measure 1.1-1.2x it looking down the layout's normal), the
        focal length's error sigma_f by as much; both scale the range. The floor (``_calibration_floor``) holds the
        across-sight share in P. Measured: the range share was the static deck's largest NEES term (z error 7 cm
        at 1.5-2 m against a 2 cm sigma)."""
        c = self.cfg
        p = self.ukf.x[dm.POS]
        r2 = float(p @ p)
        if self._consider or r2 == 0.0:
            return np.zeros((3, 3))
        C = (c.light_survey_sigma**2 / self._spread + c.camera_sigmas[1] ** 2) * np.outer(p, p)  # r^2 (..) u u^T
        side = self._survey_sigma_per_m() ** 2 * r2  # (s_m r)^2 diag(1, 1, 0)
        C[0, 0] += side
        C[1, 1] += side
        return C

    def _attitude(self, m: AttitudeSample) -> None:
        rp = np.asarray(m.euler, float)[:2]
        if np.isfinite(rp).all():
            self._rp = rp

    def _drop_imu(self, reason: str, t: float) -> None:
        self.stats.imu_dropped += 1
        if self.recorder is not None:
            self.recorder("imu_dropped", t, reason=reason)

    def _imu(self, m: ImuSample) -> None:
        t = float(m.t)
        accel, gyro = np.asarray(m.accel, float), np.asarray(m.gyro, float)
        if not (math.isfinite(t) and np.isfinite(accel).all() and np.isfinite(gyro).all()):
            return self._drop_imu("not finite", t)
        if self._rp is None:
            return self._drop_imu("no attitude yet", t)
        if self._t_imu is None:
            self._t_imu, self._gyro, self.last_gyro, self._accel = t, gyro, gyro, accel
            self._gyro_log.append((t, gyro))
            self.stats.imu_samples += 1
            return None
        dt_imu = t - self._t_imu
        if dt_imu <= 0:
            return self._drop_imu("out of order", t)
        raw = (gyro - self._gyro) / dt_imu
        a = dt_imu / (self.cfg.gyro_dot_tau + dt_imu)
        self._gyro_dot = self._gyro_dot + a * (raw - self._gyro_dot)
        gb = euler_to_dcm3(*self._rp.tolist(), 0.0).T @ _GRAVITY_NED  # (euler_to_dcm's one-vector path)
        u = dm.ImuInput(accel=accel, gyro=gyro, gyro_dot=self._gyro_dot, gravity_body=gb)
        prev_accel, prev_gyro = self._accel, self._gyro
        self._t_imu, self._gyro, self.last_gyro, self._accel, self._u = t, gyro, gyro, accel, u
        self._gyro_log.append((t, gyro))
        self.stats.imu_samples += 1
        if self.ukf is None:
            return None
        if t > self._t:
            # a gap of lost samples (issue #18 imu_drop): the forces and rates over it are the mean of the
            # samples at its ends, not the newest alone (a one-sided hold biases the attitude in a manoeuvre)
            uu = u if dt_imu < 1.5 * self.cfg.imu_period_s else replace(
                u, accel=0.5 * (accel + prev_accel), gyro=0.5 * (gyro + prev_gyro))
            self._predict(t - self._t, uu)
            self._t = t
            self._hist.append(_Step(t, self.ukf.x.copy(), self.ukf.P.copy(), uu))
        return None

    def _predict(self, dt: float, u: dm.ImuInput) -> None:
        """One prediction over ``dt``; a part of an IMU interval takes the noise of a continuous process (Q ~ dt)."""
        scale = 1.0 if abs(dt - self.cfg.imu_period_s) < 1e-9 else self.cfg.imu_period_s / dt
        imu_cov = self.imu_cov
        if self._t is not None and self._t < self._widen_until:  # after a re-tie: the velocity follows the lights
            imu_cov = imu_cov + np.diag([self.cfg.retie_accel_sigma**2] * 3 + [0.0] * 3)
        imu_cov, ship_cov = (imu_cov * scale, self.ship_cov * scale) if scale != 1.0 else (imu_cov, self.ship_cov)
        n = self.ukf.n
        if self._compiled:  # eq. 3.8 in the (n, n) matrix, zero beyond the 12 states
            Q = ek.deck_process_noise(self.ukf.x, dt, u, imu_cov, ship_cov, n)
        else:
            Q = np.zeros((n, n))
            Q[:dm.N_STATE, :dm.N_STATE] = dm.process_noise(self.ukf.x, dt, u, imu_cov, ship_cov)
        if self._bias_on:  # the bias's random walk; the consider parameters are constant
            Q[dm.BIAS, dm.BIAS] += np.eye(3) * self.cfg.accel_bias_walk**2 * dt
        try:
            self.ukf.predict(dt, Q, u=u)
        except np.linalg.LinAlgError as exc:
            self._diverged(str(exc))
            self.ukf.predict(dt, Q, u=u)

    def _diverged(self, why: str) -> None:
        """The covariance is no longer positive definite: restart the filter where it is, honestly unsure.
        The deck's attitude and rates from their sea-state prior (as after an outage), position and velocity
        kept with at least ``DIVERGED_SIGMA_M`` / ``DIVERGED_SIGMA_MPS`` per axis (their variances otherwise),
        no correlation: the protection level is then far above any landing's, the mission holds until frames
        have brought it down. Logged in ``nav_init``, counted in ``stats.divergences``."""
        x, P = self.ukf.x.copy(), self.ukf.P
        n = len(x)
        d = np.abs(np.diag(P)) if np.all(np.isfinite(P)) else np.zeros(n)
        if not np.all(np.isfinite(x)):
            x = self._hist[0].x.copy() if self._hist else np.zeros(n)
        rp = self._rp if self._rp is not None else np.zeros(2)
        var = np.asarray(self.cfg.deck_prior_var, float)
        x[3:5], x[9:12] = rp, 0.0
        dd = np.maximum(d, np.r_[[DIVERGED_SIGMA_M**2] * 3, np.zeros(3), [DIVERGED_SIGMA_MPS**2] * 3, np.zeros(n - 9)])
        dd[[3, 4, 9, 10, 11]] = var
        dd[5] = max(dd[5], np.radians(10.0) ** 2)
        self.ukf.x, self.ukf.P = x, np.diag(dd)
        self.stats.divergences += 1
        if self.recorder is not None:
            self._log_init(self._t if self._t is not None else 0.0, x, dd,
                           f"filter restarted where it was: {why}")

    def _frame(self, f: Frame) -> None:
        self.stats.frames += 1
        if self.ukf is None:
            self.stats.frames_dropped += 1
            return
        t = self._camera_time(f)
        # a live camera's noise never repeats an image bit for bit: a repeat is a frozen link, not a view
        # (issue #18); nothing is fused, so the navigator goes stale -> unusable as with no frame at all
        same = self._frozen.repeated(f.image) and self.cfg.reject_repeated_frames
        if same:
            self.stats.frames_frozen += 1
            self.integrity.record(t, "bearing", float("nan"), 0, False)
            return
        uv = find_blobs(f.image, self.tracker.threshold)
        gyro, lag = self.last_gyro, 0.0  # (the thesis: the rates are the frame's own, w_h the newest gyro sample)
        t0 = self.tracker.previous_time
        if self.cfg.rates_at_midpoint and t0 is not None and t > t0:  # the rates are differences over [t0, t]
            gyro, lag = self._rate_gyro(t0, t), 0.5 * (t - t0)
        bf = self.tracker.from_pixels(t, uv)
        if (self._t_fused is not None and t - max(self._t_fused, self._t_reacq) > self.cfg.reacquire_after_s
                and np.isfinite(bf.bearings).all(axis=1).any()):
            self._reacquire(t)
            bf = replace(bf, rates=np.full_like(np.asarray(bf.rates, float), np.nan))  # rates across the gap: none
        if t >= self._t - 1e-12:
            if t > self._t + 1e-12 and self._u is not None:  # newer than the IMU: predict to the frame
                self._predict(t - self._t, self._u)
                self._t = t
                self._hist.append(_Step(t, self.ukf.x.copy(), self.ukf.P.copy(), self._u))
            used, rejected = self._correct(bf.bearings, bf.rates, gyro, rp=self._rp, lag=lag)
            last = self._hist[-1] if self._hist else None
            if last is not None and abs(last.t - self._t) < 1e-12:
                last.x, last.P = self.ukf.x.copy(), self.ukf.P.copy()
                last.fused.append((bf.bearings, bf.rates, gyro, self._rp, lag))
        else:
            res = self._fuse_late(t, bf, gyro, lag)
            if res is None:
                self.stats.frames_dropped += 1
                used, rejected = 0, 0
            else:
                used, rejected = res
        if used:
            self._t_fused = t if self._t_fused is None else max(self._t_fused, t)
        self._frames.append((t, used, self.last_bearing_rms if used else float("nan")))
        while self._frames and self._frames[0][0] < t - 2.0:
            self._frames.popleft()
        if self.recorder is not None:
            self.recorder("camera", t, blobs=len(bf.bearings), lights_used=used, rejected=rejected,
                          nis=self.last_nis if used else float("nan"), dof=self.last_dof if used else 0,
                          bearing_rms=self.last_bearing_rms if used else float("nan"))

    def _camera_time(self, f: Frame) -> float:
        """The frame's time on the IMU's clock: its stamp minus the camera clock's offset found so far.

        A camera counts its frames and takes them at its own fixed interval, so between two frames the stamps
        must advance by (counter difference) x ``frame_interval_s``. A step of more than half an interval is a
        jump of the camera's clock, not of the scene: the offset takes it up and the frame (and every later
        one) is fused at its corrected stamp (late frames through the prediction history), the step is
        logged (``camera_clock``) and ``health`` says ``degraded`` with the reason for ``clock_alarm_s``.
        """
        t_raw = float(f.t)
        T = self.cfg.frame_interval_s
        idx = int(getattr(f, "index", -1))
        t = t_raw - self.clock_offset_s
        prev = self._cam_prev
        if T > 0 and prev is not None and 0 <= idx < prev[0] and np.isfinite(t_raw):
            # an older frame after a newer one (stamped before the jump back, delivered after it): it
            # belongs to the previous offset; put it where its counter says, the offset stays
            step = t - (prev[1] - (prev[0] - idx) * T)
            return t - step if abs(step) > 0.5 * T else t
        self._cam_prev = None
        if T > 0 and prev is not None and idx > prev[0] and np.isfinite(t_raw):
            step = t - (prev[1] + (idx - prev[0]) * T)
            if abs(step) > 0.5 * T:
                self.clock_offset_s += step
                t = t_raw - self.clock_offset_s
                self.stats.clock_steps += 1
                why = (f"camera clock stepped {step:+.3f} s against its frame counter (offset now "
                       f"{self.clock_offset_s:+.3f} s): frames re-stamped")
                self._clock_alarm = (t, why)
                if self.recorder is not None:
                    self.recorder("camera_clock", t, step=step, offset=self.clock_offset_s, stamp=t_raw)
        if idx >= 0 and np.isfinite(t):
            self._cam_prev = (idx, t)
        return t

    def _reacquire(self, t: float) -> None:
        """After an outage (no frame fused for ``reacquire_after_s``): the deck's relative roll and pitch go
        back to a level deck's (the autopilot's roll and pitch), its rates to zero, with the sea state's
        variances and no correlation (``deck_prior_var``); position, velocity and relative yaw keep what the
        IMU carried them to. Applied to the stored history too (a late frame rewinds into it)."""
        rp = self._rp if self._rp is not None else np.zeros(2)
        var = np.asarray(self.cfg.deck_prior_var, float)
        ii = np.array([3, 4, 9, 10, 11])

        def reset(x, P):
            x, P = x.copy(), P.copy()
            x[3:5], x[9:12] = rp, 0.0
            P[ii, :], P[:, ii] = 0.0, 0.0
            P[ii, ii] = var
            return x, P

        self.ukf.x, self.ukf.P = reset(self.ukf.x, self.ukf.P)
        for s in self._hist:
            s.x, s.P = reset(s.x, s.P)
        self.stats.reacquisitions += 1
        self._t_reacq = t
        self._nis_window.clear()  # the deck attitude re-converging is not a bias step (_bias_test)
        self._bias_rest_until = t + self.cfg.bias_test_reacquire_rest_s
        if self.recorder is not None:
            self._log_init(t, self.ukf.x, np.diag(self.ukf.P),
                           f"re-acquisition after {t - self._t_fused:.2f} s without a fused frame: "
                           "deck attitude and rates from the sea-state prior")

    def _rate_gyro(self, t0: float, t: float) -> np.ndarray:
        """The vehicle's rotation rate at the midpoint of the frame interval [t0, t] (the gyro's trapezoidal mean
        over it): the tracker's bearing rates are backward differences over that interval
        (``vision/blobs.BearingTracker``), the rates of its midpoint, half an interval (17 ms at 30 frames/s) before
        the frame. So the rates are predicted there: eq. 2.27-2.29 at the state taken back half an interval by the
        process model (``_correct_checked``'s ``rates_at``) with this rate as w_h. Predicted at the frame with its
        newest gyro sample they are 0.08 rad/s off in a 5 rad/s^2 swing (the rates' sigma: 0.03), at the midpoint
        2 mrad/s (test). The newest sample when fewer than two samples cover the interval."""
        ts = [s for s in self._gyro_log if t0 - 1e-9 <= s[0] <= t + 1e-9]
        if len(ts) < 2:
            return self.last_gyro
        tt = np.array([s[0] for s in ts])
        g = np.array([s[1] for s in ts])
        return (0.5 * (g[1:] + g[:-1]) * np.diff(tt)[:, None]).sum(axis=0) / (tt[-1] - tt[0])

    def _fuse_late(self, t: float, bf, gyro=None, lag: float = 0.0):
        """Rewind to the stored step before ``t``, fuse there, replay the IMU inputs since. None: too old."""
        steps = list(self._hist)
        j = max((i for i, s in enumerate(steps) if s.t <= t + 1e-12), default=None)
        if j is None:
            return None
        base = steps[j]
        self.ukf.x, self.ukf.P = base.x.copy(), base.P.copy()
        later = steps[j + 1:]
        u = later[0].u if later else self._u
        if t > base.t + 1e-12 and u is not None:
            self._predict(t - base.t, u)
        if gyro is None:
            gyro = u.gyro if u is not None else self.last_gyro
        res = self._correct(bf.bearings, bf.rates, gyro, rp=self._rp, lag=lag)
        t_prev = max(t, base.t)
        new = steps[:j]
        if t > base.t + 1e-12:
            new += [base, _Step(t, self.ukf.x.copy(), self.ukf.P.copy(), u, [(bf.bearings, bf.rates, gyro, self._rp, lag)])]
        else:
            new.append(_Step(base.t, self.ukf.x.copy(), self.ukf.P.copy(), base.u,
                             base.fused + [(bf.bearings, bf.rates, gyro, self._rp, lag)]))
        for s in later:  # replay the IMU inputs and the frames fused since
            self._predict(s.t - t_prev, s.u)
            for fb in s.fused:
                self._correct(*fb[:3], replay=True, rp=fb[3], lag=fb[4])
            t_prev = s.t
            new.append(_Step(s.t, self.ukf.x.copy(), self.ukf.P.copy(), s.u, s.fused))
        self._hist = deque(new, maxlen=self._hist.maxlen)
        return res

    def _max_nis(self, dof: int) -> float | None:
        a = self.cfg.update_gate_alpha
        if a <= 0:
            return None
        q = self._gates.get(dof)
        if q is None:
            q = self._gates[dof] = float(chi2.isf(a, dof))
        return q

    def expected_bearings(self):
        """Predicted bearings (L, 2) of every light and their covariances (L, 2, 2) with R."""
        return self._expected()[:2]

    def _expected(self):
        """``expected_bearings`` and the sigma points and light vectors it was computed from (the update of
        the same (x, P) takes them instead of drawing them again: the same arrays)."""
        sig = self.ukf.sigma_points()
        vec = dm.light_vectors(sig, self.lights, self.cam)
        L = len(self.lights)
        cal = np.zeros(L) if self._consider else np.broadcast_to(self._calibration_var(vec), (L,))
        R = np.diag(np.repeat(self.bearing_var + cal, 2))
        zp, S, _, _ = self.ukf.predict_measurement(R, dm.bearings_only, sigmas=sig, lights=self.lights, cam=self.cam,
                                                   vectors=vec)
        j = np.arange(L)
        blocks = S.reshape(L, 2, L, 2)[j, :, j, :]  # the 2x2 diagonal blocks (L, 2, 2), a fresh array
        return zp.reshape(L, 2), blocks, sig, vec

    def _time_offset_var(self, rates: np.ndarray, gyro) -> tuple[np.ndarray | float, float]:
        """The camera/IMU time offset's share of R (the inflate model; the consider model carries the offset as a
        parameter): a frame whose stamp is off by dt shows each bearing where it was dt earlier, b - b' dt, and
        each bearing rate as b' - b'' dt. So sigma_dt^2 b'^2 per bearing component (its measured rate; the gyro's
        |w| for a light without one) and sigma_dt^2 |w'|^2 per rate component (b'' = w' x b + ..., the angular
        acceleration's part, the IMU's ``gyro_dot``). Only with ``time_offset_in_r`` (``navigation.time_offset_in_r``).
        Measured (docs/results-deck.md, issue 30 rounds 16-18): without it the rate NIS fails its window test
        whenever the vehicle swings (10 ms offset, |w'| 5 rad/s^2: 0.05 rad/s against the rates' 0.03 sigma). With
        the rates predicted at the frame it cost one moving fault run of 100 (brightness seed 7, 0.61 m off the
        plate); with them at their interval's midpoint (``_rate_gyro``, round 18) no fault run is unsafe, and it is
        on by default (``navigation.time_offset_in_r``)."""
        s = self.cfg.time_offset_sigma
        if s == 0.0 or self._consider or not self.cfg.time_offset_in_r:
            return 0.0, 0.0
        rb = np.where(np.isfinite(rates), rates, float(np.linalg.norm(gyro)))
        return (s * rb).ravel() ** 2, s * s * float(self._gyro_dot @ self._gyro_dot)

    def _calibration_var(self, vec) -> np.ndarray | float:
        """The calibration's variance of each light's bearings (L,) at the mean (sigma point 0 of ``vec``):
        sigma_cam^2 + (sigma_survey / range)^2 (0.0 with an ideal calibration)."""
        c = self.cfg
        if c.calibration_bearing_sigma == 0.0 and c.light_survey_sigma == 0.0:
            return 0.0
        rng = np.linalg.norm(vec[0][0], axis=-1)
        return c.calibration_bearing_sigma**2 + (c.light_survey_sigma / np.maximum(rng, 0.05)) ** 2

    def _survey_sigma_per_m(self) -> float:
        """The horizontal error per metre of range (1 sigma per axis) that the LED survey's constant error leaves in
        the relative position: the deck plane fitted to L lights each off by sigma_survey is tilted by
        sqrt(2 / S) sigma_survey (S = sum |b_i - b_mean|^2, the attitude floor of ``_calibration_floor``), which at
        range r moves the deck origin seen from the vehicle by r times that (its apparent size, the range, by as
        much). A bias, not noise: no number of frames averages it out, so it is in the protection level (a
        covariance of its own beside P) and not in the filter's gain. 0 with the consider model (P has it) or
        an ideal survey. Measured: the 1 cm survey's draws put the fault-free horizontal error at up to 14 % of
        the range (deck-moving seeds 5 and 8), 4-5x the covariance's HPL at 1.2 m; 0.071 per m here, x 3.7 at 99.9 %.
        Not fused with the level update's tilt (which would give 0.018 per m over a static deck): the NEES of the
        static deck came nearer 12, but its fault campaign went 0.2-0.5 % over the HPL while ok (accelerometer bias,
        IMU drops; issue 30, round 16)."""
        c = self.cfg
        if self._consider or c.light_survey_sigma == 0.0:
            return 0.0
        return c.light_survey_sigma * math.sqrt(2.0 / self._spread)

    def _calibration_floor(self) -> None:
        """Keep the position and attitude variances at least at the calibration's share (a constant error that
        no number of frames averages out): per axis (range x sigma_cam)^2 + sigma_survey^2 / L for the position,
        sigma_cam^2 + 2 sigma_survey^2 / S for the attitude (the tilt of a plane fitted to L points each off by
        sigma_survey), S = sum |b_i - b_mean|^2. Only variances below the floor grow (P stays positive definite);
        an approximation of a consider filter. It leaves out the range error of the layout's apparent size
        (range x sigma_survey / sqrt(S), 7 cm at 1.5 m): with it the protection level stays above the mission's
        commit limits: deck-static seed 1 did not land and deck-moving seed 1 crashed (not analysed further)."""
        c = self.cfg
        if not c.calibration_floor or self._consider or (c.calibration_bearing_sigma == 0.0
                                                         and c.light_survey_sigma == 0.0):
            return
        rng = float(np.linalg.norm(self.ukf.x[dm.POS]))
        pos = (rng * c.calibration_bearing_sigma) ** 2 + c.light_survey_sigma**2 / len(self.lights)
        att = c.calibration_bearing_sigma**2 + 2.0 * c.light_survey_sigma**2 / self._spread
        P = self.ukf.P
        add = np.maximum(np.repeat([pos, att], 3) - np.diag(P)[0:6], 0.0)
        if add.any():
            self.ukf.P = P + np.diag(np.r_[add, np.zeros(len(P) - 6)])

    def fuse_bearings(self, bearings, rates) -> int:
        """Correct at the filter's time with bearings (M, 2) and rates (M, 2) already extracted (NaN rows
        dropped, rates NaN for new blobs); returns the number of lights used. ``update(Frame)`` does this
        after finding the blobs; this entry is for bearings from elsewhere (tests, other trackers)."""
        return self._correct(bearings, rates, self.last_gyro)[0]

    def _correct(self, bearings, rates, gyro, replay: bool = False, rp=None, lag: float = 0.0) -> tuple[int, int]:
        """Associate and correct; returns (lights used, blobs rejected). ``replay``: re-fusing after a late
        frame (counters and integrity already have it). ``rp``: the autopilot's roll and pitch at the frame (the
        level-deck update, ``_level``)."""
        b = np.asarray(bearings, float).reshape(-1, 2)
        r = np.asarray(rates, float).reshape(-1, 2)
        if r.shape != b.shape:
            raise ValueError(f"bearings {b.shape} and rates {r.shape} differ in shape")
        ok = np.isfinite(b).all(axis=1)
        b, r = b[ok], r[ok]
        try:
            used = self._correct_checked(b, r, int(ok.sum()), gyro, replay, lag)
            if used[0]:
                self._level(rp)
            return used
        except np.linalg.LinAlgError as exc:
            self._diverged(str(exc))
            self.stats.lights_used_last = 0
            if not replay:
                self.integrity.record(self._t, "bearing", float("nan"), 0, False)
            return 0, 0

    def _correct_checked(self, b, r, n_ok: int, gyro, replay: bool = False, lag: float = 0.0) -> tuple[int, int]:
        st = self.stats if not replay else DeckNavStats()
        if not replay:
            self._blobs = b  # (a re-lock's frame: ``_relocate_level``)
            if self._acquiring:
                self._acquire_level(b)
        st.blobs += n_ok
        if len(b) == 0:
            st.empty_frames += 1
            st.lights_used_last = 0
            return 0, 0
        zp, S, sig, vec = self._expected()
        assign = associate(b, zp, S, self.gate)
        rejected = int((assign < 0).sum())
        st.blobs_rejected += rejected
        m = (assign >= 0).nonzero()[0]
        if m.size == 0 and self._lockout(b, replay):
            return self._refuse(b, r, n_ok, gyro, lag)
        if m.size == 0:
            st.lights_used_last = 0
            if not replay:
                self.integrity.record(self._t, "bearing", float("nan"), 0, False)
            return 0, rejected
        m = m[assign[m].argsort()]
        idx = assign[m]
        if not replay and not self._retying and self._range_lost(b[m], idx):
            return self._refuse(b, r, n_ok, gyro, lag)
        has_rate = np.isfinite(r[m]).all(axis=1)
        ridx = idx[has_rate]
        z = np.concatenate([b[m].ravel(), r[m][has_rate].ravel()])
        cal = np.broadcast_to(self._calibration_var(vec), (len(self.lights),))[idx]
        self._calibration_rms = float(np.sqrt(np.mean(cal)))  # (the hand-over check's allowance)
        if self._consider:  # the consider parameters carry the calibration's share of S
            cal = np.zeros_like(cal)
        b_dt, r_dt = self._time_offset_var(r[m], gyro)
        R = np.diag(np.concatenate([np.repeat(self.bearing_var + cal, 2) + b_dt,
                                    np.full(2 * ridx.size, self.rate_var + r_dt)]))
        # the rates' midpoint (``_rate_gyro``): half an interval back on the newest IMU input (a late frame's replay
        # too: in a 5 rad/s^2 swing the input of 0.1 s later moves its rates by about 0.5 rad/s x 1.4 m x 17 ms / 1.4 m
        # = 0.01 rad/s, a third of their noise)
        back = (partial(self._process_model, dt=-lag, u=self._u, bias=self._bias_on)
                if lag > 0.0 and self._u is not None and ridx.size else None)
        applied = self.ukf.update(z, R, hx=dm.measurement_model, max_nis=self._max_nis(z.size), sigmas=sig,
                                  consider=self._consider_slice, lights=self.lights, cam=self.cam, gyro=gyro, idx=idx,
                                  rate_idx=ridx, vectors=vec, rates_at=back)
        nis_whole = (self.ukf.nis, int(z.size))  # the whole frame's, applied or not (the bias test's)
        if not applied and ridx.size:  # the rates (frame-to-frame blob matches) are the fragile part: try without
            nb = 2 * idx.size
            applied = self.ukf.update(z[:nb], R[:nb, :nb], hx=dm.measurement_model, max_nis=self._max_nis(nb),
                                      sigmas=sig, consider=self._consider_slice, lights=self.lights, cam=self.cam, gyro=gyro, idx=idx,
                                      rate_idx=ridx[:0], vectors=vec)
            ridx = ridx[:0]
            z = z[:nb]
        if not applied and self._lockout(b, replay):
            return self._refuse(b, r, n_ok, gyro, lag)
        if not applied:  # the whole frame disagrees with the filter beyond its gate: not fused
            st.lights_used_last = 0
            st.updates_gated += 1
            if not replay:
                self._bias_test(*nis_whole)
            if not replay:
                self.integrity.record(self._t, "bearing", float("nan"), 0, False)
            return 0, rejected + int(idx.size)
        st.lights_used_last = int(idx.size)
        self._calibration_floor()
        self._survey_attitude(idx)
        if not replay:
            self._tilt_lost()
        if not replay:
            self._bias_test(*nis_whole)
        if not replay:
            self._locked = 0
        if replay:
            return int(idx.size), rejected
        self.last_nis, self.last_dof = self.ukf.nis, int(z.size)
        nb = 2 * idx.size
        yb = self.ukf.y[:nb]
        self.last_bearing_rms = float(np.sqrt((yb * yb).sum() / yb.size))  # (the mean's own steps)
        # the bearing and rate parts' own NIS (marginal blocks of S) for the integrity monitor
        S_all, y = self.ukf.S, self.ukf.y
        fix = idx.size >= self.cfg.fix_min_lights  # (fewer lights: fused, but they do not hold the fix)
        self.integrity.record(self._t, "bearing", float(yb @ np.linalg.solve(S_all[:nb, :nb], yb)), nb, True, fix)
        if y.size > nb:
            yr = y[nb:]
            self.integrity.record(self._t, "rate", float(yr @ np.linalg.solve(S_all[nb:, nb:], yr)), yr.size, True,
                                  fix)
        self._nis_test()
        return int(idx.size), rejected

    def _nis_test(self) -> None:
        """Re-lock a filter the windowed NIS test keeps failing: ``lost_nis_failures`` failures (a pass, then a
        fail) within ``lost_window_s``. One failure is a fault or a manoeuvre the filter rides out; a fit on a
        wrong solution fails, passes for a second, fails again."""
        n = self.cfg.lost_nis_failures
        if n <= 0:
            return
        failing = self.integrity.window_state()[2]
        if failing and not self._nis_failing:
            q = self._nis_failures
            q.append(self._t)
            while q and q[0] < self._t - self.cfg.lost_window_s:
                q.popleft()
            if len(q) >= n:
                q.clear()
                self._nis_failing = False
                self._relock(f"windowed NIS test failed {n} times within {self.cfg.lost_window_s:g} s")
                return
        self._nis_failing = failing

    def _bias_test(self, nis: float, dof: int) -> None:
        """Accelerometer-bias step test: the summed NIS of the last ``bias_test_frames`` frames' whole updates
        (a normalised innovation squared is chi2 with the update's dof; the sum of independent ones with the
        summed dof) above the ``1 - bias_test_alpha`` quantile -> the bias's variance widened to at least
        ``bias_step_sigma^2`` per axis, so that the next frames move the bias estimate instead of leaving the
        prediction to run off on the old one (the random walk alone follows 0.002 m/s^2/sqrt(s), not a step of
        0.3). The window starts again ``bias_test_rest_s`` after a widening (the bias converging meanwhile: widened
        every 6 frames, the estimate swung the vehicle about at 2 m/s, deck-static bias seed 3). Needs the bias states (``accel_bias_sigma > 0``)."""
        if not self._bias_on or self.cfg.bias_test_frames <= 0 or not np.isfinite(nis):
            return
        w = self._nis_window
        if self._t < self._bias_rest_until:
            return
        w.append((nis, dof))
        if len(w) < w.maxlen:
            return
        total, k = sum(a for a, _ in w), sum(b for _, b in w)
        q = self._gates.get(("bias", k))
        if q is None:
            q = self._gates[("bias", k)] = float(chi2.isf(self.cfg.bias_test_alpha, k))
        if total <= q:
            return
        w.clear()
        while self._widened and self._widened[0] < self._t - self.cfg.lost_window_s:
            self._widened.popleft()
        if 0 < self.cfg.lost_widenings <= len(self._widened) + 1:
            return self._relock(f"accelerometer-bias test: NIS {total:.0f} over {k} dof, widening "
                                f"{len(self._widened) + 1} within {self.cfg.lost_window_s:g} s")
        self._bias_rest_until = self._t + self.cfg.bias_test_rest_s
        P = self.ukf.P.copy()
        i = np.arange(dm.BIAS.start, dm.BIAS.stop)
        P[i, i] = np.maximum(P[i, i], self.cfg.bias_step_sigma**2)  # (only the diagonal grows: P stays positive)
        self.ukf.P = P
        self.stats.bias_steps += 1
        self._widened.append(self._t)
        if self.recorder is not None:
            self._log_init(self._t, self.ukf.x, np.diag(P),
                           f"accelerometer-bias test: NIS {total:.0f} over {k} dof of the last {w.maxlen} "
                           f"frames above {q:.0f}: bias variance widened")

    def _retied(self):
        """(x, P) of a re-tie: the deck's relative roll, pitch and rates from their sea-state prior (as
        ``_reacquire``), ``retie_sigmas`` added to the position and velocity variances; copies."""
        x, P = self.ukf.x.copy(), self.ukf.P.copy()
        sp, sv = self.cfg.retie_sigmas
        rp = self._rp if self._rp is not None else x[3:5]
        ii = np.array([3, 4, 9, 10, 11])
        x[3:5], x[9:12] = rp, 0.0
        P[ii, :], P[:, ii] = 0.0, 0.0
        P[ii, ii] = np.asarray(self.cfg.deck_prior_var, float)
        P[0:3, 0:3] += np.eye(3) * sp**2
        P[6:9, 6:9] += np.eye(3) * sv**2
        return x, P

    def _relock(self, why: str) -> None:
        """The filter is lost: it fits the lights on a wrong solution (the near-planar layout's pose ambiguity:
        after a re-acquisition on the realistic deck, relative pitch 10-17 deg and position 0.5-0.9 m off with
        a 5 cm sigma, the bias test widening every 1.2 s for 50 s, static blur seed 7). Start it again from
        where it is as a re-tie does: the deck's relative roll, pitch and rates from their sea-state prior (the
        level deck breaks the ambiguity), ``retie_sigmas`` added to the position and velocity variances, the
        bias back to zero at its prior sigma; the bias test rests ``bias_test_reacquire_rest_s``. Logged in
        ``nav_init``, counted in ``stats.relocks``."""
        x, P = self._retied()
        moved = self._relocate_level(x, P, np.radians(RELOCK_YAW_PRIOR_DEG), RELOCK_MIN_TURN_SIGMAS)
        if self._bias_on:
            i = np.arange(dm.BIAS.start, dm.BIAS.stop)
            x[i] = 0.0
            P[i, :], P[:, i] = 0.0, 0.0
            P[i, i] = self.cfg.accel_bias_sigma**2
        self.ukf.x, self.ukf.P = x, P
        self._widened.clear()
        self._nis_window.clear()
        self.integrity.clear()  # the lost filter's innovations say nothing of the re-locked one
        self._bias_rest_until = self._t + self.cfg.bias_test_reacquire_rest_s
        self.stats.relocks += 1
        if self.recorder is not None:
            self._log_init(self._t, x, np.diag(P), f"{why}: lost, re-locked from the deck's sea-state prior{moved}")

    def _level(self, rp) -> None:
        """A level deck (``level_deck_sigma`` > 0): the deck frame is level, so the relative roll and pitch (phi,
        theta) of C_h^d are the vehicle's own, which the autopilot measures. After a frame's lights, z = (roll,
        pitch) is fused with h(x) = (phi, theta) and ``level_deck_sigma`` per axis, ungated: the autopilot
        outranks a fit of the lights. Not in the thesis' filter: there the four near-coplanar lights alone fix the
        attitude, and they also fit a second pose 10-40 deg off in pitch.
        * A static deck (seed 003 §5.3.3): 2 deg (the AHRS's error and the deck's departure from level). After a
          re-acquisition the thesis' filter took the second pose (static blur seed 4: re-locked every 3 s for 40 s,
          settled on it again each time, then landed 2 m off the plate).
        * A moving deck oscillates about level: its sea state's tilt sigma spread over the frames of one correlation
          time (``estimation/deck.sea_state_level_sigma``, 35 deg per frame for the Stewart preset), a weak pull
          towards level that the lights outweigh except along the second pose's valley (fault-free moving seed 19
          drifted from its Vicon start to 31-43 deg off in relative pitch within 3 s of its hover, with a 10-20 deg
          sigma: NEES 51)."""
        s = self.cfg.level_deck_sigma
        if s <= 0.0 or rp is None or self.ukf is None:
            return
        # (linear: the closed form; the lights' innovation stays the last one, which the integrity windows read)
        self.ukf.update_states(np.asarray(rp, float), np.eye(2) * s * s, _ROLL_PITCH, consider=self._consider_slice)

    def _lockout(self, b: np.ndarray, replay: bool) -> bool:
        """A frame with blobs ``b`` (bearings) had every light rejected. After ``retie_after_frames`` such frames in
        a row (at least 3 blobs each: the lights are in view, the filter has drifted off them) re-tie the
        filter and return True (the caller fuses the frame again, once); False otherwise.

        With three or more lights in view the relative pose is observable from every frame, so a filter whose
        prediction is beyond the gate of all of them has been carried off by its process input (an accelerometer
        bias, lost IMU samples in a manoeuvre) with a covariance too small to let the lights back in: it would
        stay locked out while the IMU drifts it metres away (issue #18). The re-tie adds ``retie_sigmas`` to
        the position and velocity variances, puts the deck's relative roll, pitch and rates back to their
        sea-state prior (as ``_reacquire``) and widens the accelerometer noise in Q for ``retie_hold_s`` so
        that the velocity follows the lights instead of a biased accelerometer. Logged in ``nav_init``."""
        n, n_blobs = self.cfg.retie_after_frames, len(b)
        if replay or n <= 0 or n_blobs < 3 or self._retying:
            if not replay and n_blobs < 3:
                self._locked = 0
            return False
        self._locked += 1
        if self._locked < n:
            return False
        self._locked = 0
        x, P = self._retied()
        moved = self._relocate(x, P, b)
        if self._bias_on:  # the bias states: a lock-out is what an accelerometer-bias step looks like
            i = np.arange(dm.BIAS.start, dm.BIAS.stop)
            P[i, i] = np.maximum(P[i, i], self.cfg.bias_step_sigma**2)
        self.ukf.x, self.ukf.P = x, P
        self._widen_until = self._t + self.cfg.retie_hold_s
        self._nis_window.clear()  # the widened filter's own NIS is no bias step (_bias_test)
        self._bias_rest_until = self._t + self.cfg.bias_test_reacquire_rest_s
        self.stats.reties += 1
        if self.recorder is not None:
            self._log_init(self._t, x, np.diag(P),
                           f"re-tie after {n} frames with every light rejected: position, velocity and "
                           f"deck attitude widened, accelerometer noise widened{moved}")
        return True

    def _relocate(self, x, P, b) -> str:
        """A lock-out's re-tie (``_lockout``) also takes the position from the frame itself: the lock-out frame's
        blobs ``b`` (bearings) assigned to the lights by ``locate_lights`` with the re-tie's attitude (the deck's
        level prior); kept when they reproject within ``RELOCATE_RMS_SIGMAS`` bearing sigmas (tracking and
        calibration), the position sigma the re-tie's plus ``range_check_frac`` of the range. A re-tie adds only
        5 cm to a filter that may be 1 m off (static IMU-drop seed 4: 31 re-ties in 3 s, every light still
        rejected, the vehicle flown 3.5 m off the plate). ``x``, ``P`` are changed in place; returns what the log
        says ('' when the frame gave no position)."""
        if self.cfg.range_check_sigmas <= 0:  # (on with the range check: over a static deck)
            return ""
        c = self.cfg
        sig_b = float(np.hypot(c.tracking_sigmas[0], c.calibration_bearing_sigma))
        found = dm.locate_lights(b, x[dm.ATT], self.lights, self.cfg.cam, float(c.tracking_sigmas[0]))
        if found is None or found[3] > RELOCATE_RMS_SIGMAS * sig_b:
            return ""
        idx, r, _, rms = found
        self._place(x, P, r)
        self.stats.relocations += 1
        return f"; position from the frame's {len(idx)} lights ({np.degrees(rms):.2f} deg RMS)"

    def _relocate_level(self, x, P, prior_sigma: float, min_turn_sigmas: float = 0.0, place: bool = True) -> str:
        """A re-lock over a level deck (the level update and the range check on: a static deck) also takes the
        relative yaw and the position from a frame of every light (``_blobs``): solved at every relative yaw with
        the autopilot's roll and pitch (``locate_level_deck``), the yaw a posteriori with the filter's yaw as the
        prior (sigma ``prior_sigma`` [rad]) and the bearings' sigma the tracking's with the survey's per light at
        the filter's range (the misalignment turns every bearing alike: the position takes it up); kept when
        they reproject within ``RELOCATE_RMS_SIGMAS`` bearing sigmas (tracking and calibration); the yaw's
        sigma then at least ``RELOCATE_YAW_SIGMA_DEG``. A re-lock alone keeps the yaw it was lost on: static seed
        20 started 46 deg off its eq. 5.12 prior (20 deg sigma), converged on the layout's fit from the other
        side, 88 deg off with a 4 deg sigma, and re-locked there twice (NEES 388). ``min_turn_sigmas``: the frame
        is taken only when its yaw is that many of the filter's yaw sigmas (``x``'s) from the filter's; a re-lock
        that keeps its yaw keeps its position too (taking the position at every re-lock put static black-out seed
        4, re-locking every second in a hover oscillating at 1-2 m/s, onto the deck 2.5 m off instead of holding).
        ``place``: the position too. ``x``, ``P`` are changed in place; returns what the log says ('' when the frame
        gave none)."""
        c, b = self.cfg, self._blobs
        if (c.range_check_sigmas <= 0 or c.level_deck_sigma <= 0 or self._rp is None or b is None
                or len(b) < len(self.lights)):
            return ""
        rng = float(np.linalg.norm(x[dm.POS]))
        sig = float(np.hypot(c.tracking_sigmas[0], c.light_survey_sigma / max(rng, 0.1)))
        found = dm.locate_level_deck(b, *self._rp, self.lights, self.cfg.cam, sig, prior=(float(x[5]), prior_sigma))
        if found is None or found[4] > RELOCATE_RMS_SIGMAS * float(np.hypot(c.tracking_sigmas[0],
                                                                            c.calibration_bearing_sigma)):
            return ""
        psi, idx, r, _, rms = found
        turn = float(np.degrees(wrap_angle(psi - float(x[5]))))
        if abs(turn) <= min_turn_sigmas * max(np.degrees(np.sqrt(P[5, 5])), RELOCATE_YAW_SIGMA_DEG):
            return ""
        x[5] = psi
        P[5, :], P[:, 5] = 0.0, 0.0
        P[5, 5] = max(self.ukf.P[5, 5], np.radians(RELOCATE_YAW_SIGMA_DEG) ** 2)
        if place:
            self._place(x, P, r)
        self.stats.relocations += 1
        return (f"; relative yaw ({turn:+.0f} deg){' and position' if place else ''} from the frame's {len(idx)} "
                f"lights ({np.degrees(rms):.2f} deg RMS)")

    def _acquire_level(self, b) -> None:
        """The start of eq. 5.12-5.17 over a level deck, turned by its first frame of every light: the relative yaw
        from ``_relocate_level`` (the a posteriori yaw with eq. 5.17's prior) when it lies beyond the prior's sigma
        from eq. 5.12's, roll and pitch the autopilot's, the rest of eq. 5.12-5.17 kept.

        The thesis' prior holds the yaw at 0 with a 20 deg sigma while the pilot may hold the vehicle 45 deg off
        the deck's heading (§5.3.3); from there the filter can converge on the layout's fit from the other side
        (static seed 20: 88 deg off with a 4 deg sigma for 11 s), which the operator's restart with a yaw (Fig.
        5.7) was for. A frame that confirms the thesis' start leaves it as it is (placing every start moved every
        flight, and two fault runs that had held in an oscillating hover landed off the plate instead). Off where
        ``_relocate_level`` is (a moving deck)."""
        c = self.cfg
        if c.range_check_sigmas <= 0 or c.level_deck_sigma <= 0:
            self._acquiring = False
            return
        if self._rp is None or len(b) < len(self.lights):
            return
        self._acquiring = False
        x, P = self.ukf.x.copy(), self.ukf.P.copy()
        x[3:5] = self._rp
        moved = self._relocate_level(x, P, float(np.sqrt(P[5, 5])), 1.0, place=False)  # (eq. 5.17's yaw prior)
        if not moved:
            return
        self.ukf.x, self.ukf.P = x, P
        if self.recorder is not None:
            self._log_init(self._t, x, np.diag(P), f"acquisition over a level deck{moved}")

    def _place(self, x, P, r) -> None:
        """The deck's position ``r`` from a frame's lights into (x, P): the position sigma ``range_check_frac`` of
        the range (the calibration's share of the scale) and the re-tie's, uncorrelated."""
        c = self.cfg
        x[dm.POS] = r
        P[0:3, :], P[:, 0:3] = 0.0, 0.0
        P[0:3, 0:3] = np.eye(3) * ((c.range_check_frac * float(np.linalg.norm(r))) ** 2 + c.retie_sigmas[0] ** 2)

    def _range_lost(self, b, idx) -> bool:
        """The range check (issue 30, not in the thesis): with the filter's relative attitude, the frame's lights
        give the deck's position by least squares (``position_from_bearings``: the range from the lights' spread
        in the image). A filter whose range is off by more than ``range_check_sigmas`` times the combined sigma
        (the solve's, the filter's along the sight line, and ``range_check_frac`` of the range: the survey's and
        the attitude's share of the scale) on ``range_check_frames`` frames in a row has fitted the lights on a
        wrong solution (static black-out seed 2: 0.64 m long at 2.9 m, 104 steps over the HPL while ``ok``): it
        re-locks (``_relock``: the deck attitude from its prior, velocity widened by ``retie_sigmas``) at the
        solved position; True -> the frame is fused again. Needs 3 lights; 0 sigmas: off (a moving deck)."""
        c = self.cfg
        if c.range_check_sigmas <= 0 or idx.size < 3:
            return False
        x, P = self.ukf.x, self.ukf.P
        # the tracking bearing sigma (the acquisition's is widened on purpose); the calibration's share of the
        # scale (the survey's, the focal length's) is range_check_frac: its misalignment turns every bearing alike
        sig_b = float(c.tracking_sigmas[0])
        r_ls, C_ls = dm.position_from_bearings(b, idx, x[dm.ATT], self.lights, self.cfg.cam, sig_b)
        rng = float(np.linalg.norm(x[dm.POS]))
        u = x[dm.POS] / max(rng, 1e-6)
        var = float(u @ (C_ls + P[0:3, 0:3]) @ u) + (c.range_check_frac * rng) ** 2
        off = float(u @ r_ls) - rng
        if off * off <= c.range_check_sigmas**2 * var:
            self._range_off = 0
            return False
        self._range_off += 1
        if self._range_off < c.range_check_frames:
            return False
        self._range_off = 0
        self._relock(f"range check: the lights put the deck {off:+.2f} m from the filter's {rng:.2f} m "
                     f"(sigma {np.sqrt(var):.2f} m) on {c.range_check_frames} frames")
        xr, Pr = self.ukf.x.copy(), self.ukf.P.copy()
        xr[dm.POS], _ = dm.position_from_bearings(b, idx, xr[dm.ATT], self.lights, self.cfg.cam, sig_b)
        Pr[0:3, :], Pr[:, 0:3] = 0.0, 0.0
        Pr[0:3, 0:3] = np.eye(3) * (c.range_check_frac * rng) ** 2 + np.eye(3) * c.retie_sigmas[0] ** 2
        self.ukf.x, self.ukf.P = xr, Pr
        self.stats.range_relocks += 1
        return True

    def _tilt_lost(self) -> None:
        """The tilt check (issue 30, not in the thesis; a moving deck): the deck oscillates about level, its tilt
        bounded by its sea state (``deck_prior_var``: the amplitude bound A + 3 sigma_A per axis, hypot(A_roll,
        A_pitch) = 12.7 deg for the Stewart preset). The filter's relative attitude with the autopilot's roll and
        pitch puts the deck's tilt at acos(z_d . z_n); beyond the bound plus ``tilt_check_sigmas`` times the
        filter's roll / pitch sigma on ``range_check_frames`` frames in a row, the filter has fitted the lights on
        a wrong attitude and re-locks (``_relock``: the attitude from that prior). Moving seed 5, fault-free: the
        relative pitch drifted to 66-87 deg off with a 4-7 deg sigma for 5 s in the hover (NEES 600-700) until the
        bias test re-locked it."""
        c = self.cfg
        if c.tilt_check_sigmas <= 0 or self._rp is None:
            return
        x, P = self.ukf.x, self.ukf.P
        tilt = float(np.arccos(np.clip(dm.deck_in_level(x[dm.ATT], *self._rp)[2, 2], -1.0, 1.0)))
        bound = float(np.sqrt(2.0 * (c.deck_prior_var[0] + c.deck_prior_var[1])))
        sig = float(np.sqrt(max(P[3, 3], P[4, 4])))
        if tilt <= bound + c.tilt_check_sigmas * sig:
            self._tilt_off = 0
            return
        self._tilt_off += 1
        if self._tilt_off >= c.range_check_frames:
            self._tilt_off = 0
            self._relock(f"tilt check: the deck {np.degrees(tilt):.0f} deg from level, its sea state bounds "
                         f"{np.degrees(bound):.0f} deg (+{c.tilt_check_sigmas:g} x {np.degrees(sig):.1f} deg)")

    def _refuse(self, b, r, n_ok, gyro, lag: float = 0.0) -> tuple[int, int]:
        """Fuse a locked-out frame again after the re-tie (once)."""
        self._retying = True
        try:
            return self._correct_checked(b, r, n_ok, gyro, lag=lag)
        finally:
            self._retying = False
