"""Scenario files: TOML validated by pydantic models.

A scenario has the sections ``[run] [world] [vehicle] [sensors.<name>] [navigation] [control] [mission]``, keyed by
role: ``[vehicle] kind``, ``[sensors.<name>] kind``, ``[navigation] kind`` and ``[mission] type`` pick one config
class each (pydantic unions on the tag); the mission type's suite (``scenarios/roles.SUITES``) gives the kinds
and the system's default values, so a file names only what it changes. Unknown keys are errors
(``extra="forbid"``), so is a key of a section the scenario's system does not fly (a sensor it has not, a kind
its builder does not take); every number has its allowed range, so a bad value is reported with its dotted key,
the value and the range, in one line. Files and ``--set`` keys of the mission-keyed layout before issue #13
(``mission.camera.*``, ``mission.filter.*``, ...) are translated (``roles.LEGACY``). The world (``[world]``, with
a system's own things under ``[world.<thing>]``: the deck, the maps, the pad, the targets) and the controller
gains (``[control.<system>]``) are not the mission's: what stood under ``[mission]`` before issue #31 is moved
(``roles.MOVED``), one warning line per old key naming the new one.
"""

from __future__ import annotations

import copy
import sys
import types
from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import BaseModel, Field, RootModel, ValidationError, field_validator, model_validator

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from visnav.scenarios import roles
from visnav.scenarios.base import ScenarioError, _M  # noqa: F401  (re-exported: one base for every config)
from visnav.scenarios.config_condor import (AirframeConfig, CondorCameraConfig, CondorControlConfig,
                                            CondorMissionConfig, CondorNavigationConfig, GimbalConfig, LinkConfig,
                                            TargetConfig)
from visnav.scenarios.config_deck import (DeckCameraConfig, DeckControlConfig, DeckFilterConfig, DeckImuConfig,
                                          DeckMissionConfig, DeckWorldConfig, MultirotorConfig, check_landing_point)
from visnav.scenarios.config_fixedwing import AhrsConfig, MemsImuConfig, PitotConfig
from visnav.scenarios.config_geolocation import (GeolocationMissionConfig, MavAirframeConfig, MavCameraConfig,
                                                 MavControlConfig, MavGimbalConfig, MavMapConfig, MavRegistrationConfig,
                                                 MavTargetConfig, MavTelemetryConfig)
from visnav.scenarios.config_pad import PadCameraConfig, PadFilterConfig, PadGeometryConfig, PadMissionConfig
from visnav.scenarios.config_sensors import BaroConfig, CompassConfig, GpsConfig
from visnav.scenarios.config_witas import WitasFilterConfig, WitasMapConfig, WitasMissionConfig
from visnav.scenarios.config_integrity import FaultConfig, PalaceIntegrityConfig, check_faults_apply
import hashlib
from visnav.guidance.hermite import HermitePath

BUILTIN_DIR = Path(__file__).resolve().parent


class RunConfig(_M):
    name: str = "unnamed"
    description: str = ""
    duration_s: float = Field(240.0, gt=0, le=7200)
    seed: int = Field(1, ge=0)
    dt_s: float = Field(0.01, gt=0.0005, le=0.02, description="dynamics / IMU step")


class WorldConfig(_M):
    """What the vehicle flies in, not what it does: the ground and the wind of every system, and a system's own
    things (``[world.<thing>]``, present exactly for the mission types of ``roles.WORLD``)."""

    surface: Literal["concrete", "asphalt", "grass", "gravel"] = "asphalt"
    field_size_m: float = Field(80.0, ge=10, le=400)
    map_resolution_m: float = Field(0.02, ge=0.002, le=1.0)
    detail_texture: bool = True
    map_file: Optional[str] = None
    wind_speed_mps: float = Field(3.0, ge=0, le=25)
    wind_from_deg: float = Field(0.0, ge=-360, le=360, description="relative to the initial heading")
    turbulence: Literal["none", "light", "moderate", "severe"] = "light"
    deck: Optional[DeckWorldConfig] = Field(None, description="the ship deck and its motion (deck)")
    witas_map: Optional[WitasMapConfig] = Field(None, description="the ground raster and the navigator's reference "
                                                "map (witas-homing)")
    pad: Optional[PadGeometryConfig] = Field(None, description="the three-circle pad, its shadow and lighting "
                                             "(pad-landing)")
    tent: Optional[TargetConfig] = Field(None, description="the blue tent (condor)")
    geo_map: Optional[MavMapConfig] = Field(None, description="the ground and its geo-referenced image "
                                            "(mav-geolocation)")
    truck: Optional[MavTargetConfig] = Field(None, description="the target truck (mav-geolocation)")


