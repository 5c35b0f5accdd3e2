"""CONDOR gimbal camera (seed 004 §2.1.1): 3-axis stabilised gimbal, camera AHRS, pan potentiometer.

The camera body frame has x along the optical axis, y right, z down; its attitude in NED is the
Z-Y-X Euler triple (roll, tilt, pan) with the tilt negative below the horizon and the roll about
the optical axis, so that a camera roll is exactly a 2-D rotation of the image (seed 004 eq. 3.9-3.10).
"""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.rotations import euler_to_dcm, euler_to_dcm3
from visnav.measurements import AttitudeSample, PanSample
from visnav.scalar import clip as _clip

_G_NED = np.array([0.0, 0.0, 9.81])  # what a resting accelerometer's NED specific force lacks
_G_NED.setflags(write=False)

#: OpenCV camera axes (x right, y down, z optical axis) from camera-body axes (x fwd, y right, z down)
C_CV_CB = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])




def camera_dcm(pan: float, tilt: float, roll: float) -> np.ndarray:
    """``C_n^cv``: NED -> OpenCV camera frame for a camera at (pan, tilt, roll) [rad] in NED."""
    return C_CV_CB @ euler_to_dcm3(float(roll), float(tilt), float(pan)).T


def project_points(camera, cam_pos_ned, pan: float, tilt: float, roll: float, points_ned) -> np.ndarray:
    """Pixels (N, 2) of NED points seen by ``camera`` (a PinholeCamera) at the given pose."""
    p = (np.asarray(points_ned, float) - np.asarray(cam_pos_ned, float)) @ camera_dcm(pan, tilt, roll).T
    return camera.project(p)


def centred_coords(camera, uv) -> tuple[np.ndarray, np.ndarray]:
    """Seed 004 image coordinates (X right, Y up) [px] from the image centre of OpenCV pixels."""
    uv = np.asarray(uv, float)
    return uv[..., 0] - (camera.width - 1) / 2.0, (camera.height - 1) / 2.0 - uv[..., 1]


def _wrap(a: float) -> float:
    return (a + np.pi) % (2 * np.pi) - np.pi


class Gimbal:
    """3-axis brushless gimbal with pan and tilt commands (seed 004 §2.1.1).

    Pan is relative to the airframe (about its yaw axis) and slews at ``pan_rate`` toward the
    command; tilt is held relative to the horizon and slews at ``tilt_rate``; roll stabilisation is
    imperfect: the camera keeps ``roll_leak`` of the aircraft's bank plus a static ``roll_bias``
    (the flight of §7.1 saw -11 deg). Returns the camera's true (pan, tilt, roll) in NED.
    """

    def __init__(self, pan: float, tilt: float, pan_rate: float, tilt_rate: float, roll_leak: float,
                 roll_bias: float) -> None:
        self.pan, self.tilt = float(pan), float(tilt)
        self.pan_cmd, self.tilt_cmd = self.pan, self.tilt
        self.pan_rate, self.tilt_rate = pan_rate, tilt_rate
        self.roll_leak, self.roll_bias = roll_leak, roll_bias

    def command(self, pan: float, tilt: float) -> None:
        if not (np.isfinite(pan) and np.isfinite(tilt)):
            return  # a NaN command is ignored: the gimbal keeps its last one
        self.pan_cmd, self.tilt_cmd = float(pan), _clip(tilt, -np.pi / 2, 0.0)

    def step(self, dt: float) -> None:
        """Each axis slews towards its command at most at its rate (pan the short way round)."""
        step_pan = _clip(_wrap(self.pan_cmd - self.pan), -self.pan_rate * dt, self.pan_rate * dt)
        self.pan = _wrap(self.pan + step_pan)
        self.tilt += _clip(self.tilt_cmd - self.tilt, -self.tilt_rate * dt, self.tilt_rate * dt)

    def camera_attitude(self, euler_aircraft) -> tuple[float, float, float]:
        """(pan in NED, tilt, roll) [rad] of the camera for the aircraft's (roll, pitch, yaw)."""
        phi, _, psi = euler_aircraft
        return _wrap(psi + self.pan), self.tilt, self.roll_leak * phi + self.roll_bias


