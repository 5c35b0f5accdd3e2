"""IMU whose accelerometers and gyros run at different rates (the R-MAX of seed 002 §6.2: gyros
200 Hz, accelerometers 66 Hz). Wraps ``sensors/imu.Imu`` (sampled at the gyro rate) and holds the
accelerometer reading of the latest accelerometer instant in between, so each ``ImuSample`` carries
the newest gyro sample and the newest accelerometer sample, as a flight computer that polls both
would see them."""

from __future__ import annotations

import numpy as np

from visnav.measurements import AttitudeSample, ImuSample
from visnav.sensors.base import TruthAt
from visnav.sensors.imu import Imu


class SplitRateImu:
    def __init__(self, imu: Imu, accel_hz: float = 66.0):
        self.imu = imu
        self.rate_hz = imu.rate_hz  # the gyro rate
        self.latency_s = imu.latency_s
        self.accel_period = 1.0 / float(accel_hz)
        self._next_accel = -np.inf
        self._accel: np.ndarray | None = None

    def sample(self, t: float, truth_at: TruthAt, world=None) -> tuple[ImuSample, AttitudeSample]:
        s, att = self.imu.sample(t, truth_at)
        if t >= self._next_accel - 1e-9:  # an accelerometer instant has passed: new reading
            self._accel = s.accel
            nxt = self._next_accel + self.accel_period
            self._next_accel = nxt if nxt > t else t + self.accel_period
        return ImuSample(t=t, accel=self._accel, gyro=s.gyro), att
