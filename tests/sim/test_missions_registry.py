"""Mission registry: which simulation flies a scenario's mission type."""

import pytest

from visnav.scenarios.schema import load_scenario
from visnav.sim import missions
from visnav.sim.loop import Simulation


def test_rmax_missions_fly_the_rmax_loop():
    for name in ("palace-landing", "pfcm-segment", "palace-hover-drift"):
        sc = load_scenario(name)
        assert sc.mission.type not in missions.SIMULATIONS
        assert missions.simulation_class(sc.mission.type) is Simulation


def test_a_registered_mission_gets_its_own_simulation(monkeypatch):
    monkeypatch.setitem(missions.SIMULATIONS, "palace", "visnav.sim.log:FlightLog")
    from visnav.sim.log import FlightLog

    assert missions.simulation_class("palace") is FlightLog


def test_every_registered_simulation_imports():
    for kind in missions.SIMULATIONS:
        cls = missions.simulation_class(kind)
        assert callable(getattr(cls, "run", None)), kind


def test_unknown_mission_type_names_the_known_ones():
    from types import SimpleNamespace

    fake = missions.BuildContext(SimpleNamespace(mission=SimpleNamespace(type="nope")), lambda *a, **k: None)
    with pytest.raises(ValueError, match="'nope' has no builder; known: .*palace"):
        missions.build(fake)
