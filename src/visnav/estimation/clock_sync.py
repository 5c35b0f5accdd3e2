"""Clock synchronisation with a remote peer (the autopilot) from two-way time stamps (MAVLink TIMESYNC).

Protocol (MAVLink TIMESYNC, as PX4 and ArduPilot answer it): we send ``tc1 = 0, ts1 = our_now_ns``;
the peer answers ``tc1 = its_now_ns, ts1 = our ts1`` unchanged. When the answer arrives at our
``now_ns`` the round trip is ``rtt = now - ts1`` and, assuming symmetric legs, the peer's clock read
``tc1`` at our instant ``(ts1 + now) / 2``, so one offset sample is

    offset = tc1 - (ts1 + now) / 2          (peer clock - our clock)

with an error bounded by ``rtt / 2`` (the worst leg asymmetry). The estimator is robust:

* only samples whose round trip is within ``rtt_slack`` of the smallest round trip in the recent window
  are used (the min-RTT filter: long round trips come from queueing, which is asymmetric);
* a sample further than ``max(rtt/2, outlier_floor)`` from the prediction is an outlier and rejected;
  ``reset_after`` consecutive outliers mean the peer's clock jumped (reboot): the estimator restarts;
* accepted samples are smoothed exponentially (the offset), and a least-squares line through the last
  64 accepted samples (once they span ``skew_span_s``) gives the drift rate (skew), so a peer whose
  oscillator runs 100 ppm fast is followed without lag.

Clocks are integer nanoseconds (``time.monotonic_ns()`` on our side). Nothing here knows MAVLink.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

__all__ = ["ClockSync", "SyncStats"]


@dataclass
class SyncStats:
    samples: int = 0
    accepted: int = 0
    rejected_rtt: int = 0
    rejected_outlier: int = 0
    resets: int = 0


class ClockSync:
    """Offset and skew of a peer clock against ours, from TIMESYNC round trips (module docstring)."""

    def __init__(self, alpha: float = 0.1, window: int = 32, rtt_slack_ns: int = 500_000,
                 max_rtt_ns: int = 200_000_000, outlier_floor_ns: int = 1_000_000, reset_after: int = 5,
                 converge_samples: int = 5, skew_span_s: float = 2.0):
        self.alpha = float(alpha)
        self.rtt_slack, self.max_rtt = int(rtt_slack_ns), int(max_rtt_ns)
        self.outlier_floor, self.reset_after = int(outlier_floor_ns), int(reset_after)
        self.converge_samples = int(converge_samples)
        self.skew_span_ns = int(skew_span_s * 1e9)
        self.rtts: deque[int] = deque(maxlen=window)
        self.stats = SyncStats()
        self._reset_state()

    def _reset_state(self) -> None:
        self.offset_ns: float | None = None  # peer - ours, at our instant self._t_ref
        self.skew = 0.0  # d(offset)/d(our time), dimensionless
        self._t_ref = 0
        self.rtt_ns: float | None = None  # smoothed round trip of the accepted samples
        self._n_accepted = 0
        self._outliers_in_row = 0
        self._rtt_best = 0
        self.rtts.clear()
        self._accepted: deque[tuple[int, float]] = deque(maxlen=64)

    # ------------------------------------------------------------------ protocol
    @staticmethod
    def request(now_ns: int) -> tuple[int, int]:
        """(tc1, ts1) of a TIMESYNC request sent at our ``now_ns``."""
        return 0, int(now_ns)

    @staticmethod
    def answer(tc1: int, ts1: int, now_ns: int) -> tuple[int, int] | None:
        """(tc1, ts1) to send back when the peer asks (tc1 == 0), else None."""
        return (int(now_ns), int(ts1)) if tc1 == 0 else None

    def on_reply(self, tc1: int, ts1: int, now_ns: int) -> bool:
        """Feed a reply to one of our requests received at our ``now_ns``; True if the sample was used."""
        rtt = int(now_ns) - int(ts1)
        self.stats.samples += 1
        if rtt < 0 or rtt > self.max_rtt or tc1 <= 0:
            self.stats.rejected_rtt += 1
            return False
        self.rtts.append(rtt)
        if rtt > min(self.rtts) + self.rtt_slack:  # queued in one direction: asymmetric, skip
            self.stats.rejected_rtt += 1
            return False
        t_mid = (int(ts1) + int(now_ns)) // 2
        sample = float(int(tc1) - t_mid)
        converging = self.offset_ns is not None and self._n_accepted < self.converge_samples
        if converging and self.rtt_ns is not None and rtt + self.rtt_slack < self._rtt_best:
            self.offset_ns = None  # a much shorter round trip while converging: the first ones were queued
            self._accepted.clear()
        if self.offset_ns is None:
            self._rtt_best = rtt
            self.offset_ns, self._t_ref, self.rtt_ns = sample, t_mid, float(rtt)
            self._n_accepted = 1
            self._accepted.append((t_mid, sample))
            self.stats.accepted += 1
            return True
        pred = self.offset_at(t_mid)
        resid = sample - pred
        if self._n_accepted >= self.converge_samples and abs(resid) > max(rtt / 2.0, self.outlier_floor):
            self.stats.rejected_outlier += 1
            self._outliers_in_row += 1
            if self._outliers_in_row >= self.reset_after:  # the peer's clock jumped: start again
                self.stats.resets += 1
                self._reset_state()
            return False
        self._outliers_in_row = 0
        # exponential smoothing of the offset; faster gain (1/n) while converging, then the steady alpha
        a = max(self.alpha, 1.0 / (self._n_accepted + 1))
        self.offset_ns = pred + a * resid
        self._accepted.append((t_mid, sample))
        t0 = self._accepted[0][0]
        if t_mid - t0 >= self.skew_span_ns and len(self._accepted) >= 8:  # drift rate: least squares line
            ts = [(t - t0) * 1e-9 for t, _ in self._accepted]
            ys = [y for _, y in self._accepted]
            mt, my = sum(ts) / len(ts), sum(ys) / len(ys)
            sxx = sum((t - mt) ** 2 for t in ts)
            self.skew = sum((t - mt) * (y - my) for t, y in zip(ts, ys)) / sxx * 1e-9 if sxx > 0 else 0.0
        self._t_ref = t_mid
        self.rtt_ns = float(rtt) if self.rtt_ns is None else self.rtt_ns + 0.2 * (rtt - self.rtt_ns)
        self._rtt_best = min(self._rtt_best, rtt)
        self._n_accepted += 1
        self.stats.accepted += 1
        return True

    # ------------------------------------------------------------------ mapping
    @property
    def synced(self) -> bool:
        return self.offset_ns is not None and self._n_accepted >= self.converge_samples

    def offset_at(self, ours_ns: float) -> float:
        """Peer clock minus our clock [ns] at our instant ``ours_ns``."""
        if self.offset_ns is None:
            raise RuntimeError("clock not synchronised yet (no TIMESYNC reply)")
        return self.offset_ns + self.skew * (ours_ns - self._t_ref)

    def to_peer(self, ours_ns: float) -> float:
        """Our instant -> the peer's clock reading at that instant [ns]."""
        return ours_ns + self.offset_at(ours_ns)

    def to_ours(self, peer_ns: float) -> float:
        """The peer's clock reading -> our instant [ns] (one fixed-point step suffices: skew << 1)."""
        guess = peer_ns - self.offset_at(peer_ns - self.offset_at(self._t_ref))
        return peer_ns - self.offset_at(guess)

    def offset_ms(self) -> float:
        return float("nan") if self.offset_ns is None else self.offset_ns / 1e6

    def rtt_ms(self) -> float:
        return float("nan") if self.rtt_ns is None else self.rtt_ns / 1e6
