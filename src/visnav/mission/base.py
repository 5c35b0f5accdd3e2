"""What every mission manager shares: it talks to its navigator only through ``command(NavCommand(...))``.

``NavigatorRequests`` sends the requests and keeps what the mission itself asked for: the navigation
source it set (``source``) and whether it asked for tracking during the current step (a request is
pending until the navigator's ``health.tracking_pending`` clears).
"""

from __future__ import annotations

from visnav.measurements import Health, NavCommand


def mode_gate(wanted):
    """Marks a sensor gate (``camera_wanted``) that reads only the mission's own mode, which the mission
    changes in ``step`` and ``on_touchdown``, both after the loop has delivered what was due: the gate says
    the same whether or not the loop delivers the measurements still waiting first, so the loop may sample
    the sensor before it does (``app/loop``: a frame then renders while the one before is delivered)."""
    wanted.reads_deliveries = False
    return wanted


class NavigatorRequests:
    nav: object
    source: str = "gps"
    _asked_t: float | None = None

    def _ask(self, t: float, name: str, **args) -> None:
        self.nav.command(NavCommand(t, name, args))
        if name == "set-source":
            self.source = args["source"]
        elif name in ("request-tracking", "request-tracking-rebase"):
            self._asked_t = t

    def _pending(self, health: Health, t: float) -> bool:
        """A tracking request waits for a frame (the navigator says so, or the mission asked this step)."""
        return bool(health.tracking_pending) or self._asked_t == t
