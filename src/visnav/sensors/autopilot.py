"""The flight sensors of a small fixed-wing autopilot (CONDOR's ArduPlane board, seed 004 §2.1; the
geo-location MAV's MP2028g, seed 002 §7.4): AHRS attitude, rate gyros, accelerometers, pitot airspeed.

Each is a sensor of the one contract: ``rate_hz``, ``latency_s``, ``sample(t, truth_at, world)`` ->
a measurement stamped with the instant it describes. Errors are a turn-on bias (drawn once per run
from N(0, bias)) plus white noise of the configured standard deviation. Defaults are typical of the
MEMS parts on such boards (MPU-6000 class IMU, a DCM / EKF attitude solution, MS4525 pitot):

| sensor | noise (1 sigma) | turn-on bias (1 sigma) |
|---|---|---|
| AHRS roll / pitch | 0.2 deg | 0.5 deg |
| AHRS yaw (its magnetometer: ``baro.Compass``) | 1 deg | 2 deg |
| gyro | 0.05 deg/s | 0.05 deg/s (after the power-on calibration) |
| accelerometer | 0.03 m/s^2 | 0.05 m/s^2 |
| pitot airspeed | 0.2 m/s | 0.3 m/s |
"""

from __future__ import annotations

import math

import numpy as np

from visnav.measurements import AirspeedSample, AttitudeSample, ImuSample


def _bias(rng: np.random.Generator, sigma: float, n: int):
    return rng.normal(0.0, sigma, n) if sigma > 0 else np.zeros(n)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class Ahrs:
    """Attitude solution (roll, pitch, yaw) with a turn-on bias and white noise per axis [rad]."""

    def __init__(self, rng: np.random.Generator, rate_hz: float = 50.0, noise_deg: float = 0.2,
                 bias_deg: float = 0.5, yaw_noise_deg: float = 1.0, yaw_bias_deg: float = 2.0,
                 latency_s: float = 0.0) -> None:
        self.rng, self.rate_hz, self.latency_s = rng, float(rate_hz), float(latency_s)
        self.noise = np.radians([noise_deg, noise_deg, yaw_noise_deg])
        self.bias = np.radians([*_bias(rng, bias_deg, 2), *_bias(rng, yaw_bias_deg, 1)])

    def sample(self, t: float, truth_at, world=None) -> AttitudeSample:
        e = np.asarray(truth_at(t).euler, float) + self.bias + self.noise * self.rng.standard_normal(3)
        e[2] = _wrap(float(e[2]))
        return AttitudeSample(t=t, euler=e, sensor="ahrs")


class AutopilotImu:
    """Rate gyros and accelerometers (body FRD): turn-on bias + white noise on each axis."""

    def __init__(self, rng: np.random.Generator, rate_hz: float = 50.0, gyro_noise_deg_s: float = 0.05,
                 gyro_bias_deg_s: float = 0.05, accel_noise_mps2: float = 0.03, accel_bias_mps2: float = 0.05,
                 latency_s: float = 0.0) -> None:
        self.rng, self.rate_hz, self.latency_s = rng, float(rate_hz), float(latency_s)
        self.gyro_noise, self.accel_noise = math.radians(gyro_noise_deg_s), float(accel_noise_mps2)
        self.gyro_bias = _bias(rng, math.radians(gyro_bias_deg_s), 3)
        self.accel_bias = _bias(rng, accel_bias_mps2, 3)

    def sample(self, t: float, truth_at, world=None) -> ImuSample:
        s = truth_at(t)
        n = self.rng.standard_normal(6)  # truth + turn-on bias + white noise
        return ImuSample(t=t, accel=np.asarray(s.specific_force, float) + self.accel_bias + self.accel_noise * n[:3],
                         gyro=np.asarray(s.body_rates, float) + self.gyro_bias + self.gyro_noise * n[3:])


class Pitot:
    """Indicated airspeed: the world's true airspeed (``world.airspeed(t)``) + turn-on bias + white noise."""

    def __init__(self, rng: np.random.Generator, rate_hz: float = 50.0, noise_mps: float = 0.2,
                 bias_mps: float = 0.3, latency_s: float = 0.0) -> None:
        self.rng, self.rate_hz, self.latency_s = rng, float(rate_hz), float(latency_s)
        self.noise, self.bias = float(noise_mps), float(_bias(rng, bias_mps, 1)[0])

    def sample(self, t: float, truth_at, world) -> AirspeedSample:
        return AirspeedSample(t=t, airspeed=float(world.airspeed(t) + self.bias + self.noise * self.rng.standard_normal()))
