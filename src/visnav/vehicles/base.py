"""What every vehicle model's ``step(command, dt, environment)`` receives from the world besides its command."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Environment:
    """The world around the vehicle during one step (built by the simulation from ``world/``).

    ``wind_ned``: air mass velocity [m/s, NED] (steady + gusts); ``rotor_height_m``: height of the
    rotor disc above the surface below it (ground effect; inf when irrelevant).
    """

    wind_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotor_height_m: float = float("inf")