class PfcmControlConfig(_M):
    """The R-MAX path-following controller (``[control.pfcm]``, control/rmax_path.py, seed 002 §4.5)."""

    iterations: int = Field(1, ge=1, le=20, description="control-point feedback iterations per cycle (eq. 4.10)")
    roll_integral: bool = Field(True, description="lateral integral K3r ∫δp_y (wind)")
    roll_compensator: bool = Field(True, description="eq. 4.26 inner roll loop (lead + integral) on the "
                                   "YACS roll input, lateral gains designed on it")
    roll_margin_deg: float = Field(1.5, ge=0, le=15, description="roll command limit = phi_max + this")


class ControlConfig(_M):
    """Controller gains, one section per system that has settable ones (present exactly for the mission types of
    ``roles.CONTROL``)."""

    deck: Optional[DeckControlConfig] = None
    condor: Optional[CondorControlConfig] = None
    mav: Optional[MavControlConfig] = None
    pfcm: Optional[PfcmControlConfig] = None


class VehicleConfig(_M):
    """The Yamaha R-MAX (``vehicles/rmax.py``, seed 002 eq. 3.4 / 3.9)."""

    kind: Literal["rmax"] = "rmax"
    yaw_deg: float = Field(0.0, ge=-360, le=360)


class ImuConfig(_M):
    """The R-MAX flight computer's IMU and its attitude solution (``sensors/imu.Imu``), with an unknown delay."""

    kind: Literal["rmax-imu"] = "rmax-imu"
    rate_hz: float = Field(100.0, ge=10, le=1000)
    accel_noise: float = Field(0.02, ge=0, le=5, description="m/s^2 per sample, 1 sigma")
    gyro_noise: float = Field(0.002, ge=0, le=1, description="rad/s per sample")
    accel_bias: float = Field(0.01, ge=0, le=2, description="m/s^2, 1 sigma of the constant bias")
    gyro_bias: float = Field(0.0005, ge=0, le=0.5)
    attitude_noise_deg: float = Field(0.03, ge=0, le=5)
    latency_s: float = Field(0.0, ge=0, le=1.0, description="known transport delay (correctly time-stamped)")
    delay_s: float = Field(0.0, ge=0, le=1.0, description="UNKNOWN delay: data stamped delay_s too late")


class LaserConfig(_M):
    kind: Literal["laser"] = "laser"
    rate_hz: float = Field(10.0, ge=1, le=100)
    sigma0_m: float = Field(0.01, ge=0, le=1)
    sigma_per_m: float = Field(0.002, ge=0, le=0.1, description="sigma grows with range (seed 000 Fig. 3.4)")
    min_range_m: float = Field(0.7, ge=0, le=10)
    max_range_m: float = Field(80.0, ge=1, le=500)
    dropout: float = Field(0.02, ge=0, le=1, description="probability that one beam gives no return")
    search_deg: float = Field(3.0, ge=0, le=10)
    latency_s: float = Field(0.0, ge=0, le=1.0)
    delay_s: float = Field(0.0, ge=0, le=1.0)


class SonarConfig(_M):
    kind: Literal["sonar"] = "sonar"
    rate_hz: float = Field(20.0, ge=1, le=100)
    sigma_m: float = Field(0.01, ge=0, le=1)
    max_range_m: float = Field(5.0, ge=0.5, le=20)
    latency_s: float = Field(0.0, ge=0, le=1.0)


class CameraConfig(_M):
    """A camera rendering the textured ground on a fixed mount (``sensors/camera.Camera``): the R-MAX's (PALACE)
    and WITAS' downward one."""

    kind: Literal["camera"] = "camera"
    width: int = Field(640, ge=64, le=4096)
    height: int = Field(480, ge=48, le=4096)
    focal_px: float = Field(1073.0, gt=10, le=20000)
    depression_deg: float = Field(60.0, ge=0, le=90, description="optical axis below the body x axis")
    lever_arm_m: list[float] = Field(default_factory=lambda: [0.8, 0.0, -0.6])
    capture_hz: float = Field(30.0, ge=1, le=120)
    noise_sigma: float = Field(2.0, ge=0, le=50, description="grey levels")
    latency_s: float = Field(0.03, ge=0, le=1.0, description="exposure to memory (stamped correctly)")
    delay_s: float = Field(0.0, ge=0, le=1.0, description="UNKNOWN delay: image stamped delay_s too late")


class TrackerConfig(_M):
    template_px: int = Field(21, ge=5, le=101)
    search_radius_px: int = Field(30, ge=2, le=200)
    subpixel: bool = False
    mode: Literal["thesis", "anchored", "anchored-subpixel"] = "thesis"  # thesis = Alg. 2 as written
    min_coherence: float = Field(0.5, ge=-1, le=1)
    feature_size: int = Field(7, ge=1, le=31)
    min_isotropy: float = Field(0.2, ge=0, le=1)
    max_self_coherence: float = Field(0.9, ge=0, le=1, description="distinctness guard: skip a Förstner point "
                                      "whose template matches a copy within the search window at least this well "
                                      "(vision.correlation.self_coherence; 1 = off, the thesis)")


