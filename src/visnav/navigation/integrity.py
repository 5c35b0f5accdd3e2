"""The integrity output of a navigator (issue #18): one ``IntegrityMonitor`` fed with the filter's own
innovations, assessed at ``health(t)``, transitions logged.

Each navigator calls ``record(t, stream, nis, dof, accepted)`` after every filter update it makes (the
NIS = y^T S^-1 y of that update and whether the filter's gate took it) and ``fill(health, t, P_h)`` in
``health``; ``fill`` copies ``IntegrityMonitor.assess`` into the ``Health`` and writes an
``integrity_event`` (state code, reason) whenever the state changes.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace
from typing import Callable

import numpy as np
from scipy.stats import chi2

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
        self._suspect: dict[str, tuple[str, Callable[[float], float]]] = {}

    def suspect(self, name: str, reason: str, extra_hpl_m: Callable[[float], float]) -> None:
        """A fault the innovations no longer show (a spoofed GPS the filter follows, a map that disagrees
        with the odometry from the hand-over): from now on the state is at best ``degraded`` with
        ``reason`` and the HPL grows by ``extra_hpl_m(t)`` [m] (the largest of the suspicions' terms: they
        bound the same position error). Latched for the rest of the flight."""
        self._suspect[name] = (reason, extra_hpl_m)

    @property
    def suspicions(self) -> dict[str, str]:
        return {k: r for k, (r, _) in self._suspect.items()}

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
        if self._suspect:
            extra = max(max(f(t), 0.0) for _, f in self._suspect.values())
            why = "; ".join(r for r, _ in self._suspect.values())
            a["hpl_m"] = a["hpl_m"] + extra
            limit = self.monitor.config.alert_limit_m
            if a["hpl_m"] > limit and a["integrity"] != "unusable":
                a["integrity"] = "unusable"
                a["integrity_reason"] = (f"HPL {a['hpl_m']:.1f} m (+{extra:.1f} m: {why}) above the {limit:g} m "
                                         "alert limit")
            elif a["integrity"] == "ok":
                a["integrity"], a["integrity_reason"] = "degraded", f"{why} (HPL +{extra:.1f} m)"
            else:
                a["integrity_reason"] = f"{a['integrity_reason']}; {why}"
        h.set_integrity(a)
        if a["integrity"] != self._state:
            self._state = a["integrity"]
            self.recorder("integrity_event", t, state=STATE_CODES[self._state], reason=a["integrity_reason"],
                          hpl=a["hpl_m"])
        return h


def chi2_bound(alpha: float, dof: int) -> float:
    """The upper ``1 - alpha`` quantile of chi-square with ``dof`` degrees of freedom."""
    return float(chi2.ppf(1.0 - alpha, dof))


class GpsInertialCheck:
    """Onset of a GPS walk-off (spoofing, issue #18): the fix's velocity changes by what the IMU did not feel.

    A spoofer that drags the fix off at ``w`` m/s with a consistent velocity moves the GPS velocity by
    ``w`` while the accelerometers feel nothing. Over the last ``window_s`` the change of the GPS velocity
    minus the integral of the navigation-frame acceleration the filter propagated with,
    ``d = (v(t) - v(t - T)) - int a dt``, is zero within ``sigma^2 = 2 vel_sigma^2 + (accel_sigma T)^2`` per
    axis (GPS velocity noise at both ends, accelerometer + attitude error over T). ``|d|^2 / sigma^2``
    above the ``1 - alpha`` chi-square(2) quantile flags the onset; the walk rate that triggers is
    ``sigma sqrt(bound)`` (``trigger_rate``). A walk-off that ramps up slower than the IMU's errors is
    not seen by this test (nor by any inertial check over seconds).

    Once flagged the walk is assumed to go on at the rate seen while fixes keep being used, from the start
    of the window that flagged it (``onset``): the position error it can have built is
    ``rate (t_last_fix - onset)`` (``extra_hpl``).
    """

    def __init__(self, alpha: float = 1e-7, window_s: float = 1.0, vel_sigma_mps: float = 0.03,
                 accel_sigma_mps2: float = 0.05):
        self.bound = chi2_bound(alpha, 2)
        self.window_s = float(window_s)
        self.sigma = math.sqrt(2 * vel_sigma_mps**2 + (accel_sigma_mps2 * window_s) ** 2)
        self.onset: float | None = None  # the start of the window that flagged it (the walk began after)
        self.detected_t: float | None = None
        self.rate_mps = 0.0
        self.last_fix_t = -math.inf
        self.last_stat = 0.0
        self._t: float | None = None
        self._A = np.zeros(2)  # integral of the horizontal acceleration
        self._fixes: deque = deque()

    @property
    def trigger_rate(self) -> float:
        """The smallest velocity step [m/s] that triggers."""
        return self.sigma * math.sqrt(self.bound)

    def imu(self, t: float, accel_ned) -> None:
        if self._t is not None and t > self._t:
            self._A = self._A + np.asarray(accel_ned, float)[:2] * (t - self._t)
        self._t = float(t)

    def gps(self, t: float, velocity) -> bool:
        """One fix used by the filter; True at the onset (once)."""
        self.last_fix_t = max(self.last_fix_t, float(t))
        v = np.asarray(velocity, float)[:2].copy()
        q = self._fixes
        q.append((float(t), v, self._A.copy()))
        while len(q) > 1 and q[1][0] <= t - self.window_s + 1e-9:
            q.popleft()
        t0, v0, A0 = q[0]
        if t - t0 > 1.5 * self.window_s:  # a gap in the fixes (jamming): start the window again
            q.clear()
            q.append((float(t), v, self._A.copy()))
            return False
        if self.onset is not None or t - t0 < 0.5 * self.window_s:
            return False
        d = (v - v0) - (self._A - A0)
        self.last_stat = float(d @ d) / self.sigma**2
        if self.last_stat > self.bound:
            self.onset, self.detected_t, self.rate_mps = float(t0), float(t), float(np.hypot(*d))
            return True
        return False

    def extra_hpl(self, t: float) -> float:
        if self.onset is None:
            return 0.0
        return self.rate_mps * max(min(t, self.last_fix_t) - self.onset, 0.0)


register_stream("gps_check", stat=("1", "", "GPS-inertial velocity test |d|^2 / sigma^2 (chi-square(2) when "
                                               "fault-free; navigation/integrity.GpsInertialCheck)"),
                onset=("s", "", "time the walk-off was flagged (NaN: not flagged)"))


def watch_gps(check: GpsInertialCheck, integrity: NavIntegrity, t: float, velocity) -> None:
    """One GPS fix the filter uses: the walk-off test, logged; its onset latches a suspicion whose HPL term
    grows at the rate seen."""
    if check.gps(t, velocity):
        integrity.suspect("gps_walk", f"GPS velocity changed {check.rate_mps:.2f} m/s more than the IMU felt "
                          f"by {check.detected_t:.1f} s (walk-off?)", check.extra_hpl)
    integrity.recorder("gps_check", t, stat=check.last_stat,
                       onset=check.onset if check.onset is not None else math.nan)


def gps_check_from(block) -> GpsInertialCheck:
    """A ``GpsInertialCheck`` from a navigator's ``integrity`` block (defaults without one)."""
    if block is None or not hasattr(block, "gps_check_alpha"):
        return GpsInertialCheck()
    return GpsInertialCheck(block.gps_check_alpha, block.gps_check_window_s, block.gps_velocity_sigma_mps,
                            block.gps_check_accel_sigma_mps2)


class HandoverCheck:
    """Does the map registration agree with the odometry carried from the GPS hand-over? (issue #18)

    At the hand-over the filter starts from the last GPS estimate; the odometry-only track carries it
    on. Each registration gives the PMF mean; ``d = pmf_mean - odometry_track`` should then be zero
    within ``var`` = the hand-over variance + the odometry steps' variances + the PMF's largest
    eigenvalue. ``updates`` registrations in a row with ``|d|^2 / var`` above the ``1 - alpha``
    chi-square(2) quantile say the map and the hand-over position disagree by a persistent offset: an
    offset map (an old orthophoto) or a wrong start (spoofed GPS). Which one cannot be told from on
    board, so the offset (their mean) is latched: the navigator keeps the hand-over's frame (the PMF
    fixes minus the offset reach the Kalman filter, the filter never sees the jump and cannot fold it
    into its attitude) and adds ``|offset|`` to its HPL (the truth is in one frame or the other).
    """

    def __init__(self, alpha: float = 1e-4, updates: int = 3):
        self.bound = chi2_bound(alpha, 2)
        self.updates = int(updates)
        self.run: list[np.ndarray] = []
        self.offset: np.ndarray | None = None
        self.t: float | None = None
        self.last_stat = 0.0

    def add(self, t: float, d, var: float) -> bool:
        """One registration; True when the offset is latched (once)."""
        d = np.asarray(d, float)[:2]
        self.last_stat = float(d @ d / max(var, 1e-9))
        if self.offset is not None:
            return False
        if self.last_stat > self.bound:
            self.run.append(d)
        else:
            self.run.clear()
        if len(self.run) >= self.updates:
            self.offset, self.t = np.mean(self.run, axis=0), float(t)
            return True
        return False


def same_image(a, b) -> bool:
    """``np.array_equal(a, b)`` of two frames (the frozen-video-link check, issue #18): contiguous
    images of the same shape and dtype are compared as 8-byte words (the same answer for byte images;
    ~2x faster per frame), anything else by ``np.array_equal``."""
    if b is None:
        return False
    if (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape and a.dtype == b.dtype
            and a.dtype.kind in "ui" and a.nbytes % 8 == 0 and a.flags.c_contiguous and b.flags.c_contiguous):
        return bool((a.reshape(-1).view(np.uint64) == b.reshape(-1).view(np.uint64)).all())
    return bool(np.array_equal(a, b))

