"""Navigators for the live bridge, built from a scenario exactly as the simulation builds them.

``build_navigator("witas")`` loads the ``witas-homing`` scenario (or any scenario name / .toml path),
builds its simulation with ``sim.missions.make_simulation`` and takes the navigator it wired
(``sim.nav``: the WITAS navigator with its reference map, or the PALACE navigator) together with
the camera rate the navigator consumes. Until the architecture refactor (#13) separates navigator
construction from the simulation, this builds (and discards) the simulated world too: a few seconds
at start-up, nothing per frame.

Known gaps of live use (see docs/autopilots.md): the navigator's camera model is the scenario's (a
camera.yaml is used for its time offset only); the PALACE navigator only tracks once a mission calls
``request_tracking`` (the bridge runs no mission), so over the bridge it is a GPS-phase navigator; the
WITAS navigator engages vision when GPS samples stop (its ``gps_timeout_s``) and needs a reference
map georeferenced at the bridge's NED origin (``--map`` / ``--origin``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

ALIASES = {"witas": "witas-homing", "palace": "palace-landing"}


@dataclass
class BuiltNavigator:
    navigator: object
    camera_hz: float
    scenario: str
    sim: object  # the simulation it came from (its world and camera renderer serve the SIL camera)


def build_navigator(name: str, map_path: str | None = None, overrides: list[str] | None = None) -> BuiltNavigator:
    """Raises ScenarioError / FileNotFoundError / ValueError with a one-line message on bad input."""
    from visnav.scenarios.schema import load_scenario

    scenario = ALIASES.get(name, name)
    sets = list(overrides or [])
    sc = load_scenario(scenario, sets)
    if map_path:
        key = "mission.map.file" if hasattr(sc.mission, "map") else "world.map_file"
        sc = load_scenario(scenario, sets + [f"{key}={Path(map_path).resolve()}"])
    return navigator_from_scenario(sc)


def navigator_from_scenario(sc) -> BuiltNavigator:
    """The navigator a validated Scenario's simulation wires (and the camera rate it consumes)."""
    from visnav.sim.missions import make_simulation

    sim = make_simulation(sc)
    flt = getattr(sc.mission, "filter", None)
    camera_hz = float(getattr(flt, "odometry_hz", 0) or getattr(sim.camera, "rate_hz", 10.0))
    return BuiltNavigator(sim.nav, camera_hz, sc.run.name, sim)