class MpeConfig(_M):
    model: Literal["thesis", "plane"] = "plane"
    attitude_delay_s: float = Field(0.0, ge=-0.5, le=1.0, description="compensation applied to attitude "
                                    "lookups: IMU delay minus camera delay (negative when the image is the late one)")
    laser_delay_s: float = Field(0.0, ge=-0.5, le=1.0, description="laser delay minus camera delay")
    rate_hz: float = Field(10.0, ge=1, le=30)
    jump_limit_m: float = Field(1.5, gt=0, le=50)
    range_sigma0_m: float = Field(0.0, ge=0, le=1, description="laser noise the filter assumes (0: pixels only)")
    range_sigma_per_m: float = Field(0.0, ge=0, le=0.1, description="its growth with range (seed 000 Fig. 3.4)")
    attitude_sigma_deg: float = Field(0.0, ge=0, le=5, description="attitude noise the filter assumes")


class NavigationConfig(_M):
    """The PALACE navigator (``navigation/palace.py``): tracker, MPE, position filter."""

    kind: Literal["palace"] = "palace"
    tracker: TrackerConfig = TrackerConfig()
    mpe: MpeConfig = MpeConfig()
    accel_noise: float = Field(0.3, ge=0, le=10, description="process noise of the position filter, m/s^2")
    # issue #30: the position filter estimates the accelerometer bias (NED, per axis) from the GPS / MPE /
    # sonar updates, so the final metre's dead reckoning runs on a corrected acceleration
    accel_bias_noise: float = Field(0.05, ge=0, le=5, description="random walk of the position filter's "
                                    "accelerometer-bias state, m/s^2/sqrt(s) (0: no bias state); 0.05 lets a "
                                    "0.3 m/s^2 step be followed within a few seconds of MPE fixes")
    accel_bias_sigma: float = Field(0.05, ge=0, le=5, description="1 sigma of that bias at the filter's start, "
                                    "m/s^2 (the simulated IMU's constant bias: 0.01)")
    accel_bias_alarm_mps2: float = Field(0.1, gt=0, le=10, description="estimated horizontal accelerometer "
                                         "bias above this -> integrity degraded (reported, compensated)")
    range_stuck_samples: int = Field(3, ge=2, le=100, description="this many laser / sonar ranges in a row "
                                     "identical while the vehicle moves vertically -> that sensor is stuck")
    range_stuck_min_change_m: float = Field(0.05, gt=0, le=10, description="the vertical motion over those "
                                            "samples (|v_z| x time) that must have changed the range for the test "
                                            "to apply")
    integrity: PalaceIntegrityConfig = PalaceIntegrityConfig()


class HoverMissionConfig(_M):
    """Hover on the glide slope at ``altitude_m`` with the tracker running (seed 000 §4.2, §5.2):
    ``mission.type = "hover"``; optional chirp at a cyclic actuator for frequency sweeps."""

    type: Literal["hover"] = "hover"
    point_m: list[float] = Field(default_factory=lambda: [0.0, 0.0])
    altitude_m: float = Field(12.0, ge=1, le=200)
    look_angle_deg: float = Field(60.0, ge=20, le=90, description="hover on the camera's line of sight")
    source: Literal["gps", "mpe"] = "gps"
    settle_s: float = Field(3.0, ge=0, le=60)
    coherence_threshold: float = Field(0.7, ge=-1, le=1)
    coherence_time_s: float = Field(2.0, ge=0, le=30)
    hold_s: float = Field(120.0, ge=0, le=3600)
    sweep_axis: Literal["none", "lateral", "longitudinal"] = "none"
    sweep_amplitude: float = Field(20.0, ge=0, le=500, description="YACS units")
    sweep_f0_hz: float = Field(0.05, gt=0, le=10)
    sweep_f1_hz: float = Field(3.0, gt=0, le=20)
    sweep_start_s: float = Field(5.0, ge=0, le=600)
    sweep_duration_s: float = Field(90.0, gt=0, le=3600)


