"""Integrity monitoring of a navigation filter: is the estimate consistent, and how wrong can it be?

- A windowed chi-square test of the normalised innovation squared (NIS): over the last ``window``
  accepted updates of one stream, sum(NIS) ~ chi2(sum of the update dimensions) when the filter's
  covariance is honest. Above the upper ``1 - alpha`` quantile the filter is over-confident (the
  dangerous case: wrong and sure of it); below the lower ``alpha`` quantile it is over-conservative.
- The share of updates the filter's own gate rejected over the same window.
- A consistency factor ``k^2 = max(1, mean(NIS) / dof)`` that inflates the covariance when the
  innovations say it is too small (pooled over the streams a navigator names in ``inflation_streams``,
  its horizontal position updates: a vertical baro NIS says nothing of the horizontal error). With
  ``short_window = n > 0`` (issue #30) also the mean NIS per dof of each such stream's last ``n`` accepted
  updates over the stream's own usual level (``baseline``, at most 1: a filter whose assumed fix noise is
  conservative has NIS far below chi-square's, and a fault that multiplies its innovations by ``r`` is no
  less a fault for staying under 1), the largest of them: a fault that moves the estimate off within a
  second (an accelerometer bias step under 20 Hz fixes) shows in the last few innovations, relative to their
  usual size, before the long window's mean rises. The baseline is the mean NIS per dof of the stream's
  accepted updates below 4 baselines (the fault's own are left out; 1 until 50 have come).
- A horizontal protection level (HPL): with a horizontal error ``e ~ N(0, k^2 P_h)``,
  ``|e|^2 <= lambda_max(k^2 P_h) e^T (k^2 P_h)^-1 e`` and the last factor is chi2(2), so
  ``HPL = k sqrt(lambda_max(P_h) chi2.ppf(p, 2)) = k sqrt(-2 ln(1 - p) lambda_max(P_h))``
  bounds the true horizontal error with probability at least ``p``.
- One state, ``ok | degraded | unusable``, with the reason: unusable when no update has arrived for
  ``stale_s`` or the HPL exceeds the alert limit, degraded when a stream's chi-square test fails or
  too many updates are rejected.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2


def horizontal_protection_level(P_h: np.ndarray, probability: float = 0.999, inflation: float = 1.0) -> float:
    """Radius that contains the horizontal error with at least ``probability`` (2x2 covariance ``P_h``,
    scaled by ``inflation`` = k^2)."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability must be in (0, 1), got {probability}")
    (a, b), (c, d) = np.asarray(P_h, float)[:2, :2].tolist()
    if not math.isfinite(a + b + c + d):
        return math.nan if any(map(math.isnan, (a, b, c, d))) else math.inf
    lam = 0.5 * (a + d) + math.hypot(0.5 * (a - d), 0.5 * (b + c))  # lambda_max of the symmetric part
    return math.sqrt(max(inflation, 0.0) * chi2_2_quantile(probability) * max(lam, 0.0))


def chi2_2_quantile(probability: float) -> float:
    """chi2.ppf(p, 2) = -2 ln(1 - p): chi-square with 2 degrees of freedom is exponential with mean 2."""
    return -2.0 * math.log1p(-probability)


@dataclass
class StreamTest:
    """Result of the windowed test of one update stream."""

    stream: str
    updates: int
    nis_sum: float
    dof: int
    lower: float
    upper: float
    rejected_share: float

    @property
    def over_confident(self) -> bool:
        return self.dof > 0 and self.nis_sum > self.upper

    @property
    def over_conservative(self) -> bool:
        return self.dof > 0 and self.nis_sum < self.lower

    @property
    def mean_nis_per_dof(self) -> float:
        return self.nis_sum / self.dof if self.dof else float("nan")


@dataclass
class IntegrityConfig:
    window: int = 20  # updates per stream in the chi-square window
    alpha: float = 0.001  # two-sided test level of the windowed NIS test
    max_rejected_share: float = 0.3  # degraded above this share of gated-out updates
    probability: float = 0.999  # the HPL's containment probability
    alert_limit_m: float = math.inf  # unusable when the HPL exceeds it
    stale_s: float = math.inf  # unusable when no accepted update for this long
    # streams whose NIS inflates the HPL (k^2): the horizontal position streams; None: every stream
    inflation_streams: tuple[str, ...] | None = None
    short_window: int = 0  # > 0: k^2 also from each inflation stream's last this-many accepted updates

    def __post_init__(self):
        if self.window < 1:
            raise ValueError(f"IntegrityConfig.window must be >= 1, got {self.window}")
        if not 0.0 < self.alpha < 0.5:
            raise ValueError(f"IntegrityConfig.alpha must be in (0, 0.5), got {self.alpha}")


