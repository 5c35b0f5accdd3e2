"""What a mission manager does with the navigator's integrity (issue #18): one watch shared by the missions.

``IntegrityWatch.update(t, health)`` follows ``health.integrity`` (ok | degraded | unusable) and how long
it has held; ``react(t, action, reason)`` logs what the mission did about it in the ``integrity_reaction``
stream (the mission's mode changes are in the ``mode`` stream with their reasons, the navigator's own
transitions in ``integrity_event``).
"""

from __future__ import annotations

from visnav.log_schema import register_stream

register_stream("integrity_reaction", state=("text", "", "integrity state the mission reacted to"),
                action=("text", "", "what the mission did (fallback, go-around, abort, dead reckoning, none)"),
                reason=("text", "", "the navigator's reason and the mission's rule"))


class IntegrityWatch:
    def __init__(self, recorder=None):
        self.record = recorder or (lambda *a, **k: None)
        self.state = "ok"
        self.since = 0.0
        self.reason = ""
        self.hpl_m = float("inf")
        self.seen_ok = False  # the navigator has been ok once (before that it has no estimate to judge)

    def update(self, t: float, health, hpl_m: float | None = None) -> str:
        """``hpl_m``: the protection level the mission's rules take instead of ``health.hpl_m`` (the deck's filter
        share, without the survey's constant error)."""
        s = getattr(health, "integrity", "ok")
        if s != self.state:
            self.state, self.since = s, t
        self.reason = getattr(health, "integrity_reason", "")
        self.hpl_m = float(getattr(health, "hpl_m", float("inf")) if hpl_m is None else hpl_m)
        self.seen_ok = self.seen_ok or s == "ok"
        return s

    def unusable_for(self, t: float) -> float:
        """Seconds the state has been ``unusable`` without a break (0 otherwise, and before the first ok)."""
        return t - self.since if self.state == "unusable" and self.seen_ok else 0.0

    def ok_for(self, t: float) -> float:
        return t - self.since if self.state == "ok" else 0.0

    def react(self, t: float, action: str, why: str = "") -> None:
        self.record("integrity_reaction", t, state=self.state, action=action,
                    reason=f"{self.reason}; {why}" if why else self.reason)
