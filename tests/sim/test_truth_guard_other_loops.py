"""Truth guard for the loops of their own (ship deck, CONDOR, geo-location): as ``test_truth_guard.py`` does
for the R-MAX loop, the true vehicle states (and the deck's true motion) are read only by the sensors, the
vehicle and world models that produce them, and the loop (``app/loop.py``) with the system's own logging /
contact / truth parts (``app/deck_parts.py``, ...).

The state types are swapped for subclasses whose attribute reads check the module of the reader; a read
from anywhere else (a navigator, a mission, a controller, guidance) is recorded and raises.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from visnav.scenarios.schema import load_scenario
from visnav.app.missions import make_simulation

ALLOWED = ("visnav.sensors.", "visnav.vehicles.", "visnav.world.")
ALLOWED_EXACT = {"visnav.measurements", "dataclasses", "copy"}
LEAKS: list[str] = []


def _guarded(cls, loop_module: str):
    """A subclass of the truth type ``cls`` whose attribute reads are checked."""

    def __getattribute__(self, name):
        if not name.startswith("__"):
            mod = sys._getframe(1).f_globals.get("__name__", "?")
            if not (mod.startswith(ALLOWED) or mod in ALLOWED_EXACT or mod == loop_module
                    or mod in ("visnav.sim.fixedwing_common", "visnav.app.loop", "visnav.sim.parts")):
                LEAKS.append(f"{mod} read truth {cls.__name__}.{name}")
                raise AssertionError(f"truth read from {mod} ({cls.__name__}.{name})")
        return object.__getattribute__(self, name)

    return type("Guarded" + cls.__name__, (cls,), {"__getattribute__": __getattribute__})


def _guard(monkeypatch, loop_module: str) -> dict:
    import visnav.measurements as meas
    import visnav.vehicles.fixedwing as fw
    import visnav.vehicles.multirotor as mr
    import visnav.world.deck as wd

    g = {"vs": _guarded(meas.VehicleState, loop_module), "mr": _guarded(mr.MultirotorState, loop_module),
         "ds": _guarded(wd.DeckState, loop_module)}
    monkeypatch.setattr(fw, "VehicleState", g["vs"])  # the fixed wing's state
    monkeypatch.setattr(mr, "MultirotorState", g["mr"])  # the Y6's state
    monkeypatch.setattr(wd, "DeckState", g["ds"])  # the ship deck's true motion
    if loop_module == "visnav.app.deck_parts":
        import visnav.app.deck_parts as dp

        monkeypatch.setattr(dp, "VehicleState", g["vs"])  # what the deck's truth history holds
    return g


def test_the_guard_catches_a_read_from_elsewhere(monkeypatch):
    g = _guard(monkeypatch, "visnav.app.deck_parts")
    from visnav.world.deck import DeckMotion

    ds = DeckMotion.static().state(0.0)
    assert isinstance(ds, g["ds"])
    LEAKS.clear()
    with pytest.raises(AssertionError, match="truth read from"):
        _ = ds.position
    assert LEAKS == [f"{__name__} read truth DeckState.position"]
    LEAKS.clear()


@pytest.mark.parametrize("name, loop, keys", [
    ("deck-static", "visnav.app.deck_parts", ["run.duration_s=8"]),  # manual start, hand-over, approach
    ("deck-moving", "visnav.app.deck_parts", ["run.duration_s=6"]),
    ("condor-orbit", "visnav.app.condor_parts", ["run.duration_s=30", "mission.orbit.switch_time_s=20"]),  # GPS, then vision
    ("mav-geolocation", "visnav.app.geoloc_parts", ["run.duration_s=25"]),
])
def test_no_truth_outside_the_sensors_models_and_the_loop(monkeypatch, name, loop, keys):
    g = _guard(monkeypatch, loop)
    LEAKS.clear()
    sim = make_simulation(load_scenario(name, keys))
    st = sim.vehicle.state
    assert isinstance(st, (g["vs"], g["mr"])), type(st)
    res = sim.run()
    assert LEAKS == [], LEAKS
    assert res.error is None, res.error
    modes = res.log.get("mode")
    assert modes and len(modes["t"]) >= 1
    if name == "condor-orbit":
        assert "vision_orbit" in [str(m) for m in modes["mode"]]
    est = res.log.get("estimate") or res.log.get("sample")
    assert est and len(est["t"]) > 0
