"""How fresh the bridge's inputs are, and what that does to the estimate it sends (issue 30, item 1).

Every input stream of the live bridge has a freshness budget. The estimate a navigator gives at instant
``t`` was made from samples of each stream up to that stream's newest stamp; when a stream stops (the
autopilot stopped, the link was cut, the camera stalled, IMU messages arrive late), the navigator may keep
extrapolating with a covariance that no longer grows. The bridge therefore does not send the navigator's
covariance as it is: it adds what the missing inputs can no longer rule out, and stops sending past a
timeout.

Streams (``STREAMS``) and their defaults (``DEFAULT_BUDGETS``, every figure configurable through
``BridgeConfig.freshness``):

============  ==========  ==========  ===========  ======  ===============================================
stream        budget [s]  timeout [s] a [m/s^2]    axes    applies while the estimate's source is
============  ==========  ==========  ===========  ======  ===============================================
imu           0.2         1.0         2.0          x y z   any (IMU and attitude: the propagation itself)
gps           0.5         --          0.1          x y z   ``gps`` (a GPS-following estimate)
height        0.5         --          0.1          z       any (range finder and barometer)
camera        1.0         10.0        0.1          x y z   a vision source (mpe, vision, registration, camera)
============  ==========  ==========  ===========  ======  ===============================================

* ``budget``: a stream older than this is *stale*: GPS_INPUT drops from a 3D to a 2D fix.
* ``timeout``: a stream older than this is *expired*: no estimate is sent (the bridge says so once, and
  once when estimates resume); ``--`` never stops the output (losing GPS is the GPS-denied case the
  navigators are built for; the height streams only widen the vertical sigma).
* ``a``: the acceleration nobody observes while the stream is missing. For the IMU it is the vehicle's own
  manoeuvring (2 m/s^2 ~ 0.2 g, a multirotor banking ~12 deg: the SIL stand-in's circle flies 1.25 m/s^2);
  for the aiding streams it is an INS's residual drift (accelerometer bias and attitude error, 0.1 m/s^2).

The model (inertial drift of an unobserved constant acceleration a ~ N(0, a_k^2) over the age tau_k of
stream k, on the stream's axes):

    dp = 0.5 a tau^2,  dv = a tau                                                   (1)
    Q_k = a_k^2 [[tau^4/4, tau^3/2], [tau^3/2, tau^2]]   per axis, over (p, v)      (2)

and the filter's own covariance P (6x6 over position, velocity) is carried over the IMU's age with the
constant-velocity transition (the navigator extrapolates without propagating its covariance):

    F = [[I, tau_imu I], [0, I]],   P' = F P F^T + sum_k Q_k                        (3)

A gap in the IMU outlives the gap: the navigator extrapolated across it, and its error stays when the IMU
is back. A gap longer than the IMU's budget is therefore remembered (its length added to the IMU's age,
``tau_imu = age + gaps``) until an aiding stream that applies to the estimate (GPS, camera) delivers a sample
stamped after the gap; so after the autopilot's data stopped for longer than the timeout, estimates resume
once the IMU *and* the aiding are back (a dead-reckoning estimate, no aiding applying, is not sent again).

The quality (``mavlink_messages.quality_from``), ODOMETRY's and VISION_*'s covariances and GPS_INPUT's
accuracies are computed from P', so they fall / grow with every stream's age and with the filter's own
covariance. A stream that has never delivered a sample is not judged (a vehicle without a range finder).
Ages are measured on the samples' own stamps (the autopilot's clock mapped to ours), so a late sample
counts as old as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from visnav.io.mavlink_messages import horizontal_sigma, mavlink
from visnav.measurements import AttitudeSample, BaroSample, GpsSample, ImuSample, NavEstimate, RangeSample

STREAMS = ("imu", "gps", "height", "camera")
LABELS = {"imu": "IMU/attitude", "gps": "GPS", "height": "range/baro", "camera": "camera"}
VISION_SOURCES = ("mpe", "vision", "registration", "camera")


@dataclass(frozen=True)
class StreamBudget:
    budget_s: float  # older: stale (GPS_INPUT 2D fix)
    timeout_s: float | None  # older: no estimate is sent; None: never stops the output
    accel_mps2: float  # acceleration unobserved while the stream is missing, eq. (1)-(2)
    axes: tuple[int, ...] = (0, 1, 2)  # NED axes it bounds
    sources: tuple[str, ...] | None = None  # estimate sources it applies to (None: every source)


DEFAULT_BUDGETS = {
    "imu": StreamBudget(0.2, 1.0, 2.0),  # 0.2 s: ten samples at 50 Hz (a busy companion computer's hiccup)
    "gps": StreamBudget(0.5, None, 0.1, sources=("gps",)),
    "height": StreamBudget(0.5, None, 0.1, axes=(2,)),
    "camera": StreamBudget(1.0, 10.0, 0.1, sources=VISION_SOURCES),
}


@dataclass
class FreshnessConfig:
    budgets: dict = field(default_factory=lambda: dict(DEFAULT_BUDGETS))
    fix3_max_h_acc_m: float = 10.0  # GPS_INPUT: a 3D fix only while the horizontal accuracy is within this

    def with_overrides(self, **streams: StreamBudget | dict) -> "FreshnessConfig":
        """A copy with some streams' budgets replaced (a StreamBudget, or a dict of its fields to change)."""
        b = dict(self.budgets)
        for k, v in streams.items():
            if k not in STREAMS:
                raise ValueError(f"unknown bridge input stream {k!r} (known: {', '.join(STREAMS)})")
            b[k] = v if isinstance(v, StreamBudget) else replace(b[k], **v)
        return FreshnessConfig(b, self.fix3_max_h_acc_m)


