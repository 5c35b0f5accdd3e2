"""The flight sensors of a small fixed-wing autopilot (``sensors/autopilot.py``), shared by the CONDOR orbit
and the geo-location MAV: ``[sensors.ahrs] kind = "ahrs"``, ``[sensors.imu] kind = "mems-imu"``,
``[sensors.pitot] kind = "pitot"`` (its compass and GPS: ``config_sensors.py``). Defaults: a MEMS AHRS /
MPU-6000-class IMU / MS4525 pitot (the table in ``sensors/autopilot.py``)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from visnav.scenarios.base import _M
from visnav.sensors.autopilot import Ahrs, AutopilotImu, Pitot


class AhrsConfig(_M):
    kind: Literal["ahrs"] = "ahrs"
    rate_hz: float = Field(50.0, gt=0.0, le=1000.0)
    noise_deg: float = Field(0.2, ge=0.0, le=10.0, description="roll / pitch white noise (1 sigma)")
    bias_deg: float = Field(0.5, ge=0.0, le=10.0, description="roll / pitch turn-on bias (1 sigma of the draw)")
    yaw_noise_deg: float = Field(1.0, ge=0.0, le=20.0)
    yaw_bias_deg: float = Field(2.0, ge=0.0, le=20.0)


class MemsImuConfig(_M):
    kind: Literal["mems-imu"] = "mems-imu"
    rate_hz: float = Field(50.0, gt=0.0, le=1000.0)
    gyro_noise_deg_s: float = Field(0.05, ge=0.0, le=10.0)
    gyro_bias_deg_s: float = Field(0.05, ge=0.0, le=10.0, description="after the power-on calibration")
    accel_noise_mps2: float = Field(0.03, ge=0.0, le=5.0)
    accel_bias_mps2: float = Field(0.05, ge=0.0, le=5.0)


class PitotConfig(_M):
    kind: Literal["pitot"] = "pitot"
    rate_hz: float = Field(50.0, gt=0.0, le=1000.0)
    noise_mps: float = Field(0.2, ge=0.0, le=5.0)
    bias_mps: float = Field(0.3, ge=0.0, le=5.0)


def build_autopilot_sensors(sensors, rng) -> list:
    """[Ahrs, AutopilotImu, Pitot] of the scenario's ``sensors`` (``ahrs``, ``imu``, ``pitot``), each with its own
    generator from ``rng`` (a list of 3)."""

    a, i, p = sensors.ahrs, sensors.imu, sensors.pitot
    return [Ahrs(rng[0], a.rate_hz, a.noise_deg, a.bias_deg, a.yaw_noise_deg, a.yaw_bias_deg),
            AutopilotImu(rng[1], i.rate_hz, i.gyro_noise_deg_s, i.gyro_bias_deg_s, i.accel_noise_mps2, i.accel_bias_mps2),
            Pitot(rng[2], p.rate_hz, p.noise_mps, p.bias_mps)]
