"""Mission registry: which simulation flies a scenario's mission type."""

import pytest

from visnav.scenarios.schema import load_scenario
from visnav.app import missions
from visnav.app.loop import Simulation


def test_every_scenario_flies_the_one_loop_from_its_builder():
    """Every built-in scenario's mission type has a builder, and the one ``Simulation`` flies it."""
    from visnav.scenarios.schema import builtin_names

    names = builtin_names()
    assert {"deck-static", "condor-orbit", "mav-geolocation", "palace-landing"} <= set(names)
    for name in names:
        assert load_scenario(name).mission.type in missions.REGISTRY, name
    assert missions.simulation_class() is Simulation


def test_a_vehicle_of_its_own_is_a_part_not_a_loop():
    sim = missions.make_simulation(load_scenario("deck-static", ["run.duration_s=0.5"]))
    assert type(sim) is Simulation
    from visnav.vehicles.multirotor import Multirotor

    assert isinstance(sim.vehicle, Multirotor) and sim.parts.hooks.contact is not None
    r = sim.run()
    assert r.error is None and len(r.log.get("vehicle")["t"]) == 51  # every step, the end included


def test_unknown_mission_type_names_the_known_ones():
    from types import SimpleNamespace

    fake = missions.BuildContext(SimpleNamespace(mission=SimpleNamespace(type="nope")), lambda *a, **k: None)
    with pytest.raises(ValueError, match="'nope' has no builder; known: .*palace"):
        missions.build(fake)
