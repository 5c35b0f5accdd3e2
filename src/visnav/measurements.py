"""Typed messages that flow between blocks: measurements, truth, estimates, commands.

Every field is SI (metres, seconds, radians) unless its name carries a unit suffix
(YACS commands are in YACS units, +-500). Frames: world = local NED tangent plane,
body = FRD, camera = OpenCV (x right, y down, z along the optical axis).

Every measurement carries ``t``: the instant it *describes* (not the instant it was
delivered). The simulator delivers it at ``t + latency``; replay front ends deliver
it when the log says it arrived.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np


def _arr(x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class VehicleState:
    """Ground truth of a rigid vehicle (never given to a navigator)."""

    t: float
    position: np.ndarray  # NED of the vehicle reference point [m]
    velocity: np.ndarray  # NED [m/s]
    euler: np.ndarray  # roll, pitch, yaw [rad] (ZYX, body -> NED)
    body_rates: np.ndarray  # p, q, r [rad/s]
    specific_force: np.ndarray  # body FRD, what an ideal accelerometer reads [m/s^2]
    on_ground: bool = False

    @property
    def height_agl(self) -> float:
        """Height above the flat ground plane z = 0 [m]."""
        return float(-self.position[2])


@dataclass(frozen=True)
class ImuSample:
    t: float
    accel: np.ndarray  # specific force, body FRD [m/s^2]
    gyro: np.ndarray  # body rates [rad/s]


@dataclass(frozen=True)
class AttitudeSample:
    """Attitude solution of the vehicle's AHRS / flight computer (the thesis' 'IMU attitude').

    ``sensor`` names the unit when a vehicle carries more than one (CONDOR: ``"ahrs"`` of the autopilot,
    ``"camera"`` of the gimbal's mini-controller, which gives (roll, tilt, NaN): it has no heading)."""

    t: float
    euler: np.ndarray  # roll, pitch, yaw [rad]
    sensor: str = "ahrs"


@dataclass(frozen=True)
class GpsSample:
    t: float
    position: np.ndarray  # NED [m]
    velocity: np.ndarray  # NED [m/s]
    sigma: float = 0.02  # 1-sigma horizontal position noise [m]


@dataclass(frozen=True)
class RangeSample:
    """A range along a known direction of the sensor (laser along the camera axis, sonar down).

    ``range`` is NaN when there was no return. ``beam_offset`` is the angle of the beam
    that produced the return relative to the sensor's nominal axis (the PALACE laser
    searches +-3 deg for a return), positive towards the camera's image-down direction.
    """

    t: float
    range: float
    sensor: str = "laser"
    beam_offset: float = 0.0


@dataclass(frozen=True)
class Frame:
    t: float
    image: np.ndarray  # uint8 HxW
    index: int = 0


@dataclass(frozen=True)
class PanTiltFrame(Frame):
    """A frame from a camera on a pan-tilt unit, with the encoder angles at ``t`` [rad]
    (pan about body z, tilt = depression below the body x-y plane; ``geometry/mounts.PanTiltMount``)."""

    pan: float = 0.0
    tilt: float = 0.0


def read_only(obj):
    """``obj`` with every numpy array among its dataclass fields made read-only, and ``obj`` returned: for an
    output a cache hands out again, so that a caller writing into it raises instead of changing what the
    next caller gets."""
    for v in getattr(obj, "__dict__", {}).values():  # (a dataclass's fields are its instance attributes)
        if isinstance(v, np.ndarray):
            v.setflags(write=False)
    return obj


#: the frames an estimate's position and velocity are given in (``Estimate.frame``): name -> what it is (the TUM
#: header of a replay, ``app/navigators.NavigatorSpec.frame``)
FRAMES = {
    "ned": "NED world, body FRD",
    "deck_body": "deck-relative: deck origin relative to the vehicle in body FRD, deck -> body Euler",
    "target_ned": "target position: NED world, on the ground (down 0)",
}


class Estimate:
    """The typed base of every navigator's ``estimate(t)`` (issue #31 item 5): what any reader of any
    navigator may rely on.

    * ``t`` - the instant it describes [s];
    * ``position``, ``velocity`` - (n,) arrays, n = 3 (or 2 for a horizontal-only estimate), in ``frame``;
      velocity components the estimator does not estimate are NaN;
    * ``covariance`` - the estimate type's own covariance (its layout documented on the type);
      ``pv_covariance`` is the (2n, 2n) block of position then velocity taken from it (rows and columns of
      what is not estimated NaN), ``position_covariance`` its (n, n) position block;
    * ``valid`` - a bool: the position (and its covariance) can be flown on;
    * ``frame`` - a name of ``FRAMES``.

    Subclasses are frozen dataclasses that have these as fields or properties and say where position and
    velocity sit in their covariance (``position_index``, ``velocity_index``: None where not estimated).
    """

    t: float
    position: np.ndarray
    velocity: np.ndarray
    covariance: np.ndarray
    valid: bool
    frame: ClassVar[str] = "ned"
    position_index: ClassVar[tuple[int, ...]] = (0, 1, 2)
    velocity_index: ClassVar[tuple[int, ...] | None] = (3, 4, 5)

    @property
    def position_covariance(self) -> np.ndarray:
        i = self.position_index
        return np.asarray(self.covariance, float)[np.ix_(i, i)]

    @property
    def pv_covariance(self) -> np.ndarray:
        n = len(self.position_index)
        if self.velocity_index is None:
            C = np.full((2 * n, 2 * n), np.nan)
            C[:n, :n] = self.position_covariance
            return C
        i = self.position_index + self.velocity_index
        return np.asarray(self.covariance, float)[np.ix_(i, i)]


@dataclass(frozen=True)
class NavEstimate(Estimate):
    """A vehicle's state in NED: covariance (6, 6) of (position, velocity)."""

    t: float
    position: np.ndarray
    velocity: np.ndarray
    attitude: np.ndarray  # roll, pitch, yaw [rad]
    covariance: np.ndarray = field(default_factory=lambda: np.full((6, 6), np.nan))
    valid: bool = True
    source: str = "gps"  # gps | mpe | inertial


@dataclass(frozen=True)
class FixedWingEstimate(NavEstimate):
    """What a fixed-wing autopilot and its guidance fly on (CONDOR, geo-location MAV): the NavEstimate
    plus body rates (gyros), specific force (accelerometers), airspeed (pitot), height (baro), and the
    range / range rate to the target the orbit guidance needs (NaN when unknown)."""

    body_rates: np.ndarray = field(default_factory=lambda: np.zeros(3))  # p, q, r [rad/s]
    specific_force: np.ndarray = field(default_factory=lambda: np.zeros(3))  # body FRD [m/s^2]
    airspeed: float = float("nan")  # m/s
    height: float = float("nan")  # m above the ground
    ground_speed: float = float("nan")  # m/s (GPS; NaN without)
    radius: float = float("nan")  # m, horizontal range to the target
    radius_rate: float = 0.0  # m/s
    radius_valid: bool = False  # the range is fresh enough to fly on


@dataclass
class Health:
    """What a navigator reports about itself besides its estimate."""

    source: str = "gps"
    tracking: bool = False
    tracking_pending: bool = False  # a tracking request of the mission waits for a frame (PALACE)
    coherence: float = float("nan")
    tracked_px: tuple[float, float] = (float("nan"), float("nan"))
    mpe_rate_hz: float = 0.0
    mpe_jump: bool = False
    laser_ok: bool = True
    rejected_ranges: int = 0
    rejected_samples: int = 0
    reinitializations: int = 0
    notes: list[str] = field(default_factory=list)
    # integrity (estimation/integrity.py ``IntegrityMonitor.assess``): the same keys for every navigator
    integrity: str = "ok"  # ok | degraded | unusable
    integrity_reason: str = ""
    hpl_m: float = float("inf")  # horizontal protection level at ``hpl_probability``
    hpl_probability: float = 0.999
    consistency_k2: float = 1.0
    nis_per_dof: dict = field(default_factory=dict)  # update stream -> mean NIS / dof over the window
    rejected_share: dict = field(default_factory=dict)  # update stream -> share gated out over the window

    def set_integrity(self, assessment: dict) -> "Health":
        """Copy ``IntegrityMonitor.assess`` output into this health record (returns self)."""
        for k, v in assessment.items():
            setattr(self, k, v)
        return self


@dataclass(frozen=True)
class YacsCommand:
    """Inputs of the YACS-augmented R-MAX (seed 002 eq. 3.4), increments from trim, +-500."""

    t: float
    ail: float = 0.0
    ele: float = 0.0
    rud: float = 0.0
    thr: float = 0.0


@dataclass(frozen=True)
class TurnReference:
    """Reference of a fixed-wing autopilot (seed 004 Fig. 5.1): heading rates for the aileron (through the
    bank reference eq. 5.4) and the rudder (eq. 5.6; None: turn coordinator), the speed the bank
    reference uses, altitude and airspeed to hold."""

    t: float
    psidot_ail: float  # rad/s
    psidot_rud: float | None  # rad/s, None: turn coordinator
    v_bank: float  # m/s
    altitude: float  # m above the ground
    airspeed: float  # m/s


@dataclass(frozen=True)
class PositionReference:
    """The 'white rabbit' (seed 000 §2.1.2): where the vehicle should be now."""

    t: float
    position: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    yaw: float = 0.0
    source: str = "gps"  # which position source the controller must fly on


@dataclass(frozen=True)
class BaroSample:
    """Barometric altitude relative to the take-off point (up positive) [m]."""

    t: float
    altitude: float


@dataclass(frozen=True)
class HeadingSample:
    """Magnetic-compass heading (declination removed) [rad]."""

    t: float
    heading: float


@dataclass(frozen=True)
class AirspeedSample:
    """Indicated airspeed of a pitot-static probe [m/s]."""

    t: float
    airspeed: float


@dataclass(frozen=True)
class PanSample:
    """Gimbal pan angle relative to the airframe from its potentiometer [rad] (seed 004 Fig. 2.7)."""

    t: float
    pan: float


@dataclass(frozen=True)
class TargetRangeSample:
    """A vision fix of a ground target (seed 004 eq. 3.9-3.24): ground range, the target's bearing from
    the camera's pan axis (Psi_VB) and the pan potentiometer reading of the frame; ``t`` is the frame's instant."""

    t: float
    range: float  # m, horizontal
    bearing: float  # rad, Psi_VB
    pan: float  # rad, pan relative to the airframe


@dataclass(frozen=True)
class TelemetrySample:
    """One autopilot telemetry message (seed 002 §7.4: MAV state at 5 Hz): GPS position, the
    GPS-derived heading (course over ground: the compass was not used), barometric height above the
    take-off point, GPS ground speed. ``t`` is the instant the message claims to describe."""

    t: float
    position: np.ndarray  # NED [m] (GPS; the down component is not used, see ``height``)
    heading: float  # rad, course over ground from the GPS velocity
    height: float  # m above the take-off ground (barometer)
    ground_speed: float = float("nan")  # m/s


@dataclass(frozen=True)
class OperatorClick:
    """The ground operator selects the target in the frame of time ``t`` (seed 002 §7.3, §7.4.3)."""

    t: float
    pixel: np.ndarray  # (u, v) in the grabbed frame


@dataclass(frozen=True)
class TargetEstimate(Estimate):
    """A navigator's estimate of a ground target's horizontal position (a still target: no velocity
    estimated, ``velocity`` NaN); covariance (2, 2) of the position."""

    frame: ClassVar[str] = "target_ned"
    position_index: ClassVar[tuple[int, ...]] = (0, 1)
    velocity_index: ClassVar[tuple[int, ...] | None] = None

    t: float
    position: np.ndarray  # (north, east) [m]
    covariance: np.ndarray  # 2x2 [m^2]
    samples: int
    valid: bool
    method: str = "registration"  # registration | map_based

    @property
    def velocity(self) -> np.ndarray:
        return np.full(2, np.nan)


@dataclass
class Controls:
    """Control surface deflections [rad] and throttle (0..1) of the fixed wing (seed 004's autopilot output)."""

    aileron: float = 0.0
    elevator: float = 0.0
    rudder: float = 0.0
    throttle: float = 0.5


@dataclass(frozen=True)
class NavInit:
    """An explicit initialisation of a navigator (the thesis' surveyed start, a Vicon pose, an operator reset).

    The only way truth-derived numbers reach a navigator in simulation; whoever sends one logs it
    (stream ``nav_init``) so that a run says where its start came from. ``state`` holds the navigator's
    own state vector when it has one (deck UKF: 12 relative states); ``covariance`` its uncertainty.
    """

    t: float
    source: str  # "survey" | "truth+noise" | "operator" | "static" | ...
    position: np.ndarray | None = None
    velocity: np.ndarray | None = None
    attitude: np.ndarray | None = None
    state: np.ndarray | None = None
    covariance: np.ndarray | None = None


@dataclass(frozen=True)
class NavCommand:
    """A mission manager's request to its navigator: ``name`` says what, ``args`` how (navigator-specific keys).

    The navigator decides how to carry it out (``navigation/base.py``); an unknown name raises ``ValueError``.
    """

    t: float
    name: str
    args: dict = field(default_factory=dict)


@dataclass(frozen=True)
class RelativeStateSample:
    """An outside observer's view of the vehicle relative to a moving deck (motion capture, a safety pilot):
    the 12 relative states of ``estimation/deck.py`` (r, e, v, w_d; vehicle body frame) at ``t``, with the
    1-sigma of its noise per state."""

    t: float
    state: np.ndarray
    sigma: np.ndarray
    source: str = "pilot"  # pilot | mocap


@dataclass(frozen=True)
class AttitudeThrustCommand:
    """Inputs of a multirotor's attitude + thrust autopilot (the deck Y6's Pixhawk, seed 003 §2.2.2)."""

    t: float
    roll: float  # rad
    pitch: float  # rad
    yaw_rate: float  # rad/s
    throttle: float  # 0..1


@dataclass(frozen=True)
class DeckReference:
    """What the deck mission asks the deck controller for (level-deck frame: heading-free, z down, relative
    to the deck; ``control/deck.py``).

    ``kind``: ``level`` (hover level on the IMU, no position loop), ``follow`` (spring-damper on
    ``position`` / ``velocity`` plus the feed-forward ``accel``, eq. 4.25) or ``descend`` (thrust along
    ``normal``, sink at the final descent speed, horizontal hold on ``target``). ``target``: the body
    origin at contact; ``normal``: the predicted upward deck normal there; ``flare_time_left``: the
    trajectory's time to go when the flare may act (None: no flare). ``pilot_view``: the safety pilot's
    view of the relative state; when set the controller flies on it instead of the navigator's estimate.
    """

    t: float
    kind: str
    position: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel: np.ndarray = field(default_factory=lambda: np.zeros(3))
    target: np.ndarray | None = None
    normal: np.ndarray | None = None
    flare_time_left: float | None = None
    pilot_view: np.ndarray | None = None
    vertical_accel: float | None = None  # follow / descend: this vertical acceleration (z down) instead of the
    # position loop's / the sink-rate loop's on the estimate (the mission flies the height on the IMU)
