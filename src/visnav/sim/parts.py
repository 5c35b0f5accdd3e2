"""What a mission builder of the R-MAX loop returns (``sim/missions.py`` ``@register``): a leaf module, so
that the builders in ``sim/witas_parts.py`` and ``sim/pad_parts.py`` import it without importing the registry."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass
class MissionParts:
    """Everything the loop drives; the loop builds nothing else.

    ``sensors``: name -> sensor (``rate_hz``, ``latency_s``, ``sample(t, truth_at, world)`` -> a
    measurement, a tuple of them or None), sampled in this order; the one named ``camera`` renders only
    while ``mission.camera_wanted(t)``. ``nav_init``: an explicit start of the navigator (a surveyed
    pose), sent before the first step and logged in the ``nav_init`` stream. ``actuator_injection(t)``:
    YACS increments added to the controller's output (a sweep), or None.
    """

    world: object  # world/scene.World: ground (rendered by the cameras) and wind
    sensors: dict
    navigator: object  # navigation/base.Navigator
    mission: object  # .step(t, estimate, health) -> (reference, mode); .mode; .done; .on_touchdown(t); .camera_wanted(t)
    controller: object  # .rate_hz; .command(t, estimate, reference) -> command
    metrics: Callable  # metrics(log, scenario, *, wall_time_s, error) -> dict (from the log only)
    start_position: np.ndarray
    start_yaw: float = 0.0
    camera_model: object = None  # geometry of the navigator's camera (recordings write it to camera.yaml)
    mount: object = None
    nav_init: object = None  # measurements.NavInit | None
    actuator_injection: Callable | None = None
    info: dict = field(default_factory=dict)  # what reports and tests read (reference map, path, pad layout, notes)
