"""Sensor kinds that several systems fly (one config class per device, one sensor model behind each):
``[sensors.<name>] kind = "gps" | "baro" | "compass"``. The systems differ only in their default values,
which their suites give (``scenarios/roles.SUITES``): the R-MAX's 10 Hz / 2 cm GPS and CONDOR's 5 Hz / 1 m
one are the same ``sensors/gps.Gps``; WITAS' barometer (Gauss-Markov bias) and CONDOR's (eq. 2.1
temperature error) the same ``sensors/baro.Baro``; WITAS' and the fixed wing's compass the same
``sensors/baro.Compass``."""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import Field

from visnav.scenarios.base import _M


class GpsConfig(_M):
    kind: Literal["gps"] = "gps"
    rate_hz: float = Field(10.0, gt=0, le=50)
    sigma_m: float = Field(0.02, ge=0, le=20, description="horizontal position noise, 1 sigma")
    velocity_sigma_mps: float = Field(0.02, ge=0, le=5)
    latency_s: float = Field(0.05, ge=0, le=2.0)
    jam_start_s: Optional[float] = Field(None, ge=0)
    jam_end_s: Optional[float] = Field(None, ge=0)


class BaroConfig(_M):
    kind: Literal["baro"] = "baro"
    rate_hz: float = Field(20.0, gt=0, le=200)
    sigma_m: float = Field(0.3, ge=0, le=10)
    bias_sigma_m: float = Field(0.5, ge=0, le=20, description="Gauss-Markov bias, 1 sigma (0: none)")
    bias_tau_s: float = Field(300.0, gt=0, le=1e5)
    t_outside_c: float = Field(15.0, ge=-20.0, le=45.0, description="outside air temperature (eq. 2.1)")
    t_measured_c: float = Field(15.0, ge=-20.0, le=45.0, description="temperature the navigator's eq. 2.1 "
                                "correction uses (CONDOR)")
    c0: float = Field(0.0, ge=0.0, le=0.01, description="eq. 2.1 constant (print: 0.004, see docs/condor.md)")
    c1: float = Field(0.0, ge=0.0, le=0.001, description="eq. 2.1 per-degree term (print: 0.00005)")


class CompassConfig(_M):
    kind: Literal["compass"] = "compass"
    rate_hz: float = Field(10.0, gt=0.0, le=200.0)
    noise_deg: float = Field(1.0, ge=0.0, le=20.0)
    bias_deg: float = Field(2.0, ge=0.0, le=20.0, description="residual after calibration (1 sigma of the draw)")
