"""Pieces every fixed-wing simulation needs (the CONDOR loop and the geo-location loop): wind from the
scenario's ``[world]``, the aircraft started in trim in that wind, and the autopilot's air data."""

from __future__ import annotations

import math

import numpy as np

from visnav.control.fixedwing import AirData
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
    model = FixedWingModel.from_trim(params, trim(params, airspeed_mps, turn_radius=turn_radius), position_ned, heading)
    model.x[3:6] += euler_to_dcm(model.x[6:9]).T @ wind.steady.ned
    return model


def air_data(model: FixedWingModel, height_m: float, airspeed_mps: float) -> AirData:
    """What the autopilot measures: AHRS attitude, gyros, the given height and airspeed, the ball."""
    x = model.x
    return AirData(phi=x[6], theta=x[7], p=x[9], q=x[10], r=x[11], h=float(height_m), Va=float(airspeed_mps),
                   ay=float(model.air["specific_force"][1]))
