"""Which mission manager, controller and metrics a scenario's ``mission.type`` flies with.

Each builder receives the half-built ``Simulation`` (world, sensors, navigator ready) and returns
the ``MissionParts``; a new mission registers itself here with ``@register("name")`` (and its
pydantic config in ``scenarios/schema.py``).
"""

from __future__ import annotations

from typing import Callable

from visnav.sim.parts import MissionParts  # noqa: F401  (re-exported)

Builder = Callable[[object], "MissionParts"]
REGISTRY: dict[str, Builder] = {}

#: mission type -> "module:Class" of a simulation of its own, for missions that fly another
#: vehicle with other sensors than the R-MAX loop of ``sim/loop.py`` (multirotor on a ship deck,
#: fixed wing with a gimbal). The class takes the ``Scenario`` and offers what ``Simulation`` offers
#: to the command line and the campaign runner: ``.sc``, ``.mission.mode`` and
#: ``.run(progress=None) -> RunResult``.
SIMULATIONS: dict[str, str] = {
    "condor": "visnav.sim.condor_loop:CondorSimulation",
    "deck": "visnav.sim.deck_loop:DeckSimulation",
    "mav-geolocation": "visnav.sim.geoloc_loop:GeolocationSimulation",
}


#: the R-MAX loop, which flies every mission type not in ``SIMULATIONS`` (named, not imported: sim/loop.py
#: imports this module's ``build``, and the package's imports have no cycle, tests/test_import_rules.py)
RMAX_SIMULATION = "visnav.sim.loop:Simulation"


def simulation_class(mission_type: str):
    """The simulation class that flies ``mission_type`` (the R-MAX ``Simulation`` by default)."""
    import importlib

    module, name = SIMULATIONS.get(mission_type, RMAX_SIMULATION).split(":")
    return getattr(importlib.import_module(module), name)


def make_simulation(scenario):
    """Build the simulation for a validated ``Scenario``."""
    return simulation_class(getattr(scenario.mission, "type", "palace"))(scenario)


def register(name: str) -> Callable[[Builder], Builder]:
    def deco(fn: Builder) -> Builder:
        REGISTRY[name] = fn
        return fn

    return deco


def build(sim) -> MissionParts:
    kind = sim.sc.mission.type
    if kind not in REGISTRY:
        raise ValueError(f"mission.type {kind!r} has no builder; known: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[kind](sim)


@register("palace")
def _palace(sim) -> MissionParts:
    from visnav.analysis.metrics import palace_metrics
    from visnav.control.rmax import RmaxPositionController
    from visnav.mission.palace import PalaceMission

    c = sim.sc.sensors.camera
    mission = PalaceMission(sim.sc.mission, sim.nav, yaw=sim.yaw, image_size=(c.width, c.height),
                            recorder=sim.log.record)
    return MissionParts(mission=mission, controller=RmaxPositionController(), metrics=palace_metrics,
                        start_position=mission.start_position(), start_yaw=sim.yaw, uses_camera=True)


@register("hover")
def _hover(sim) -> MissionParts:
    from visnav.analysis.metrics import hover_metrics
    from visnav.control.rmax import RmaxPositionController
    from visnav.mission.hover import HoverMission

    mission = HoverMission(sim.sc.mission, sim.nav, yaw=sim.yaw, recorder=sim.log.record)
    return MissionParts(mission=mission, controller=RmaxPositionController(), metrics=hover_metrics,
                        start_position=mission.start_position(), start_yaw=sim.yaw, uses_camera=True)


@register("pfcm")
def _pfcm(sim) -> MissionParts:
    from visnav.analysis.path_metrics import pfcm_metrics
    from visnav.control.rmax_path import PathFollowingController
    from visnav.mission.pfcm import PfcmMission, path_loop_gains

    cfg = sim.sc.mission
    mission = PfcmMission(cfg, recorder=sim.log.record)
    controller = PathFollowingController(path_loop_gains(cfg), recorder=sim.log.record)
    return MissionParts(mission=mission, controller=controller, metrics=pfcm_metrics,
                        start_position=mission.start_position(), start_yaw=mission.start_yaw, uses_camera=False)


@register("witas-homing")
def _witas(sim) -> MissionParts:
    from visnav.sim.witas_parts import build as build_witas

    return build_witas(sim)


@register("pad-landing")
def _pad(sim) -> MissionParts:
    from visnav.sim.pad_parts import build as build_pad

    return build_pad(sim)
