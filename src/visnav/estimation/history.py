"""The one ring-buffer history: recent (time, vector) rows, looked up at any instant by linear interpolation.

Navigators keep one to place a late measurement at the instant it describes (PALACE's attitude at a
frame's instant, WITAS's and the pad navigator's filter position and attitude at a frame's instant).
Angle columns are unwrapped on ``push`` (each sample moved by whole turns to within pi of the previous
one) so that interpolating across +-pi is right, and wrapped back to [-pi, pi) by ``at``.

``at(t)`` is ``numpy.interp`` on every column at once (the same arithmetic: slope times the distance
from the left sample, plus the left sample), without building index arrays: each row is stored twice,
at ``i`` and ``i + n``, so the newest ``n`` rows are always one contiguous slice.
"""

from __future__ import annotations

import math

import numpy as np

_TWO_PI = 2.0 * math.pi


class History:
    """``n`` most recent rows of ``width`` values; ``angles``: indices of the angle columns [rad];
    ``tolerance``: how far outside the stored times ``at`` still answers (it holds the end value there)."""

    def __init__(self, width: int, n: int = 256, angles: tuple[int, ...] = (), tolerance: float = 0.0):
        if n < 1 or width < 1:
            raise ValueError(f"History needs n >= 1 rows of width >= 1, got n={n}, width={width}")
        self.n, self.width = int(n), int(width)
        self.angles = tuple(int(a) for a in angles)
        self.tolerance = float(tolerance)
        self._t = np.full(2 * self.n, -np.inf)
        self._x = np.zeros((2 * self.n, self.width))
        self.k = 0  # rows pushed so far

    def __len__(self) -> int:
        return min(self.k, self.n)

    def push(self, t: float, row) -> None:
        """Append the row of time ``t`` (times must increase)."""
        x = np.array(row, dtype=float)
        if self.k and self.angles:
            prev = self._x[(self.k - 1) % self.n]
            for j in self.angles:
                x[j] = prev[j] + (x[j] - prev[j] + math.pi) % _TWO_PI - math.pi
        i = self.k % self.n
        self._t[i] = self._t[i + self.n] = t
        self._x[i] = self._x[i + self.n] = x
        self.k += 1

    @property
    def newest_t(self) -> float:
        """Time of the newest row (-inf when empty)."""
        return float(self._t[(self.k - 1) % self.n]) if self.k else -math.inf

    def newest(self) -> np.ndarray | None:
        """The newest row as pushed (angles unwrapped), a view: copy it to keep it."""
        return self._x[(self.k - 1) % self.n] if self.k else None

    def _window(self) -> tuple[np.ndarray, np.ndarray]:
        m = min(self.k, self.n)
        end = (self.k - 1) % self.n + self.n + 1
        return self._t[end - m:end], self._x[end - m:end]

    def at(self, t: float) -> np.ndarray | None:
        """The row at ``t`` (linear interpolation, angles wrapped to [-pi, pi)); None when empty or when
        ``t`` lies more than ``tolerance`` outside the stored times."""
        if self.k == 0:
            return None
        ts, xs = self._window()
        if t < ts[0] - self.tolerance or t > ts[-1] + self.tolerance:
            return None
        j = int(np.searchsorted(ts, t, side="right")) - 1
        if j < 0:
            out = xs[0].copy()
        elif j >= len(ts) - 1:
            out = xs[-1].copy()
        elif t == ts[j]:
            out = xs[j].copy()
        else:
            x0, x1 = xs[j], xs[j + 1]
            slope = (x1 - x0) / (ts[j + 1] - ts[j])
            out = slope * (t - ts[j]) + x0
        for a in self.angles:
            out[a] = (out[a] + math.pi) % _TWO_PI - math.pi
        return out