class PalaceMissionConfig(_M):
    """PALACE landing (seed 000 Fig. 1.1): ``mission.type = "palace"``."""

    type: Literal["palace"] = "palace"
    landing_point_m: list[float] = Field(default_factory=lambda: [0.0, 0.0])
    start_height_m: float = Field(30.0, ge=2, le=200)
    glide_slope_deg: float = Field(60.0, ge=20, le=90)
    descent_speed_mps: float = Field(0.6, gt=0, le=5)
    settle_s: float = Field(3.0, ge=0, le=60)
    switch_height_m: float = Field(12.0, ge=1, le=100)
    coherence_threshold: float = Field(0.7, ge=-1, le=1)
    coherence_time_s: float = Field(2.0, ge=0, le=30)
    hold_s: float = Field(0.0, ge=0, le=600, description="hover under MPE at the switch height before descending")
    inertial_height_m: float = Field(1.0, ge=0.1, le=10)
    abort_climb_m: float = Field(5.0, ge=0, le=50)
    max_fallbacks: int = Field(3, ge=0, le=100, description="MPE -> GPS fallbacks before a soft abort")
    laser_loss_s: float = Field(0.5, ge=0, le=10, description="no laser return this long above 1 m -> soft abort")
    edge_margin_px: int = Field(60, ge=0, le=300)
    final_descent_mps: float = Field(0.3, gt=0, le=3)
    flare_height_m: float = Field(3.0, ge=0, le=30, description="sink rate eases to the final rate below this")
    integrity_unusable_s: float = Field(1.0, ge=0, le=60, description="navigator integrity unusable this long "
                                        "-> fallback to GPS (on MPE) or abort and go around (on GPS)")


class PfcmSpiralConfig(_M):
    """Level lead-in north from the origin, then a descending helix (seed 002 Fig. 4.9), then an
    optional steeper straight exit descent."""

    start_height_m: float = Field(40.0, ge=2, le=500)
    end_height_m: float = Field(10.0, ge=2, le=500)
    radius_m: float = Field(25.0, ge=5, le=500)
    turns: float = Field(1.5, gt=0, le=10)
    direction: Literal["left", "right"] = "left"
    lead_in_m: float = Field(60.0, ge=0, le=2000, description="level straight before the helix")
    segments_per_turn: int = Field(8, ge=4, le=64)
    exit_drop_m: float = Field(0.0, ge=0, le=200, description="height lost on the straight exit (part of the total)")
    exit_angle_deg: float = Field(35.0, gt=0, le=80, description="descent angle of the exit")


class PfcmMissionConfig(_M):
    """WITAS path following control mode (seed 002 ch. 4): ``mission.type = "pfcm"``.

    The path: ``path = "waypoints"`` (NED points with tangent directions, magnitudes by
    ``tangent_scale``), ``"segments"`` (the planner's 12 parameters per segment: p0, p1, ṗ0, ṗ1)
    or ``"spiral"`` (``[mission.spiral]``)."""

    type: Literal["pfcm"] = "pfcm"
    path: Literal["waypoints", "segments", "spiral"] = "waypoints"
    tangent_scale: Literal["arc", "chord", "given"] = "arc"
    waypoints_ned_m: list[list[float]] = Field(
        default_factory=lambda: [[0.0, 0.0, -20.0], [80.0, 0.0, -20.0], [140.0, 30.0, -20.0]])
    tangents: list[list[float]] = Field(default_factory=lambda: [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0]],
                                        validate_default=True)
    segments: list[list[float]] = Field(default_factory=list, validate_default=True,
                                        description="12 numbers each: p0, p1, t0, t1 (NED)")
    spiral: PfcmSpiralConfig = Field(default_factory=PfcmSpiralConfig, validate_default=True)
    v_cruise_mps: float = Field(5.0, gt=0, le=20)
    v_end_mps: float = Field(0.0, ge=0, le=20, description="speed at the end of the path")
    accel_mps2: float = Field(1.2, gt=0, le=5)
    r_max_deg_s: float = Field(40.0, gt=0, le=180)
    phi_max_deg: float = Field(15.0, gt=0, le=45)
    theta_max_deg: float = Field(15.0, gt=0, le=45)
    nz_max: float = Field(1.1, gt=1, le=3)
    vrs_steep_angle_deg: float = Field(30.0, gt=0, lt=90)
    vrs_steep_descent_mps: float = Field(1.5, gt=0, le=10)
    vrs_shallow_descent_mps: float = Field(3.0, gt=0, le=10)
    anticipate_limits: bool = True
    settle_s: float = Field(2.0, ge=0, le=60)
    end_tolerance_m: float = Field(0.5, gt=0, le=20)
    hold_s: float = Field(2.0, ge=0, le=600, description="hover at the end of the path before finishing")

    # the path is checked here, before the run starts (a bad one names its segment)
    @field_validator("tangents")
    @classmethod
    def _waypoint_path(cls, tangents, info):
        d = info.data
        if d.get("path") != "waypoints" or "waypoints_ned_m" not in d:
            return tangents
        pts = d["waypoints_ned_m"]
        for name, rows in (("waypoints_ned_m", pts), ("tangents", tangents)):
            bad = [i for i, p in enumerate(rows) if len(p) != 3]
            if bad:
                raise ValueError(f"mission.{name}[{bad[0]}] must have 3 values (north, east, down)")
        if len(tangents) != len(pts):
            raise ValueError(f"{len(tangents)} tangents for {len(pts)} waypoints")
        if any(p[2] > 0 for p in pts):
            raise ValueError("waypoints_ned_m: down coordinates must be <= 0 (above the ground)")
        HermitePath.from_waypoints(pts, tangents, scale=d.get("tangent_scale", "arc"))
        return tangents

    @field_validator("segments")
    @classmethod
    def _segment_path(cls, segments, info):
        if info.data.get("path") != "segments":
            return segments
        if not segments or any(len(s) != 12 for s in segments):
            raise ValueError("mission.segments must be a list of 12-number segments (p0, p1, t0, t1)")
        HermitePath.from_segments(segments)
        return segments

    @field_validator("spiral")
    @classmethod
    def _spiral_path(cls, sp, info):
        if info.data.get("path") == "spiral" and 0 < sp.exit_drop_m >= sp.start_height_m - sp.end_height_m:
            raise ValueError("exit_drop_m must be smaller than start_height_m - end_height_m")
        return sp


