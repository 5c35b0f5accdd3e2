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
from visnav.estimation.ins import quat_conj, quat_from_rotvec, quat_mult, quat_to_dcm, rotvec_from_dcm
from visnav.estimation.kernels import quat_step
from visnav.geometry.rotations import euler_to_dcm
from visnav.log_schema import register_stream
from visnav.measurements import Health
from visnav.navigation.base import same_image  # noqa: F401  (the frozen-link check; re-exported)

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

    def clear(self, name: str) -> None:
        """A transient fault is over (a frozen camera that runs again): its suspicion no longer holds."""
        self._suspect.pop(name, None)

    @property
    def suspicions(self) -> dict[str, str]:
        return {k: r for k, (r, _) in self._suspect.items()}

    def record(self, t: float, stream: str, nis: float, dof: int, accepted: bool, fix: bool = True) -> None:
        if math.isfinite(nis) and dof > 0:
            self.monitor.record(t, stream, nis, dof, accepted, fix)

    def start(self, t: float) -> None:
        """The filter (re)started at ``t``: the stale clock starts here (no update is owed before)."""
        self.monitor._last_accept = max(self.monitor._last_accept, float(t))

    def restart(self, t: float) -> None:
        """The filter was re-initialised at ``t``: the innovations of the one before say nothing of it (the
        windows are emptied) and the stale clock starts again."""
        self.monitor.clear()
        self.start(t)

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



class GyroAttitudeCheck:
    """Do the navigation gyros agree with the autopilot's attitude solution? (issue #18)

    Over the last ``window_s`` the body rotation integrated from the gyro rates the filter propagates
    with, ``dR_g = prod exp([w dt]x)``, against the rotation between the autopilot's attitudes at both
    ends, ``dR_a = C_a(t0)^T C_a(t1)`` (``C``: body -> NED). ``d = log(dR_a^T dR_g)`` [rad] is zero within
    ``sigma^2 = 2 att_sigma^2 + gyro_noise^2 dt T + (gyro_bias T)^2`` per axis (the attitude noise at both
    ends, the gyro's white noise and turn-on bias over T) + ``(att_bias |log dR_a|)^2`` (a roll / pitch bias of
    the attitude solution is not a constant rotation: it shows in proportion to how much the vehicle turned)
    and ``|d|^2 / sigma^2`` is chi-square(3). Above
    the ``1 - alpha`` quantile the gyros are not to be trusted (a bias step): ``rate`` = ``|d| / T`` is
    what they are off by, ``t0`` the start of the window that flagged it (the fault began after).
    A heading offset between the two attitudes cancels: only rotations over the window are compared.
    """

    kernel = True  # gyro(): the quaternion product on floats (``estimation/kernels.quat_step``); False: readable

    def __init__(self, alpha: float = 1e-7, window_s: float = 1.0, att_sigma_rad: float = math.radians(0.05),
                 gyro_noise: float = 2e-3, gyro_bias: float = 1e-3, dt: float = 0.02,
                 att_bias_rad: float = math.radians(0.2)):
        self.bound = chi2_bound(alpha, 3)
        self.window_s = float(window_s)
        self.sigma2 = 2 * att_sigma_rad**2 + gyro_noise**2 * dt * window_s + (gyro_bias * window_s) ** 2
        self.att_bias = float(att_bias_rad)
        self._R = (1.0, 0.0, 0.0, 0.0)
        self._q: deque = deque()  # (t, cumulative gyro rotation at t: a quaternion)
        self.last_stat = 0.0
        self.detected_t: float | None = None
        self.t0: float | None = None
        self.rate = 0.0
        self.d = np.zeros(3)

    def gyro(self, t: float, w, dt: float) -> None:
        """One propagation step of the filter: body rates ``w`` [rad/s] held over ``dt`` ending at ``t``."""
        # the cumulative rotation as a quaternion (w, x, y, z): R <- R (x) exp(w dt) (body rates: right product)
        if self.kernel:  # (estimation/kernels: the same product on floats, at the IMU rate)
            self._R = quat_step(self._R, np.asarray(w, float).tolist(), float(dt))
        else:
            self._R = quat_mult(self._R, quat_from_rotvec(np.asarray(w, float) * dt))
        self._q.append((float(t), self._R))
        while len(self._q) > 2 and self._q[1][0] <= t - 2.0 * self.window_s:
            self._q.popleft()

    def check(self, attitude_at: Callable[[float], np.ndarray | None]) -> bool:
        """The test on the newest window the attitude solution covers (``attitude_at(t)``: Euler angles
        [rad] or None); True when it fails."""
        q = self._q
        for k in range(len(q) - 1, 0, -1):
            t1, R1 = q[k]
            e1 = attitude_at(t1)
            if e1 is not None:
                break
        else:
            return False
        j = next((i for i in range(k) if q[i][0] >= t1 - self.window_s - 1e-9), None)
        if j is None or t1 - q[j][0] < 0.9 * self.window_s:
            return False
        t0, R0 = q[j]
        e0 = attitude_at(t0)
        if e0 is None:
            return False
        dRa = euler_to_dcm(e0).T @ euler_to_dcm(e1)
        d = rotvec_from_dcm(dRa.T @ quat_to_dcm(quat_mult(quat_conj(R0), R1)))  # R0^T R1 of the gyros
        turned = float(np.linalg.norm(rotvec_from_dcm(dRa)))
        self.last_stat = float(d @ d) / (self.sigma2 + (self.att_bias * turned) ** 2)
        if self.last_stat > self.bound:
            self.detected_t, self.t0, self.d = float(t1), float(t0), d
            self.rate = float(np.linalg.norm(d)) / (t1 - t0)
            return True
        return False


