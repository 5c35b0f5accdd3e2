"""Shared pieces of the simulated sensors: the truth look-up they sample from."""

from __future__ import annotations

from typing import Callable

import numpy as np

from visnav.measurements import VehicleState

TruthAt = Callable[[float], VehicleState]
"""``truth_at(t)`` returns the (interpolated) true vehicle state at time ``t``; sensors with an
unmodelled delay sample it at ``t - delay`` and stamp the result ``t``."""


class TruthHistory:
    """Ring buffer of recent truth on the uniform dynamics grid, with linear interpolation.

    Sensors that describe an earlier instant than they claim (the PALACE IMU was 44 ms late,
    seed 000 §5.2) read the past from here. Look-ups before the buffer clamp to its oldest entry.
    """

    def __init__(self, dt: float, horizon_s: float = 2.0):
        self.dt = float(dt)
        self.n = int(np.ceil(horizon_s / dt)) + 2
        self._pos = np.zeros((self.n, 3))
        self._vel = np.zeros((self.n, 3))
        self._eul = np.zeros((self.n, 3))
        self._rates = np.zeros((self.n, 3))
        self._f = np.zeros((self.n, 3))
        self._ground = np.zeros(self.n, dtype=bool)
        self._k = -1  # index of the newest sample on the time grid
        self._t0 = 0.0
        self.latest: VehicleState | None = None

    def push(self, s: VehicleState) -> None:
        if self._k < 0:
            self._t0 = s.t
        k = int(round((s.t - self._t0) / self.dt))
        if self._k >= 0 and k != self._k + 1:
            raise ValueError(f"TruthHistory: state at t={s.t} is not the next grid step after {self._k}")
        i = k % self.n
        self._pos[i] = s.position
        self._vel[i] = s.velocity
        eul = np.asarray(s.euler, dtype=float).copy()
        if self._k >= 0:  # keep yaw continuous for interpolation
            prev = self._eul[self._k % self.n, 2]
            eul[2] = prev + (eul[2] - prev + np.pi) % (2 * np.pi) - np.pi
        self._eul[i] = eul
        self._rates[i] = s.body_rates
        self._f[i] = s.specific_force
        self._ground[i] = s.on_ground
        self._k = k
        self.latest = s

    def __call__(self, t: float) -> VehicleState:
        if self._k < 0:
            raise RuntimeError("TruthHistory is empty")
        if self.latest is not None and abs(t - self.latest.t) < 1e-9:
            return self.latest
        x = (t - self._t0) / self.dt
        oldest = max(0, self._k - self.n + 2)
        x = min(max(x, oldest), self._k)
        k0 = int(np.floor(x))
        a = x - k0
        k1 = min(k0 + 1, self._k)
        i0, i1 = k0 % self.n, k1 % self.n

        def lerp(arr):
            return arr[i0] * (1 - a) + arr[i1] * a

        eul = lerp(self._eul)
        eul[2] = (eul[2] + np.pi) % (2 * np.pi) - np.pi
        return VehicleState(
            t=float(t),
            position=lerp(self._pos),
            velocity=lerp(self._vel),
            euler=eul,
            body_rates=lerp(self._rates),
            specific_force=lerp(self._f),
            on_ground=bool(self._ground[i1]),
        )
