"""Shared pieces of the simulated sensors: the truth look-up they sample from."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from visnav.estimation.history import History
from visnav.measurements import VehicleState

TruthAt = Callable[[float], VehicleState]
"""``truth_at(t)`` returns the (interpolated) true vehicle state at time ``t``; sensors with an
unmodelled delay sample it at ``t - delay`` and stamp the result ``t``."""


class TruthHistory:
    """Recent truth on the uniform dynamics grid, linearly interpolated (``estimation/history.History``).

    Sensors that describe an earlier instant than they claim (the PALACE IMU was 44 ms late,
    seed 000 §5.2) read the past from here. Look-ups outside the buffer hold its oldest / newest entry;
    ``on_ground`` is true when the vehicle was on the ground at either neighbouring step.
    """

    def __init__(self, dt: float, horizon_s: float = 2.0):
        self.dt = float(dt)
        self.n = int(np.ceil(horizon_s / dt)) + 2
        # position, velocity, euler (yaw unwrapped), body rates, specific force, on ground
        self._h = History(16, self.n, angles=(8,), tolerance=math.inf)
        self._k = -1  # index of the newest sample on the time grid
        self._t0 = 0.0
        self.latest: VehicleState | None = None

    def push(self, s: VehicleState) -> None:
        if self._k < 0:
            self._t0 = s.t
        k = int(round((s.t - self._t0) / self.dt))
        if self._k >= 0 and k != self._k + 1:
            raise ValueError(f"TruthHistory: state at t={s.t} is not the next grid step after {self._k}")
        self._h.push(s.t, np.concatenate((s.position, s.velocity, s.euler, s.body_rates, s.specific_force,
                                          (1.0 if s.on_ground else 0.0,))))
        self._k = k
        self.latest = s

    def __call__(self, t: float) -> VehicleState:
        if self._k < 0:
            raise RuntimeError("TruthHistory is empty")
        if self.latest is not None and abs(t - self.latest.t) < 1e-9:
            return self.latest
        x = self._h.at(t)
        return VehicleState(t=float(t), position=x[0:3], velocity=x[3:6], euler=x[6:9], body_rates=x[9:12],
                            specific_force=x[12:15], on_ground=bool(x[15] > 0.0))
