"""Mission manager of the geo-location flight (seed 002 §7.5, Fig. 7.7): a figure-eight at 70 m over
where the target is believed to be; the operator clicks the target in the first frame that shows it
(the simulation plays the operator); the flight ends once ``max_samples`` target samples are in (or
one, in the one-frame case of the competition flight, §7.5 second scenario).

Modes: ``search`` (flying the eight, no target selected) -> ``tracking`` (tracker running, samples
coming in) -> ``done``. ``step`` takes the latest telemetry and the navigator's health and returns the
heading-rate, height and airspeed references of the autopilot (``control/fixedwing.py``).
"""

from __future__ import annotations

import math

import numpy as np

from visnav.guidance.figure_eight import FigureEight
from visnav.measurements import TelemetrySample

__all__ = ["GeolocationMission"]


class GeolocationMission:
    def __init__(self, cfg, path: FigureEight, airspeed_mps: float, recorder=None) -> None:
        self.cfg, self.path, self.airspeed = cfg, path, airspeed_mps
        self.mode = "search"
        self.done = False
        self.record = recorder or (lambda *a, **k: None)
        self.need = 1 if cfg.experiment == "single_frame" else cfg.max_samples

    def step(self, t: float, tel: TelemetrySample, samples: int, tracking: bool) -> tuple[float, float, float]:
        """(heading-rate reference [rad/s], height [m], airspeed [m/s])."""
        if self.mode == "search" and tracking:
            self._switch(t, "tracking", "operator selected the target, tracker started")
        if self.mode == "tracking" and samples >= self.need:
            self._switch(t, "done", f"{samples} target sample(s)")
        vel = tel.ground_speed * np.array([math.cos(tel.heading), math.sin(tel.heading)])  # GPS velocity
        psidot, info = self.path.heading_rate(tel.position[:2], vel)
        self.info = info
        c = self.cfg
        return psidot, c.altitude_m, self.airspeed

    def _switch(self, t: float, mode: str, reason: str) -> None:
        self.mode = mode
        self.done = mode == "done"
        self.record("mode", t, mode=mode, reason=reason)