@dataclass
class IntegrityMonitor:
    """Feed it every update a filter makes (``record``); ask it for the state (``assess``)."""

    config: IntegrityConfig = field(default_factory=IntegrityConfig)

    def __post_init__(self):
        self._streams: dict[str, deque] = {}
        self._last_accept: float = -math.inf
        self._quantiles: dict[int, tuple[float, float]] = {}
        self.transitions: list[tuple[float, str, str]] = []  # (t, state, reason)
        self._state = "ok"
        self._memo: tuple | None = None  # what ``assess`` derives from the windows alone, until they change
        # per-stream tests and k^2 kept until their own windows change (a baro update leaves the other
        # streams' tests and the horizontal k^2 as they were)
        self._tests: dict[str, StreamTest] = {}
        self._k2: float | None = None
        self._base: dict[str, list[float]] = {}  # stream -> [sum of NIS/dof, count] of its usual updates

    def clear(self) -> None:
        """Empty every stream's window (a filter re-initialised: its predecessor's innovations say nothing)."""
        for q in self._streams.values():
            q.clear()
        self._memo = None
        self._tests.clear()
        self._k2 = None

    def record(self, t: float, stream: str, nis: float, dof: int, accepted: bool, fix: bool = True) -> None:
        """One update: its NIS, its dimension, and whether the filter's gate accepted it; ``fix`` False: an
        accepted update that does not fix the state on its own (a deck frame with one or two lights), which
        does not hold off ``stale_s``."""
        q = self._streams.get(stream)
        if q is None:
            q = self._streams[stream] = deque(maxlen=self.config.window)
        q.append((float(nis), int(dof), bool(accepted)))
        self._memo = None
        self._tests.pop(stream, None)
        only = self.config.inflation_streams
        if only is None or stream in only:
            self._k2 = None
        if accepted and fix:
            self._last_accept = max(self._last_accept, float(t))
            if self.config.short_window > 0 and dof > 0 and (only is None or stream in only):
                b = self._base.setdefault(stream, [0.0, 0])
                if nis / dof < 4.0 * self.baseline(stream):
                    b[0] += nis / dof
                    b[1] += 1

    def baseline(self, stream: str) -> float:
        """The stream's usual NIS per dof (``short_window``): 1 until 50 updates, then their mean, at most 1."""
        b = self._base.get(stream)
        return 1.0 if b is None or b[1] < 50 else min(1.0, b[0] / b[1])

    def _bounds(self, dof: int) -> tuple[float, float]:
        b = self._quantiles.get(dof)
        if b is None:
            a = self.config.alpha
            b = self._quantiles[dof] = (float(chi2.ppf(a / 2, dof)), float(chi2.ppf(1 - a / 2, dof)))
        return b

    def test(self, stream: str) -> StreamTest:
        """The windowed test of one stream (accepted updates only: rejected ones never reached the state)."""
        q = self._streams.get(stream, ())
        acc = [(n, d) for n, d, ok in q if ok]
        dof = sum(d for _, d in acc)
        s = float(sum(n for n, _ in acc))
        lo, hi = self._bounds(dof) if dof else (0.0, math.inf)
        rej = 1.0 - len(acc) / len(q) if len(q) else 0.0
        return StreamTest(stream, len(acc), s, dof, lo, hi, rej)

    def inflation(self) -> float:
        """k^2 = max(1, mean NIS per degree of freedom) over the windows of the ``inflation_streams``."""
        tot_n = tot_d = 0.0
        short = 1.0
        m = self.config.short_window
        only = self.config.inflation_streams
        for name, q in self._streams.items():
            if only is not None and name not in only:
                continue
            for n, d, ok in q:
                if ok:
                    tot_n, tot_d = tot_n + n, tot_d + d
            if m > 0:
                last = [(n, d) for n, d, ok in q if ok][-m:]
                sd = sum(d for _, d in last)
                if sd:
                    short = max(short, sum(n for n, _ in last) / sd / max(self.baseline(name), 1e-6))
        return max(1.0, tot_n / tot_d if tot_d else 1.0, short)

    def _windows(self) -> tuple:
        """The windowed tests, k^2 and the state they give alone, computed once per change of the windows (the
        navigators assess at every step, the windows change at each update)."""
        if self._memo is None:
            c = self.config
            tests = []
            for name in self._streams:
                x = self._tests.get(name)
                if x is None:
                    x = self._tests[name] = self.test(name)
                tests.append(x)
            state, reason = "ok", ""
            bad = [x for x in tests if x.over_confident]
            rej = [x for x in tests if x.rejected_share > c.max_rejected_share]
            if bad:
                state = "degraded"
                reason = "; ".join(f"{x.stream} NIS {x.mean_nis_per_dof:.2f}/dof over {x.updates} updates "
                                   f"(chi2 bound {x.upper / x.dof:.2f})" for x in bad)
            elif rej:
                state = "degraded"
                reason = "; ".join(f"{x.stream} rejected {100 * x.rejected_share:.0f} %" for x in rej)
            if self._k2 is None:
                self._k2 = self.inflation()
            self._memo = (self._k2, state, reason, {x.stream: x.mean_nis_per_dof for x in tests},
                          {x.stream: x.rejected_share for x in tests}, bool(bad))
        return self._memo

    def window_state(self) -> tuple[str, str, bool]:
        """What the windows alone say now: (state, reason, whether a NIS test failed: over-confident, not only
        rejections). For a navigator that acts on a failing test (the deck's re-lock)."""
        _, state, reason, _, _, nis_failed = self._windows()
        return state, reason, nis_failed

    def assess(self, t: float, P_h: np.ndarray | None = None) -> dict:
        """The integrity output every navigator's ``health`` carries (one set of keys)."""
        c = self.config
        k2, state, reason, nis, rejected, _ = self._windows()
        hpl = horizontal_protection_level(P_h, c.probability, k2) if P_h is not None else math.inf
        if t - self._last_accept > c.stale_s:
            state, reason = "unusable", f"no accepted update for {t - self._last_accept:.1f} s"
        elif hpl > c.alert_limit_m:
            state, reason = "unusable", f"HPL {hpl:.1f} m above the {c.alert_limit_m:g} m alert limit"
        if state != self._state:
            self.transitions.append((float(t), state, reason))
            self._state = state
        return {"integrity": state, "integrity_reason": reason, "hpl_m": hpl, "hpl_probability": c.probability,
                "consistency_k2": k2, "nis_per_dof": dict(nis), "rejected_share": dict(rejected)}
