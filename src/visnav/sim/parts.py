"""What a mission builder of the R-MAX loop returns (``sim/missions.py`` ``@register``): a leaf module, so
that the builders in ``sim/witas_parts.py`` and ``sim/pad_parts.py`` import it without importing the registry."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass
class MissionParts:
    mission: object  # .step(t, nav, health) -> (reference, mode); .done; .mode; .on_touchdown(t)
    controller: object  # .command(t, nav, reference) -> command
    metrics: Callable  # metrics(log, scenario, *, wall_time_s, error) -> dict (from the log only)
    start_position: np.ndarray
    start_yaw: float = 0.0
    uses_camera: bool = True
    navigator: object | None = None  # a mission's own navigator (replaces the PALACE one)
    sensors: tuple = ()  # extra sensors: .rate_hz, .latency_s, .sample(t, truth_at) -> measurement