class CameraAhrs:
    """The mini-controller on the camera (§2.1.1, §4, Fig. 4.2, §7.1): tilt and roll readings with a
    static misalignment (calibrated away on the ground, what is left is ``bias``), white noise, and
    an acceleration error: the part of the horizontal acceleration it cannot tell from gravity
    (``accel_gain`` times the NED acceleration not explained by the airspeed-based centripetal
    compensation) tilts its vertical, low-passed with ``tau_s`` (it needs a steady position to
    converge). Its noise is what a filtered attitude output shows: a first-order Gauss-Markov error
    of standard deviation ``noise`` and correlation time ``noise_tau_s`` (0: white). With ``lag_s`` > 0
    its tilt and roll follow the camera through a first-order lag, so a quick tilt (Fig. 4.2) reads
    late: a ramp at rate w reads ``w lag_s`` behind."""

    def __init__(self, rng: np.random.Generator, noise: float, bias_tilt: float, bias_roll: float,
                 accel_gain: float, tau_s: float, noise_tau_s: float = 0.0, lag_s: float = 0.0,
                 rate_hz: float = 7.5, latency_s: float = 0.0) -> None:
        self.rate_hz, self.latency_s = float(rate_hz), float(latency_s)
        self._t: float | None = None
        self.rng, self.noise, self.noise_tau = rng, noise, noise_tau_s
        self.bias = np.array([bias_tilt, bias_roll])
        self.accel_gain, self.tau_s = accel_gain, tau_s
        self.err = np.zeros(2)
        self.gm = rng.normal(0.0, noise, 2) if noise > 0 else np.zeros(2)
        self.lag_s = lag_s
        self.lagged: np.ndarray | None = None
        self._gm_coef: dict = {}  # (dt, noise_tau, noise) -> the Gauss-Markov step's (a, noise sqrt(1 - a^2))

    def step(self, dt: float, accel_unexplained_ned, cam_pan: float, tilt: float | None = None,
             roll: float | None = None) -> None:
        if self.lag_s > 0 and tilt is not None and roll is not None:
            true = np.array([tilt, roll])
            if self.lagged is None:
                self.lagged = true
            self.lagged = self.lagged + (true - self.lagged) * min(1.0, dt / self.lag_s)
        a0, a1 = float(accel_unexplained_ned[0]), float(accel_unexplained_ned[1])
        c, s = math.cos(cam_pan), math.sin(cam_pan)
        fwd, right = a0 * c + a1 * s, -a0 * s + a1 * c
        # a forward acceleration looks like a nose-up vertical: the camera seems tilted down less
        g, k = self.accel_gain, min(1.0, dt / self.tau_s)
        e0, e1 = self.err.tolist()
        self.err[0] = e0 + (g * math.atan2(fwd, 9.81) - e0) * k
        self.err[1] = e1 + (g * -math.atan2(right, 9.81) - e1) * k
        if self.noise > 0 and self.noise_tau > 0:
            key = (dt, self.noise_tau, self.noise)
            ak = self._gm_coef.get(key)
            if ak is None:  # a = exp(-dt / tau) and noise sqrt(1 - a^2), as numpy computes them, per step size
                a = np.exp(-dt / self.noise_tau)
                if len(self._gm_coef) > 64:
                    self._gm_coef.clear()
                ak = self._gm_coef[key] = (float(a), float(self.noise * np.sqrt(1.0 - a * a)))
            a, k = ak
            g0, g1 = self.gm.tolist()
            n0, n1 = self.rng.standard_normal(2).tolist()
            self.gm = np.array([a * g0 + k * n0, a * g1 + k * n1])  # a gm + k n per axis

    def sample(self, t: float, truth_at, world) -> AttitudeSample:
        """The camera's (roll, tilt, NaN) [rad] at ``t`` (``sensor="camera"``): the unit is stepped over
        the time since its last sample with what its accelerometers feel that the airspeed-based
        centripetal compensation does not explain (truth: ``C_bn f + g`` minus ``psi_dot Va`` across
        the track, ``world.airspeed``), then read at the gimbal's true camera attitude."""
        s = truth_at(t)
        pan, tilt, roll = world.gimbal.camera_attitude(s.euler)
        if self._t is not None and t > self._t:
            phi, th, psi = s.euler.tolist()
            an, ae, _ = (euler_to_dcm3(phi, th, psi) @ s.specific_force + _G_NED).tolist()
            _, q, r = s.body_rates.tolist()
            psidot = (q * math.sin(phi) + r * math.cos(phi)) / math.cos(th)
            k = psidot * world.airspeed(t)  # centripetal compensation across the track (N, E; D unused)
            self.step(t - self._t, (an - k * -math.sin(psi), ae - k * math.cos(psi)), pan, tilt, roll)
        self._t = t
        tm, rm = self.read(tilt, roll)
        return AttitudeSample(t=t, euler=np.array([rm, tm, np.nan]), sensor="camera")

    def read(self, tilt: float, roll: float) -> tuple[float, float]:
        if self.lag_s > 0 and self.lagged is not None:
            tilt, roll = float(self.lagged[0]), float(self.lagged[1])
        if self.noise_tau > 0:
            n = self.gm
        else:
            n = self.rng.normal(0.0, self.noise, 2) if self.noise > 0 else np.zeros(2)
        (e0, e1), (b0, b1), (n0, n1) = self.err.tolist(), self.bias.tolist(), n.tolist()
        return tilt + e0 + b0 + n0, roll + e1 + b1 + n1


