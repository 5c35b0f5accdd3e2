"""Navigators for the live bridge, from the one registry (``app/navigators.py``) the simulation and the replay use.

``build_navigator("witas")`` takes the navigator's default scenario (``witas-homing``; ``palace`` ->
``palace-landing``), or any scenario name / .toml path, whose mission type names the navigator; no
simulation is built (the WITAS reference map is degraded from the scenario's ground, or ``--map``).

Known gaps of live use (see docs/autopilots.md): the navigator's camera model is the scenario's (a
camera.yaml is used for its time offset only); the PALACE navigator only tracks once a mission commands
``request-tracking`` (the bridge runs no mission: a mission on the autopilot side sends it over MAVLink,
COMMAND_LONG MAV_CMD_USER_1, docs/autopilots.md; without one it is a GPS-phase navigator); the
WITAS navigator engages vision when GPS samples stop (its ``gps_timeout_s``) and needs a reference
map georeferenced at the bridge's NED origin (``--map`` / ``--origin``); the pad navigator needs a
pan-tilt link (not there yet).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from visnav.app.navigators import NAVIGATORS, make_navigator, navigator_for
from visnav.scenarios.schema import load_scenario


@dataclass
class BuiltNavigator:
    navigator: object
    camera_hz: float
    scenario: str  # the run name of its scenario
    sc: object  # the resolved Scenario (``sim.missions.make_simulation(sc)`` builds its simulated world)
    name: str = ""  # its name in the registry app/navigators.py (what `visnav replay --navigator` takes)


def build_navigator(name: str, map_path: str | None = None, overrides: list[str] | None = None,
                    recorder=None) -> BuiltNavigator:
    """Raises ScenarioError / FileNotFoundError / ValueError with a one-line message on bad input."""

    scenario = NAVIGATORS[name].scenario if name in NAVIGATORS else name
    sets = list(overrides or [])
    sc = load_scenario(scenario, sets)
    if map_path:
        key = {"witas-homing": "world.witas_map.file", "mav-geolocation": "world.geo_map.file"}.get(
            sc.mission.type, "world.map_file")
        sc = load_scenario(scenario, sets + [f"{key}={Path(map_path).resolve()}"])
    return navigator_from_scenario(sc, recorder)


def navigator_from_scenario(sc, recorder=None) -> BuiltNavigator:
    """The registered navigator a validated Scenario's mission flies with (and the camera rate it consumes)."""
    name = navigator_for(getattr(sc.mission, "type", "palace"))
    return BuiltNavigator(make_navigator(name, sc, recorder), float(NAVIGATORS[name].camera_hz(sc)), sc.run.name, sc,
                          name)
