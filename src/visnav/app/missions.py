"""What a scenario's ``mission.type`` flies with: the parts of the one loop (``app/loop.py``).

A builder takes a ``BuildContext`` (the scenario, the log's recorder, the run's random generators) and
returns the ``MissionParts`` (``sim/parts.py``): every part of its system, stated. The simulation builds
nothing else: a builder asks for the textured world (``ctx.textured_world()``) or the standard R-MAX sensors
(``ctx.rmax_sensors()``) only when its mission uses them. A new mission registers its builder here with
``@register("name")`` (and its pydantic config in ``scenarios/schema.py``). The R-MAX's missions take the
helicopter's parts from ``app/rmax_parts.rmax_parts``; the other systems build theirs in
``app/deck_parts.py``, ``app/condor_parts.py``, ``app/geoloc_parts.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from visnav.sim.parts import GroundTest, MissionParts, Step
from visnav.analysis.metrics import palace_metrics, hover_metrics
from visnav.analysis.path_metrics import pfcm_metrics
from visnav.app.navigators import rmax_camera, make_navigator
from visnav.app.rmax_parts import rmax_parts
import importlib

Builder = Callable[["BuildContext"], "MissionParts | GroundTest"]
REGISTRY: dict[str, Builder] = {}

#: the missions the R-MAX flies (the others fly their own vehicle, from their own parts)
RMAX_MISSIONS = ("palace", "hover", "pfcm", "witas-homing", "pad-landing")

#: the one loop, which flies every mission from its builder's parts (named, not imported: app/loop.py imports
#: this module's ``build``, and the package's imports have no cycle, tests/test_import_rules.py)
SIMULATION = "visnav.app.loop:Simulation"


def simulation_class():
    """The one simulation class (``app/loop.Simulation``)."""

    module, name = SIMULATION.split(":")
    return getattr(importlib.import_module(module), name)


def make_simulation(scenario, navigator_wrapper=None):
    """Build the simulation for a validated ``Scenario`` (its mission's builder gives the parts)."""
    return simulation_class()(scenario, navigator_wrapper=navigator_wrapper)


@dataclass
class BuildContext:
    """What a builder gets: the scenario, the log's recorder and the run's random generators; for a part that
    logs a step of its own (the R-MAX's touchdown), the loop's ``step`` (``sim/parts.Step``, filled at each
    log step) and ``settle()`` (everything due delivered to the navigator before the part reads it)."""

    scenario: object
    record: Callable
    navigator_wrapper: Callable | None = None  # wraps the navigator (visnav record's proxy) before a mission gets it
    step: Step = field(default_factory=lambda: Step(0.0, None, None, None, None, None, ""))
    settle: Callable[[], None] = lambda: None

    @cached_property
    def rng(self) -> list[np.random.Generator]:
        """The R-MAX loop's generators: world, IMU, GPS, laser, sonar, camera, 2 spare."""
        return [np.random.default_rng(s) for s in np.random.SeedSequence(self.scenario.run.seed).spawn(8)]

    @property
    def yaw(self) -> float:
        return float(np.deg2rad(self.scenario.vehicle.yaw_deg))

    def textured_world(self):
        """The ``[world]`` section's world: textured ground (rendered by the camera) and wind."""
        from visnav.world.scene import build_world

        return build_world(self.scenario.world, self.rng[0], heading_rad=self.yaw)

    def scenario_wind(self):
        """The ``[world]`` section's wind alone (no ground drawn), for a mission that renders no ground or
        brings its own. The gusts draw from the world's generator undrawn by a ground (another realisation
        than under ``textured_world`` where turbulence is on)."""
        from visnav.world.scene import build_wind

        return build_wind(self.scenario.world, self.rng[0], heading_rad=self.yaw)

    def wind_world(self):
        """A world with the ``[world]`` section's wind and no ground (nothing is rendered)."""
        from visnav.world.scene import World

        return World(ground=None, surface=self.scenario.world.surface, wind=self.scenario_wind())

    def camera_geometry(self):
        """(PinholeCamera, FixedMount) of ``[sensors.camera]``."""
        return rmax_camera(self.scenario)

    def rmax_sensors(self, camera: bool = True) -> dict:
        """The ``[sensors]`` section: IMU (+ attitude), GPS, laser, sonar and (``camera``) the camera."""
        from visnav.sensors.camera import Camera
        from visnav.sensors.gps import Gps
        from visnav.sensors.imu import Imu
        from visnav.sensors.rangefinder import LaserRangeFinder, Sonar

        sc, rng = self.scenario, self.rng
        s = sc.sensors
        model, mount = self.camera_geometry()
        out = {"imu": Imu(rng[1], **s.imu.model_dump(exclude={"kind"})),
               "gps": Gps(rng[2], **s.gps.model_dump(exclude={"kind"}))}
        if "laser" in s:  # the laser shares the camera's mount
            out["laser"] = LaserRangeFinder(rng[3], mount, surface=sc.world.surface, **s.laser.model_dump(exclude={"kind"}))
        if "sonar" in s:
            out["sonar"] = Sonar(rng[4], **s.sonar.model_dump(exclude={"kind"}))
        if camera:
            c = s.camera
            out["camera"] = Camera(model, mount, rng[5], capture_hz=c.capture_hz, process_hz=sc.navigation.mpe.rate_hz,
                                   noise_sigma=c.noise_sigma, latency_s=c.latency_s, delay_s=c.delay_s)
        return out

    def navigator(self, name: str, **parts):
        """The registered navigator ``name`` (``app/navigators.py``) configured by the scenario (wrapped by
        ``navigator_wrapper`` when given)."""
        nav = make_navigator(name, self.scenario, self.record, **parts)
        return nav if self.navigator_wrapper is None else self.navigator_wrapper(nav)


def register(name: str) -> Callable[[Builder], Builder]:
    def deco(fn: Builder) -> Builder:
        REGISTRY[name] = fn
        return fn

    return deco


def build(ctx: BuildContext) -> MissionParts | GroundTest:
    kind = ctx.scenario.mission.type
    if kind not in REGISTRY:
        raise ValueError(f"mission.type {kind!r} has no builder; known: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[kind](ctx)


@register("palace")
def _palace(ctx: BuildContext) -> MissionParts:
    from visnav.control.rmax import RmaxPositionController
    from visnav.mission.palace import PalaceMission

    sc = ctx.scenario
    world = ctx.textured_world()
    model, mount = ctx.camera_geometry()
    nav = ctx.navigator("palace")
    c = sc.sensors.camera
    mission = PalaceMission(sc.mission, nav, yaw=ctx.yaw, image_size=(c.width, c.height), recorder=ctx.record)
    return rmax_parts(ctx, world=world, sensors=ctx.rmax_sensors(), navigator=nav, mission=mission,
                      controller=RmaxPositionController(), metrics=palace_metrics,
                      start_position=mission.start_position(), start_yaw=ctx.yaw, camera_model=model, mount=mount)


@register("hover")
def _hover(ctx: BuildContext) -> MissionParts:
    from visnav.control.rmax import RmaxPositionController
    from visnav.mission.hover import HoverMission

    world = ctx.textured_world()
    model, mount = ctx.camera_geometry()
    nav = ctx.navigator("palace")
    mission = HoverMission(ctx.scenario.mission, nav, yaw=ctx.yaw, recorder=ctx.record)
    return rmax_parts(ctx, world=world, sensors=ctx.rmax_sensors(), navigator=nav, mission=mission,
                      controller=RmaxPositionController(), metrics=hover_metrics,
                      start_position=mission.start_position(), start_yaw=ctx.yaw, camera_model=model, mount=mount,
                      injection=mission.actuator_injection)


@register("pfcm")
def _pfcm(ctx: BuildContext) -> MissionParts:
    from visnav.control.rmax_path import PathFollowingController
    from visnav.mission.pfcm import PfcmMission, path_loop_gains

    cfg = ctx.scenario.mission
    world = ctx.wind_world()  # no camera: no ground to render
    model, mount = ctx.camera_geometry()
    ctl = ctx.scenario.control.pfcm
    mission = PfcmMission(cfg, recorder=ctx.record, iterations=ctl.iterations)
    controller = PathFollowingController(path_loop_gains(cfg, ctl), recorder=ctx.record)
    # PFCM flies on the PALACE navigator's GPS solution: no camera
    return rmax_parts(ctx, world=world, sensors=ctx.rmax_sensors(camera=False), navigator=ctx.navigator("palace"),
                      mission=mission, controller=controller, metrics=pfcm_metrics,
                      start_position=mission.start_position(), start_yaw=mission.start_yaw, camera_model=model,
                      mount=mount)


@register("witas-homing")
def _witas(ctx: BuildContext) -> MissionParts:
    from visnav.app.witas_parts import build as build_witas

    return build_witas(ctx)


@register("pad-landing")
def _pad(ctx: BuildContext) -> MissionParts:
    from visnav.app.pad_parts import build as build_pad

    return build_pad(ctx)


@register("deck")
def _deck(ctx: BuildContext) -> MissionParts:
    from visnav.app.deck_parts import build as build_deck

    return build_deck(ctx)


@register("condor")
def _condor(ctx: BuildContext) -> MissionParts | GroundTest:
    from visnav.app.condor_parts import build as build_condor

    return build_condor(ctx)


@register("mav-geolocation")
def _geolocation(ctx: BuildContext) -> MissionParts:
    from visnav.app.geoloc_parts import build as build_geolocation

    return build_geolocation(ctx)