register_stream("gyro_check", stat=("1", "", "gyro / autopilot-attitude rotation test |d|^2 / sigma^2 over the "
                                                "window (chi-square(3) when fault-free; "
                                                "navigation/integrity.GyroAttitudeCheck)"))


def gyro_check_from(block) -> GyroAttitudeCheck | None:
    """A ``GyroAttitudeCheck`` from a navigator's ``integrity`` block (``GyroCheckBlock``); None when it is off."""
    if block is None or not getattr(block, "gyro_check", False):
        return None
    return GyroAttitudeCheck(block.gyro_check_alpha, block.gyro_check_window_s,
                             math.radians(block.gyro_check_attitude_sigma_deg))


class StuckRangeCheck:
    """Is a range sensor (laser, sonar) stuck on one value while the vehicle moves vertically? (issue #30)

    A working range sensor's readings carry noise and follow the height: ``samples`` readings in a row that
    are identical (within ``tolerance_m``: a float repeat; a sensor that quantises would use its quantum)
    while the vertical speed estimate says the range must have changed by at least ``min_change_m`` over
    them (``|v_z| (t_last - t_first)``, ``v_z`` at the first of them: the stuck readings the filter fuses pull
    its vertical speed towards zero) are a stuck sensor. A vehicle that hovers cannot tell (nor does a
    stuck range then mislead it). ``stuck`` holds until a reading differs from the stuck value again;
    ``onset`` is the first of the repeated readings (the fault began then or before), ``error_bound(t)`` the
    range error the readings used between the onset and the detection can carry (``|v_z|`` times that
    time; the navigator uses none after the detection).
    """

    def __init__(self, samples: int = 3, min_change_m: float = 0.05, tolerance_m: float = 1e-6):
        self.samples = int(samples)
        self.min_change_m = float(min_change_m)
        self.tolerance_m = float(tolerance_m)
        self._q: deque = deque(maxlen=self.samples)
        self.stuck = False
        self.onset: float | None = None
        self.detected_t: float | None = None
        self.rate_mps = 0.0
        self.value = math.nan

    def add(self, t: float, r: float, vz: float) -> bool:
        """One reading and the vertical speed estimate [m/s] at it; True while the sensor is stuck."""
        if not math.isfinite(r):
            self._q.clear()
            return self.stuck
        if self.stuck:
            if abs(r - self.value) > self.tolerance_m:  # the sensor moves again
                self.stuck = False
                self._q.clear()
            else:
                return True
        self._q.append((float(t), float(r), abs(float(vz))))
        if len(self._q) < self.samples:
            return False
        rs = [x for _, x, _ in self._q]
        t0, _, vz0 = self._q[0]
        if max(rs) - min(rs) <= self.tolerance_m and vz0 * (t - t0) >= self.min_change_m:
            self.stuck, self.value = True, rs[0]
            self.onset, self.detected_t, self.rate_mps = t0, float(t), vz0
        return self.stuck

    def error_bound(self, t: float) -> float:
        """Range error [m] the readings used from the onset to the detection can carry (0 before one)."""
        if self.onset is None or self.detected_t is None:
            return 0.0
        return self.rate_mps * max(min(t, self.detected_t) - self.onset, 0.0)


class TiltCheck:
    """Does a navigation filter's tilt agree with the autopilot's attitude solution? (issue #30)

    A horizontal accelerometer bias ``b`` that an INS filter cannot tell from a tilt (position aids alone)
    is taken into its roll / pitch: the filter leaves the autopilot's (independent) attitude by
    ``~ b / g``. ``update(t, d)`` takes the roll / pitch difference [rad] (filter minus autopilot, at the same
    instant); above ``limit_rad`` for ``persist_s`` it flags (once): ``detected_t``, ``angle`` (the
    difference then) and ``onset``, when the difference last rose above half the limit (the bias began
    about then). ``position_bound()``: the horizontal error the unmodelled acceleration ``g sin(angle)`` can
    have built from the onset to the detection, ``g sin(angle) T^2 / 2``.
    """

    def __init__(self, limit_deg: float = 1.5, persist_s: float = 1.0):
        self.limit = math.radians(limit_deg)
        self.persist_s = float(persist_s)
        self.onset: float | None = None
        self._above: float | None = None
        self.detected_t: float | None = None
        self.angle = 0.0
        self.last = 0.0

    def update(self, t: float, d) -> bool:
        """One comparison; True at the flag (once)."""
        a = float(np.hypot(*np.asarray(d, float)[:2]))
        self.last = a
        if self.detected_t is not None:
            return False
        if a <= 0.5 * self.limit:
            self.onset, self._above = None, None
            return False
        if self.onset is None:
            self.onset = float(t)
        if a <= self.limit:
            self._above = None
            return False
        if self._above is None:
            self._above = float(t)
        if t - self._above >= self.persist_s:
            self.detected_t, self.angle = float(t), a
            return True
        return False

    def position_bound(self) -> float:
        if self.detected_t is None or self.onset is None:
            return 0.0
        T = self.detected_t - self.onset
        return 9.81 * math.sin(self.angle) * T * T / 2


register_stream("tilt_check", angle=("deg", "", "filter roll / pitch minus the autopilot's (navigation/integrity."
                                                  "TiltCheck)"))
