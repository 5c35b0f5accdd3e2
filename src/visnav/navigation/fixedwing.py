"""The state a small fixed-wing autopilot flies on, from its own sensors (seed 004 §2.1, Fig. 5.1):
attitude from the AHRS, body rates from the gyros, the lateral specific force ("ball") from the
accelerometers, airspeed from the pitot, height from the barometer (eq. 2.1-corrected when the
navigator is given the altimeter constants) or from the autopilot's telemetry.

``estimate(t)`` propagates the last AHRS attitude to ``t`` with the gyro rates (the Euler kinematics,
over at most ``max_propagation_s``) and returns a ``FixedWingEstimate``; position and velocity are
NaN here (CONDOR's navigator adds them). Nothing here ever sees truth.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.measurements import (AirspeedSample, AttitudeSample, BaroSample, FixedWingEstimate, Health, ImuSample,
                                 NavInit, TelemetrySample)
from visnav.geometry.rotations import body_rates_to_euler_rates, wrap_angle
from visnav.navigation.base import CommandDispatch
from visnav.vision.rectification import altimeter_correction

NAN3 = np.full(3, np.nan)


class AutopilotNavigator(CommandDispatch):
    def __init__(self, altimeter: tuple[float, float, float] | None = None, max_propagation_s: float = 0.1) -> None:
        """``altimeter``: (measured outside temperature [C], c0, c1) of the eq. 2.1 correction, None: the
        baro reads height directly."""
        self.altimeter = altimeter
        self.max_prop = float(max_propagation_s)
        self.att: AttitudeSample | None = None
        self.imu: ImuSample | None = None
        self.va = math.nan
        self.h = math.nan
        self.baro_raw = math.nan

    # ------------------------------------------------------------------ measurements
    def update(self, m) -> None:
        if isinstance(m, AttitudeSample):
            if m.sensor == "ahrs":
                self.att = m
        elif isinstance(m, ImuSample):
            self.imu = m
        elif isinstance(m, AirspeedSample):
            self.va = float(m.airspeed)
        elif isinstance(m, BaroSample):
            self.baro_raw = float(m.altitude)
            a = self.altimeter
            self.h = self.baro_raw if a is None else float(altimeter_correction(self.baro_raw, *a))
        elif isinstance(m, TelemetrySample):
            self.h = float(m.height)

    def initialize(self, init: NavInit) -> None:
        """Nothing to initialise: the AHRS, gyros and pitot give their values directly."""

    def _base(self, t: float) -> dict:
        rates = self.imu.gyro if self.imu is not None else np.zeros(3)
        f = self.imu.accel if self.imu is not None else np.array([0.0, 0.0, -9.81])
        if self.att is None:
            att = np.zeros(3)
        else:
            # the AHRS attitude carried to t by the gyros' Euler rates (seed 002 eq. 3.7), yaw wrapped
            dt = min(max(t - self.att.t, 0.0), self.max_prop)
            e = np.asarray(self.att.euler, float)
            att = e + body_rates_to_euler_rates(e, np.asarray(rates, float)) * dt
            att[2] = wrap_angle(att[2])
        return {"attitude": att, "body_rates": np.asarray(rates, float).copy(), "specific_force": np.asarray(f, float),
                "airspeed": self.va, "height": self.h}

    def estimate(self, t: float) -> FixedWingEstimate:
        return FixedWingEstimate(t=t, position=NAN3, velocity=NAN3, valid=self.att is not None, source="ahrs",
                                 **self._base(t))

    def health(self, t: float) -> Health:
        return Health(source="ahrs", tracking=False)
