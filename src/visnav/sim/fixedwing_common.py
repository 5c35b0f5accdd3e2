"""Pieces every fixed-wing simulation needs (the CONDOR loop and the geo-location loop): wind from the
scenario's ``[world]``, the aircraft started in trim in that wind, and what its air-data sensors see."""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.rotations import euler_to_dcm
from visnav.vehicles.fixedwing import FixedWingModel, FixedWingParams, trim
from visnav.world.wind import DrydenTurbulence, SteadyWind, Wind


def scenario_wind(world_cfg, rng: np.random.Generator, altitude_m: float, airspeed_mps: float) -> Wind:
    """Steady wind (from ``wind_from_deg``, true north) plus Dryden turbulence of the scenario."""
    w = world_cfg
    turb = None if w.turbulence == "none" else DrydenTurbulence(w.turbulence, rng, altitude_m, airspeed_mps)
    return Wind(SteadyWind(w.wind_speed_mps, w.wind_from_deg), turb)


def trimmed_aircraft(params: FixedWingParams, airspeed_mps: float, position_ned, heading: float,
                     wind: Wind, turn_radius: float = math.inf) -> FixedWingModel:
    """The aircraft in trim at ``airspeed_mps`` (level or turning), moving with the steady wind."""
    tr = trim(params, airspeed_mps, turn_radius=turn_radius)
    model = FixedWingModel.from_trim(params, tr, position_ned, heading)
    model.x[3:6] += euler_to_dcm(model.x[6:9]).T @ wind.steady.ned
    # air data (airspeed, specific force) of the start state, before the first step, for the sensors
    model.hold_air_data(tr.controls, wind.steady.ned)
    return model


class AircraftAir:
    """The ``world`` a fixed wing's air-data sensors see: the aircraft's true airspeed now (``Pitot``)."""

    def __init__(self, vehicle: FixedWingModel) -> None:
        self.vehicle = vehicle

    def airspeed(self, t: float) -> float:
        """True airspeed [m/s] at the current step (sensors sample at the current step)."""
        return float(self.vehicle.air["Va"])
