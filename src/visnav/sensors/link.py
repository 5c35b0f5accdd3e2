"""A radio link as a generic latency + drop channel (CONDOR's telemetry uplink, seed 004 §4, ch. 6:
0.33 s typical latency and dropouts).

``transmit(t, msg)`` returns the delivery time ``t + latency_s``, or None when the message is lost:
each is lost with ``drop_prob``, and outages of ``outage_s`` start at ``outage_rate_hz`` (a Poisson
rate, drawn per message over the time since the previous one). The loop puts delivered messages
into its latency queue. ``sent`` / ``dropped`` count the traffic.
"""

from __future__ import annotations

import numpy as np


class Link:
    def __init__(self, rng: np.random.Generator, latency_s: float = 0.33, drop_prob: float = 0.1,
                 outage_rate_hz: float = 0.0, outage_s: float = 1.0) -> None:
        if latency_s < 0 or not 0.0 <= drop_prob <= 1.0 or outage_rate_hz < 0 or outage_s < 0:
            raise ValueError(f"link: latency {latency_s} s, drop probability {drop_prob}, outage rate "
                             f"{outage_rate_hz} Hz, outage {outage_s} s: none may be negative, drop_prob <= 1")
        self.rng, self.latency_s = rng, float(latency_s)
        self.drop_prob, self.outage_rate, self.outage_s = float(drop_prob), float(outage_rate_hz), float(outage_s)
        self._outage_until = -np.inf
        self._t_last: float | None = None
        self.sent = self.dropped = 0

    def transmit(self, t: float, msg=None) -> float | None:
        """Delivery time of a message sent at ``t`` (None: lost)."""
        self.sent += 1
        dt = 0.0 if self._t_last is None else max(t - self._t_last, 0.0)
        self._t_last = t
        if self.outage_rate > 0 and self.rng.random() < self.outage_rate * dt:
            self._outage_until = t + self.outage_s
        if t < self._outage_until or (self.drop_prob > 0 and self.rng.random() < self.drop_prob):
            self.dropped += 1
            return None
        return t + self.latency_s