class PanPotentiometer:
    """Linear potentiometer on the gimbal's yaw axis (Fig. 2.7): pan relative to the airframe
    (``world.gimbal.pan``) plus white noise (ADC and wire) and a scale error."""

    def __init__(self, rng: np.random.Generator, noise: float, scale_error: float = 0.0, rate_hz: float = 7.5,
                 latency_s: float = 0.0) -> None:
        self.rng, self.noise, self.scale = rng, noise, 1.0 + scale_error
        self.rate_hz, self.latency_s = float(rate_hz), float(latency_s)

    def sample(self, t: float, truth_at, world) -> PanSample:
        n = self.rng.normal(0.0, self.noise) if self.noise > 0 else 0.0
        return PanSample(t=t, pan=float(self.scale * world.gimbal.pan + n))


class PitchRollGimbal:
    """Seed 002 §7.3 / Fig. 7.6: a pitch-roll camera unit that counteracts the aircraft's pitch and roll
    to keep a nadir camera perpendicular to the ground, on the autopilot's attitude estimate (which
    under-reads the bank in sustained turns: ``ahrs_turn_gain``, ``ahrs_tau_s``, and is biased by
    ``ahrs_bias_roll``, ``ahrs_bias_pitch``: §7.2 names "biases in the MAV's attitude estimation" and
    the IMU-gimbal misalignment as the systematic errors of the map-based method). Its servos follow the
    commanded angles through
    a first-order lag (``lag_s``) and compensate only ``1 - leak`` of them; the camera sits on the unit
    with a static misalignment (``bias_roll``, ``bias_pitch``) and jitters (Gauss-Markov, ``jitter``
    rad, 0.5 s). The micro servos of a few-gram gimbal neither move for a command change smaller than
    their dead band nor take up their gear backlash: ``deadband`` (rad, full width) is a hysteresis on
    each axis, so the camera stays up to half of it off where the command asks, on the side it came
    from (a roll reversal leaves it there). Travel is limited to +-``limit`` (the camera tilts by the
    excess in steeper banks). ``camera_dcm(euler)`` is the true C_cn (camera -> NED); the image top
    points along the aircraft's yaw (the unit has no pan axis)."""

    #: OpenCV camera axes in body axes for a nadir camera: x = body right, y = body backward, z = down
    R_CAM_BODY = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])

    def __init__(self, rng: np.random.Generator, lag_s: float, leak: float, bias_roll: float, bias_pitch: float,
                 jitter: float, limit: float = np.radians(45.0), ahrs_turn_gain: float = 0.0,
                 ahrs_tau_s: float = 8.0, ahrs_bias_roll: float = 0.0, ahrs_bias_pitch: float = 0.0,
                 deadband: float = 0.0) -> None:
        self.deadband = float(deadband)
        self.held: np.ndarray | None = None  # the command the servos settle on (after the dead band)
        self.ahrs_bias = np.array([ahrs_bias_roll, ahrs_bias_pitch], float)  # the attitude estimate's bias [rad]
        self.rng, self.lag, self.leak, self.limit = rng, float(lag_s), float(leak), float(limit)
        self.turn_gain, self.ahrs_tau = float(ahrs_turn_gain), float(ahrs_tau_s)
        self.ahrs_err = 0.0  # the autopilot's bank under-read in turns [rad]
        self.bias = np.array([bias_roll, bias_pitch], float)
        self.jitter = float(jitter)
        self.servo = np.zeros(2)  # servo angles (roll, pitch) [rad]
        self.gm = rng.normal(0.0, jitter, 2) if jitter > 0 else np.zeros(2)

    def step(self, dt: float, euler) -> None:
        e = np.asarray(euler, float)
        # the servos counter the autopilot's attitude estimate; a small autopilot's AHRS levels itself on
        # the apparent gravity in a sustained turn: it under-reads the bank by up to turn_gain x bank
        self.ahrs_err += (self.turn_gain * e[0] - self.ahrs_err) * min(1.0, dt / self.ahrs_tau)
        cmd = -(1.0 - self.leak) * (e[:2] - np.array([self.ahrs_err, 0.0]) + self.ahrs_bias)
        cmd = np.clip(cmd, -self.limit, self.limit)
        if self.deadband > 0:  # dead band + backlash: the servo moves only when the command leaves the band
            if self.held is None:
                self.held = cmd.copy()
            hb = 0.5 * self.deadband
            self.held = np.clip(self.held, cmd - hb, cmd + hb)
            cmd = self.held
        self.servo += (cmd - self.servo) * (min(1.0, dt / self.lag) if self.lag > 0 else 1.0)
        if self.jitter > 0:
            a = np.exp(-dt / 0.5)
            self.gm = a * self.gm + self.jitter * np.sqrt(1.0 - a * a) * self.rng.standard_normal(2)

    def residual(self, euler) -> np.ndarray:
        """(roll, pitch) of the optical axis away from nadir [rad]."""
        return np.asarray(euler, float)[:2] + self.servo + self.bias + self.gm

    def camera_dcm(self, euler) -> np.ndarray:
        r = self.residual(euler)
        return euler_to_dcm(np.array([r[0], r[1], float(euler[2])])) @ self.R_CAM_BODY