# Every mission's config, told apart by its ``type`` (add new ones to this tuple). A mission that
# flies another vehicle keeps its own config module (scenarios/config_<mission>.py, built on
# scenarios/base.py) and its builder of the loop's parts (registered in app/missions.py, @register).
MISSION_CONFIGS: tuple[type[BaseModel], ...] = (PalaceMissionConfig, HoverMissionConfig, PfcmMissionConfig,
                                                WitasMissionConfig, CondorMissionConfig, DeckMissionConfig,
                                                GeolocationMissionConfig, PadMissionConfig)
MissionConfig = (
    Annotated[Union[MISSION_CONFIGS], Field(discriminator="type")]  # type: ignore[valid-type]
    if len(MISSION_CONFIGS) > 1
    else MISSION_CONFIGS[0]
)
MISSION_TYPES = {m.model_fields["type"].default: m for m in MISSION_CONFIGS}


def _union(classes: tuple[type[BaseModel], ...], tag: str):
    return Annotated[Union[classes], Field(discriminator=tag)]  # type: ignore[valid-type]


#: one config class per kind and role (a system's suite, roles.SUITES, names the kinds it flies)
VEHICLE_KINDS: tuple[type[BaseModel], ...] = (VehicleConfig, MultirotorConfig, AirframeConfig, MavAirframeConfig)
SENSOR_KINDS: tuple[type[BaseModel], ...] = (
    ImuConfig, DeckImuConfig, MemsImuConfig, GpsConfig, LaserConfig, SonarConfig, BaroConfig, CompassConfig,
    AhrsConfig, PitotConfig, CameraConfig, DeckCameraConfig, PadCameraConfig, CondorCameraConfig, MavCameraConfig,
    GimbalConfig, MavGimbalConfig, MavTelemetryConfig, LinkConfig)
NAVIGATION_KINDS: tuple[type[BaseModel], ...] = (NavigationConfig, WitasFilterConfig, PadFilterConfig, DeckFilterConfig,
                                                 CondorNavigationConfig, MavRegistrationConfig)
KINDS = {role: {c.model_fields["kind"].default: c for c in classes}
         for role, classes in (("vehicle", VEHICLE_KINDS), ("sensors", SENSOR_KINDS), ("navigation", NAVIGATION_KINDS))}
SensorConfig = _union(SENSOR_KINDS, "kind")


class SensorsConfig(RootModel[dict[str, SensorConfig]]):  # type: ignore[valid-type]
    """The scenario's sensors by name (``[sensors.<name>] kind = ...``); ``sensors.imu`` reads ``sensors["imu"]``."""

    root: dict[str, SensorConfig] = Field(default_factory=dict)  # type: ignore[valid-type]

    def __getattr__(self, name: str):
        root = self.__dict__.get("root", {})
        if name in root:
            return root[name]
        raise AttributeError(f"the scenario has no sensor {name!r} (its sensors: {', '.join(root) or 'none'})")

    def __getitem__(self, name: str):
        return self.root[name]

    def __contains__(self, name: str) -> bool:
        return name in self.root

    def __iter__(self):
        return iter(self.root)

    def items(self):
        return self.root.items()


