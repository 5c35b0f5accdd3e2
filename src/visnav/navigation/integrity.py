"""The integrity output of a navigator (issue #18): one ``IntegrityMonitor`` fed with the filter's own
innovations, assessed at ``health(t)``, transitions logged.

Each navigator calls ``record(t, stream, nis, dof, accepted)`` after every filter update it makes (the
NIS = y^T S^-1 y of that update and whether the filter's gate took it) and ``fill(health, t, P_h)`` in
``health``; ``fill`` copies ``IntegrityMonitor.assess`` into the ``Health`` and writes an
``integrity_event`` (state code, reason) whenever the state changes.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from visnav.estimation.integrity import IntegrityMonitor
from visnav.log_schema import register_stream
from visnav.measurements import Health

#: integrity state -> the code logged in ``status.integrity`` and ``integrity_event.state``
STATE_CODES = {"ok": 0, "degraded": 1, "unusable": 2}
STATE_NAMES = {v: k for k, v in STATE_CODES.items()}

register_stream("integrity_event", state=("1", "", "new integrity state: 0 ok, 1 degraded, 2 unusable"),
                reason=("text", "", "why (the failed test, the HPL against the alert limit, the stale stream)"),
                hpl=("m", "horizontal", "protection level at the transition"))


class NavIntegrity:
    """An ``IntegrityMonitor`` configured from a navigator's ``integrity`` block (``IntegrityBlock``)."""

    def __init__(self, block, recorder: Callable | None = None, inflation_streams: tuple[str, ...] | None = None):
        cfg = block.monitor_config() if block is not None else None
        if cfg is not None and inflation_streams is not None:
            cfg = replace(cfg, inflation_streams=tuple(inflation_streams))
        self.monitor = IntegrityMonitor(cfg) if cfg is not None else IntegrityMonitor()
        self.recorder = recorder or (lambda *a, **k: None)
        self._state = "ok"

    def record(self, t: float, stream: str, nis: float, dof: int, accepted: bool) -> None:
        if math.isfinite(nis) and dof > 0:
            self.monitor.record(t, stream, nis, dof, accepted)

    def start(self, t: float) -> None:
        """The filter (re)started at ``t``: the stale clock starts here (no update is owed before)."""
        self.monitor._last_accept = max(self.monitor._last_accept, float(t))

    def fill(self, h: Health, t: float, P_h, unobserved_var: float = 0.0) -> Health:
        """``unobserved_var``: variance [m^2] per horizontal axis of an error the filter's covariance does
        not hold (a bias its aid shares), added to ``P_h`` for the HPL."""
        P = None if P_h is None else np.asarray(P_h, float)[:2, :2] + unobserved_var * np.eye(2)
        a = self.monitor.assess(t, P)
        h.set_integrity(a)
        if a["integrity"] != self._state:
            self._state = a["integrity"]
            self.recorder("integrity_event", t, state=STATE_CODES[self._state], reason=a["integrity_reason"],
                          hpl=a["hpl_m"])
        return h