def stream_of(m) -> str | None:
    """The stream a decoded measurement belongs to (None: not a judged stream)."""
    if isinstance(m, (ImuSample, AttitudeSample)):
        return "imu"
    if isinstance(m, GpsSample):
        return "gps"
    if isinstance(m, (RangeSample, BaroSample)):
        return "height"
    return None


@dataclass(frozen=True)
class Assessment:
    estimate: NavEstimate  # the navigator's estimate with the covariance P' of eq. (3)
    ages: dict  # stream -> age [s] at the estimate's instant, of the streams that apply
    stale: tuple[str, ...]  # past their budget
    expired: tuple[str, ...]  # past their timeout: do not send

    @property
    def send(self) -> bool:
        return not self.expired

    def reason(self) -> str:
        return ", ".join(f"no {LABELS[k]} for {self.ages[k]:.1f} s" for k in (self.expired or self.stale))


def inflate(P: np.ndarray, ages: dict, budgets: dict) -> np.ndarray:
    """Eq. (3): the 6x6 [position, velocity] covariance carried over the IMU's age, plus eq. (2) per stream."""
    P = np.asarray(P, float)
    tau_imu = ages.get("imu", 0.0)
    F = np.eye(6)
    F[:3, 3:] = np.eye(3) * tau_imu
    out = F @ P[:6, :6] @ F.T
    for k, tau in ages.items():
        a = budgets[k].accel_mps2
        for ax in budgets[k].axes:
            i, j = ax, ax + 3
            out[i, i] += a**2 * tau**4 / 4.0
            out[i, j] += a**2 * tau**3 / 2.0
            out[j, i] += a**2 * tau**3 / 2.0
            out[j, j] += a**2 * tau**2
    return out


class Freshness:
    """The newest stamp of every stream, and what an estimate at instant ``t`` may claim."""

    def __init__(self, cfg: FreshnessConfig | None = None):
        self.cfg = cfg or FreshnessConfig()
        self.newest: dict[str, float] = {}
        self.imu_gaps_s = 0.0  # IMU gaps longer than its budget not yet corrected by an aiding sample
        self.imu_gap_end = -np.inf

    def seen(self, stream: str, t: float) -> None:
        if not np.isfinite(t):
            return
        prev = self.newest.get(stream, -np.inf)
        if stream == "imu" and np.isfinite(prev) and t - prev > self.cfg.budgets["imu"].budget_s:
            self.imu_gaps_s += t - prev
            self.imu_gap_end = t
        self.newest[stream] = max(t, prev)

    def _gaps(self, source: str) -> float:
        """The IMU gaps an estimate of ``source`` still carries (none once an applicable aiding sample came after)."""
        if self.imu_gaps_s == 0.0:
            return 0.0
        for k, b in self.cfg.budgets.items():
            if k not in ("imu", "height") and (b.sources is None or source in b.sources) \
                    and self.newest.get(k, -np.inf) > self.imu_gap_end:
                self.imu_gaps_s = 0.0  # corrected: forgotten
                return 0.0
        return self.imu_gaps_s

    def ages(self, t: float, source: str) -> dict:
        """Age [s] at ``t`` of every stream seen so far that applies to an estimate of ``source``."""
        out = {}
        for k, b in self.cfg.budgets.items():
            if k in self.newest and (b.sources is None or source in b.sources):
                out[k] = max(0.0, t - self.newest[k])
        if "imu" in out:
            out["imu"] += self._gaps(source)
        return out

    def assess(self, est: NavEstimate) -> Assessment:
        ages = self.ages(est.t, est.source)
        B = self.cfg.budgets
        stale = tuple(k for k, a in ages.items() if a > B[k].budget_s)
        expired = tuple(k for k, a in ages.items() if B[k].timeout_s is not None and a > B[k].timeout_s)
        P = np.asarray(est.covariance, float)
        if P.shape[0] >= 6 and np.all(np.isfinite(P[:6, :6])):
            Pn = P.copy()
            Pn[:6, :6] = inflate(P, ages, B)
            est = replace(est, covariance=Pn)
        return Assessment(est, ages, stale, expired)

    def fix_type(self, a: Assessment) -> int:
        """GPS_INPUT fix type: no fix when invalid or withheld, 2D when a stream is stale or the horizontal
        accuracy is worse than ``fix3_max_h_acc_m``, else 3D."""
        P = np.asarray(a.estimate.covariance, float)
        if not a.estimate.valid or a.expired or not np.all(np.isfinite(P[:3, :3])):
            return mavlink.GPS_FIX_TYPE_NO_FIX
        if a.stale or horizontal_sigma(P) > self.cfg.fix3_max_h_acc_m:
            return mavlink.GPS_FIX_TYPE_2D_FIX
        return mavlink.GPS_FIX_TYPE_3D_FIX