class Scenario(_M):
    run: RunConfig = RunConfig()
    world: WorldConfig = WorldConfig()
    vehicle: _union(VEHICLE_KINDS, "kind") = VehicleConfig()  # type: ignore[valid-type]
    sensors: SensorsConfig = SensorsConfig()
    navigation: _union(NAVIGATION_KINDS, "kind") = NavigationConfig()  # type: ignore[valid-type]
    control: ControlConfig = ControlConfig()
    mission: MissionConfig = PalaceMissionConfig()
    faults: list[FaultConfig] = Field(default_factory=list, description="injected faults (sensors/faults.py)")

    @model_validator(mode="before")
    @classmethod
    def _suite(cls, data):
        """The roles the mission type's system flies, its kinds and default values (roles.SUITES)."""
        if isinstance(data, dict):
            if roles.is_legacy(data):  # the mission-keyed layout before issue #13
                data = roles.migrate(data, _RMAX_OLD_DEFAULTS)
            return roles.fill_suite(roles.move(data, say=_say))  # world content and gains out of [mission] (#31)
        return data

    @model_validator(mode="after")
    def _deck_filter_sea_state(self):
        nav, m, deck = self.navigation, self.mission, self.world.deck
        if isinstance(m, DeckMissionConfig) and deck is not None:
            check_landing_point(m.guidance.landing_point_m, deck)
        if isinstance(nav, DeckFilterConfig) and nav.sea_state is None and deck is not None:
            # the nominal sea state of the deck the scenario names (the filter never sees motion_scale)
            nav.sea_state = deck.sea_state if deck.motion == "moving" else "calm"
        return self


def _say(line: str) -> None:
    """A key of the layout before issue #31 was read at its new place: one warning line on stderr."""
    print(f"warning: {line}", file=sys.stderr)


# ---------------------------------------------------------------------------------------------
#: Keys of a system's sections that its simulation never reads although the section is its own (the world is
#: shared; a few keys of a shared kind): mission.type -> [(key prefix, keys under it that do apply, where the
#: mission takes that instead)]. Setting one of them to anything but its default is an error (a resolved
#: scenario.toml, which holds every key at its default, still loads). Whole sections a system does not fly are
#: not in its suite (roles.SUITES) and fail there.
_WIND = ("wind_speed_mps", "wind_from_deg", "turbulence")


def _fixed_wing(world: str, own: tuple[str, ...]) -> list[tuple[str, tuple[str, ...], str]]:
    return [("world", _WIND + own, f"its world is the wind (world.{', world.'.join(_WIND)}) and {world}")]


_NO_FAULTS = "its simulation injects no faults (issue #18: the R-MAX, deck and CONDOR missions do)"
NOT_APPLICABLE: dict[str, list[tuple[str, tuple[str, ...], str]]] = {
    "deck": [("world", ("deck",), "its world is the ship deck, world.deck.*")],
    "condor": _fixed_wing("the tent (world.tent.*)", ("tent",)),
    "mav-geolocation": _fixed_wing("the map and the truck (world.geo_map.*, world.truck.*)", ("geo_map", "truck"))
    + [("faults", (), _NO_FAULTS)],
    "witas-homing": [("sensors.baro.t_measured_c", (), "its navigator makes no eq. 2.1 temperature correction")],
    "pad-landing": [("sensors.imu.rate_hz", (), "its IMU rates are navigation.gyro_hz and navigation.accel_hz")],
    "pfcm": [
        ("navigation.tracker", (), "it flies on GPS: no camera, no tracker"),
        ("navigation.mpe", (), "it flies on GPS: no camera, no MPE"),
        ("sensors.camera", ("depression_deg", "lever_arm_m"), "it flies on GPS: the camera's mount carries the "
         "laser, no frame is taken"),
    ],
}


def _leaves(data: Any, path: tuple[str, ...] = ()):
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _leaves(v, path + (str(k),))
    else:
        yield path


def not_applicable(key: str, mission_type: str) -> str | None:
    """Why the dotted ``key`` does not apply to ``mission_type`` (None: it applies)."""
    parts = key.split(".")
    for prefix, keep, hint in NOT_APPLICABLE.get(mission_type, ()):
        pre = prefix.split(".")
        if parts[: len(pre)] == pre and not (len(parts) > len(pre) and parts[len(pre)] in keep):
            return hint
    return None


def _check_applicable(data: dict, sc: Scenario) -> None:
    """One line for the first key set in ``data`` that ``sc``'s mission ignores (to a non-default value)."""
    kind = getattr(sc.mission, "type", "palace")
    if kind not in NOT_APPLICABLE:
        return
    default = Scenario(mission=MISSION_TYPES[kind]())
    for path in _leaves({k: v for k, v in data.items() if k != "mission"}):
        key = ".".join(path)
        hint = not_applicable(key, kind)
        if hint is None:
            continue
        value, ref = sc, default
        for p in path:
            value, ref = _child(value, p), _child(ref, p)
        if value != ref:
            raise ScenarioError(f"{key} does not apply to mission.type {kind!r} ({hint})")


def _child(model: Any, name: str) -> Any:
    if isinstance(model, SensorsConfig):
        return model.root.get(name)
    return getattr(model, name, None)


_ROLE_TAGS = {"mission": MISSION_TYPES, "vehicle": KINDS["vehicle"], "navigation": KINDS["navigation"]}


