"""Strap-down IMU with its attitude solution (the R-MAX Crossbow IMU + flight computer filter)."""

from __future__ import annotations

import numpy as np

from visnav.measurements import AttitudeSample, ImuSample
from visnav.sensors.base import TruthAt


class Imu:
    """Accelerometers and gyros (white noise + constant bias) and an attitude output.

    ``delay_s`` is the *unknown* delay of seed 000 §5.2: every sample describes the state
    ``delay_s`` earlier than its time stamp says. ``latency_s`` is a known transport delay
    (the sample is delivered late but stamped correctly).
    """

    def __init__(
        self,
        rng: np.random.Generator,
        rate_hz: float = 100.0,
        accel_noise: float = 0.02,
        gyro_noise: float = 0.002,
        accel_bias: float = 0.01,
        gyro_bias: float = 0.0005,
        attitude_noise_deg: float = 0.03,
        latency_s: float = 0.0,
        delay_s: float = 0.0,
    ):
        self.rng = rng
        self.rate_hz = rate_hz
        self.accel_noise = accel_noise
        self.gyro_noise = gyro_noise
        self.attitude_noise = np.deg2rad(attitude_noise_deg)
        self.latency_s = latency_s
        self.delay_s = delay_s
        self.accel_bias = rng.normal(0.0, accel_bias, 3) if accel_bias > 0 else np.zeros(3)
        self.gyro_bias = rng.normal(0.0, gyro_bias, 3) if gyro_bias > 0 else np.zeros(3)

    def sample(self, t: float, truth_at: TruthAt, world=None) -> tuple[ImuSample, AttitudeSample]:
        s = truth_at(t - self.delay_s)
        n = self.rng.standard_normal(9)
        imu = ImuSample(
            t=t,
            accel=s.specific_force + self.accel_bias + self.accel_noise * n[0:3],
            gyro=s.body_rates + self.gyro_bias + self.gyro_noise * n[3:6],
        )
        att = AttitudeSample(t=t, euler=s.euler + self.attitude_noise * n[6:9])
        return imu, att


class AccelGyro:
    """Accelerometers and gyros (the deck Y6's Pixhawk IMU, seed 003 §5.1): white noise plus a bias that starts at
    ``accel_bias`` / ``gyro_bias`` (3,) and random-walks by ``*_bias_walk`` per sqrt(s), its steps drawn from
    ``bias_rng`` (a generator of its own, so that the noise draws do not depend on the bias settings)."""

    def __init__(self, rng: np.random.Generator, accel_noise: float, gyro_noise: float, rate_hz: float = 100.0,
                 latency_s: float = 0.0, accel_bias=(0.0, 0.0, 0.0), gyro_bias=(0.0, 0.0, 0.0),
                 accel_bias_walk: float = 0.0, gyro_bias_walk: float = 0.0,
                 bias_rng: np.random.Generator | None = None):
        self.rng, self.rate_hz, self.latency_s = rng, rate_hz, latency_s
        self.accel_noise, self.gyro_noise = accel_noise, gyro_noise
        self.accel_bias, self.gyro_bias = np.array(accel_bias, float), np.array(gyro_bias, float)
        self.walk = np.repeat([accel_bias_walk, gyro_bias_walk], 3) * np.sqrt(1.0 / rate_hz)  # per sample
        self.bias_rng = bias_rng if bias_rng is not None else np.random.default_rng(0)
        self._walking = bool(np.any(self.walk > 0))

    def sample(self, t: float, truth_at: TruthAt, world=None) -> ImuSample:
        s = truth_at(t)
        acc = s.specific_force + self.accel_bias + self.accel_noise * self.rng.standard_normal(3)
        gyro = s.body_rates + self.gyro_bias + self.gyro_noise * self.rng.standard_normal(3)
        if self._walking:  # b_{k+1} = b_k + sigma_walk sqrt(dt) n_k
            step = self.walk * self.bias_rng.standard_normal(6)
            self.accel_bias, self.gyro_bias = self.accel_bias + step[:3], self.gyro_bias + step[3:]
        return ImuSample(t=t, accel=acc, gyro=gyro)


class RollPitchAhrs:
    """The autopilot's roll and pitch; no heading: yaw is NaN. White noise of ``attitude_noise_deg``, and, with
    ``leveled_on`` (the ``AccelGyro`` whose accelerometers the autopilot levels on), the tilt that accelerometer's
    bias b (body FRD) gives it: the attitude that makes the measured specific force f + b at rest look like gravity,
    f_b = (g sin theta, -g sin phi cos theta, -g cos phi cos theta), is off by (-b_y / g, +b_x / g) to first order
    (issue 30: a real autopilot's roll and pitch are as good as its accelerometers)."""

    def __init__(self, rng: np.random.Generator, attitude_noise_deg: float, rate_hz: float = 100.0,
                 latency_s: float = 0.0, leveled_on: AccelGyro | None = None, g: float = 9.81):
        self.rng, self.rate_hz, self.latency_s = rng, rate_hz, latency_s
        self.sigma = np.radians(attitude_noise_deg)
        self.leveled_on, self.g = leveled_on, float(g)

    def tilt_error(self) -> np.ndarray:
        """(roll, pitch) error [rad] of the leveling on the accelerometer's present bias (zero without one)."""
        if self.leveled_on is None:
            return np.zeros(2)
        b = self.leveled_on.accel_bias
        return np.array([-b[1], b[0]]) / self.g

    def sample(self, t: float, truth_at: TruthAt, world=None) -> AttitudeSample:
        s = truth_at(t)
        rp = s.euler[:2] + self.tilt_error() + self.sigma * self.rng.standard_normal(2)
        return AttitudeSample(t=t, euler=np.array([rp[0], rp[1], np.nan]))