def _clean_loc(loc: list[str]) -> list[str]:
    """Drop the tag pydantic puts in the path of a union member (mission.palace.x, sensors.imu.rmax-imu.x)."""
    if len(loc) > 1 and loc[0] in _ROLE_TAGS and loc[1] in _ROLE_TAGS[loc[0]]:
        return [loc[0]] + loc[2:]
    if len(loc) > 2 and loc[0] == "sensors" and loc[2] in KINDS["sensors"]:
        return loc[:2] + loc[3:]
    return loc


def _model_at(path: list[str], kinds: dict[str, str] | str | None = None) -> type[BaseModel] | None:
    """The config class at the dotted ``path``; ``kinds``: the scenario's role tags ({"mission": type,
    "vehicle": kind, "navigation": kind, "sensors.<name>": kind}; a string: the mission type)."""
    if not isinstance(kinds, dict):
        kinds = {"mission": kinds or "palace"}
    model: Any = Scenario
    path = list(path)
    if path[:1] == ["sensors"]:
        if len(path) < 2:
            return None
        model = KINDS["sensors"].get(kinds.get("sensors." + path[1], ""))
        path = path[2:]
    for p in path:
        if model is Scenario and p in ("mission", "vehicle", "navigation"):
            default = roles.SUITES.get(kinds.get("mission", "palace"), roles.SUITES["palace"])
            tag = kinds.get(p) or (kinds.get("mission", "palace") if p == "mission" else default[p]["kind"])
            model = _ROLE_TAGS[p].get(tag)
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or p not in model.model_fields:
            return None
        model = _optional(model.model_fields[p].annotation)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _optional(ann: Any) -> Any:
    """X of ``Optional[X]`` (a system's own world or control section), else ``ann``."""
    args = [a for a in getattr(ann, "__args__", ()) if a is not type(None)]
    if len(args) == 1 and (getattr(ann, "__origin__", None) is Union or isinstance(ann, types.UnionType)):
        return args[0]
    return ann


def describe_field(parent: type[BaseModel] | None, name: str) -> str:
    """``allowed: ...`` of field ``name`` of ``parent`` (its bounds or its literals)."""
    if parent is None or name not in parent.model_fields:
        return ""
    f = parent.model_fields[name]
    bounds = []
    for m in f.metadata:
        for attr, sym in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<")):
            v = getattr(m, attr, None)
            if v is not None:
                bounds.append(f"{sym} {v}")
    ann = f.annotation
    args = getattr(ann, "__args__", None)
    if getattr(ann, "__origin__", None) is Literal or (args and all(isinstance(a, str) for a in args)):
        return "allowed: " + ", ".join(repr(a) for a in args)
    return ("allowed: " + " and ".join(bounds)) if bounds else ""


def _describe_field(loc: list[str], kinds: dict[str, str] | str | None = None) -> str:
    return describe_field(_model_at(loc[:-1], kinds), loc[-1])


def _kinds(data: dict) -> dict[str, str]:
    """The role tags of a (suite-filled) scenario dict."""
    out = {"mission": roles.mission_type_of(data)}
    for role in ("vehicle", "navigation"):
        k = roles._kind_of(data.get(role))
        if isinstance(k, str):
            out[role] = k
    sensors = data.get("sensors")
    sensors = getattr(sensors, "root", sensors)
    if isinstance(sensors, dict):
        for name, v in sensors.items():
            k = roles._kind_of(v)
            if isinstance(k, str):
                out["sensors." + name] = k
    return out


def _format_error(err: ValidationError, data: dict) -> str:
    e = err.errors()[0]
    raw = [str(x) for x in e["loc"]]
    kinds = _kinds(data)
    loc = _clean_loc(raw)
    key = ".".join(loc)
    if e["type"] == "union_tag_invalid":
        tag = "type" if loc and loc[0] == "mission" else "kind"
        allowed = (MISSION_TYPES if loc[0] == "mission" else KINDS.get(loc[0], {}))
        return f"invalid value for '{key}.{tag}': {e.get('input', {}).get(tag)!r}; allowed: " + ", ".join(
            repr(k) for k in allowed)
    if e["type"] == "extra_forbidden":
        parent = _model_at(loc[:-1], kinds)
        allowed = ", ".join(k for k in parent.model_fields if k != "kind") if parent else ""
        if parent is not None and "kind" in parent.model_fields and loc[0] in ("vehicle", "sensors", "navigation"):
            section = ".".join(loc[:2] if loc[0] == "sensors" else loc[:1])
            what = f"({section} is kind {kinds.get(section)!r}; allowed keys here: {allowed})"
            if any(loc[-1] in c.model_fields for c in KINDS[loc[0]].values()):  # a key of another kind
                return f"{key} does not apply to mission.type {kinds['mission']!r} {what}"
            return f"unknown scenario key '{key}' {what}"
        return f"unknown scenario key '{key}'; allowed keys here: {allowed}"
    if not loc:  # a check across sections (the deck landing point on world.deck's plate)
        return str(e["msg"]).removeprefix("Value error, ")
    value = e.get("input")
    desc = _describe_field(loc, kinds)
    msg = f"invalid value for '{key}': {value!r} ({e['msg']})"
    return msg + (f"; {desc}" if desc else "")


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text  # bare string


def apply_overrides(data: dict, overrides: list[str]) -> dict:
    """Apply ``key.path=value`` overrides (values parsed as TOML, else kept as strings)."""
    data = copy.deepcopy(data)
    for ov in overrides:
        if "=" not in ov:
            raise ScenarioError(f"override '{ov}' is not of the form key.path=value")
        key, text = ov.split("=", 1)
        parts = [p for p in key.strip().split(".") if p]
        if not parts:
            raise ScenarioError(f"override '{ov}' has an empty key")
        node = data
        for p in parts[:-1]:
            nxt = node.setdefault(p, {})
            if not isinstance(nxt, dict):
                raise ScenarioError(f"override '{ov}': '{p}' is a value, not a section")
            node = nxt
        node[parts[-1]] = _parse_value(text.strip())
    return data


#: the R-MAX sections' defaults in the old layout (what every old resolved scenario.toml holds)
_RMAX_OLD_DEFAULTS = {".".join(p): v for p, v in roles._leaves({
    "vehicle": {"model": "rmax", **VehicleConfig().model_dump(exclude={"kind"})},
    "sensors": {n: c().model_dump(exclude={"kind"}) for n, c in (("imu", ImuConfig), ("gps", GpsConfig),
                ("laser", LaserConfig), ("sonar", SonarConfig), ("camera", CameraConfig))},
    "navigation": NavigationConfig().model_dump(exclude={"kind"})})}


def validate(data: dict) -> Scenario:
    if roles.is_legacy(data):
        data = roles.migrate(data, _RMAX_OLD_DEFAULTS)
    data = roles.fill_suite(roles.move(data, say=_say))
    try:
        sc = Scenario.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(_format_error(err, data)) from None
    _check_applicable(data, sc)
    try:
        check_faults_apply(sc.mission.type, sc.faults)
    except ValueError as err:
        raise ScenarioError(str(err)) from None
    return sc


def builtin_names() -> list[str]:
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.toml"))


def resolve_path(name_or_path: str) -> Path:
    """A built-in name is the built-in scenario unless the argument is an existing *file* ending in
    ``.toml``; anything else (a folder named like a scenario, a missing file) is one clear error."""
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.is_file():
        return p
    cand = BUILTIN_DIR / f"{name_or_path}.toml"
    if "/" not in name_or_path and "\\" not in name_or_path and cand.is_file():
        return cand
    names = ", ".join(builtin_names())
    if p.is_dir():
        raise ScenarioError(f"'{name_or_path}' is a directory, not a scenario: give a built-in name ({names}) "
                            "or a .toml file")
    if p.exists():
        raise ScenarioError(f"'{name_or_path}' is not a .toml file nor a built-in scenario; built-in: {names}")
    if p.suffix == ".toml":
        raise ScenarioError(f"scenario file not found: {p}")
    raise ScenarioError(f"unknown scenario '{name_or_path}'; built-in scenarios: {names}")


def load_scenario(name_or_path: str, overrides: list[str] | None = None, seed: int | None = None) -> Scenario:
    path = resolve_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read the scenario file ({exc})") from None
    data = apply_overrides(data, list(overrides or []))
    if seed is not None:
        data.setdefault("run", {})["seed"] = int(seed)
    try:
        return validate(data)
    except ScenarioError as err:  # one line that names the scenario
        raise ScenarioError(f"scenario {name_or_path}: {err}") from None


def to_toml(sc: Scenario) -> str:
    import tomli_w

    def clean(x):  # None and sections left empty (a system without [control.<system>]) are left out
        if isinstance(x, dict):
            out = {k: clean(v) for k, v in x.items() if v is not None}
            return {k: v for k, v in out.items() if v != {}}
        return x

    return tomli_w.dumps(clean(sc.model_dump()))


def scenario_hash(sc: Scenario, *, ignore_seed: bool = False) -> str:
    """SHA-256 (hex) of the fully resolved scenario's canonical TOML: the identity of a configuration
    (provenance of a run; the resume key of a campaign, there with ``ignore_seed=True``)."""

    if ignore_seed:
        sc = sc.model_copy(update={"run": sc.run.model_copy(update={"seed": 0})})
    return hashlib.sha256(to_toml(sc).encode()).hexdigest()
