"""Truth reaches only the sensors, the loop's logging and contact code and explicit NavInit senders.

Every R-MAX scenario flies a few seconds with the truth guarded: the vehicle model's states and the
states the truth history interpolates are a ``VehicleState`` subclass whose attribute reads check the
module of the code that reads them, and the truth history checks who calls it. A read from anywhere
else (a navigator, a mission, a controller, a metric) is recorded and raises.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from visnav.measurements import VehicleState
from visnav.scenarios.schema import load_scenario

#: modules allowed to read truth: the sensors, the loop and the R-MAX's parts (logging, touchdown, wind), the vehicle model
#: that produces it, the state type's own properties (height_agl) and the dataclass machinery
ALLOWED = ("visnav.sensors.", "visnav.vehicles.")
ALLOWED_EXACT = {"visnav.app.loop", "visnav.app.rmax_parts", "visnav.measurements", "dataclasses"}
RMAX_SCENARIOS = ["palace-landing", "palace-hover-drift", "palace-sweep", "pfcm-segment", "pfcm-spiral",
                  "witas-homing", "pad-landing"]

LEAKS: list[str] = []


def _caller_ok(depth: int) -> tuple[bool, str]:
    mod = sys._getframe(depth).f_globals.get("__name__", "?")
    return mod.startswith(ALLOWED) or mod in ALLOWED_EXACT, mod


class GuardedState(VehicleState):
    def __getattribute__(self, name):
        if not name.startswith("__"):
            ok, mod = _caller_ok(2)
            if not ok:
                LEAKS.append(f"{mod} read truth .{name}")
                raise AssertionError(f"truth read from {mod} (.{name})")
        return object.__getattribute__(self, name)


def _guard(monkeypatch):
    import visnav.sensors.base as sb
    import visnav.sim.parts as parts
    import visnav.app.rmax_parts as rp
    import visnav.vehicles.rmax as vr

    class GuardedHistory(parts.VehicleTruth):
        def __call__(self, t):
            ok, mod = _caller_ok(2)
            if not ok:
                LEAKS.append(f"{mod} called the truth history")
                raise AssertionError(f"truth history called from {mod}")
            return super().__call__(t)

    monkeypatch.setattr(sb, "VehicleState", GuardedState)  # what the truth history interpolates
    monkeypatch.setattr(vr, "VehicleState", GuardedState)  # the vehicle model's state
    monkeypatch.setattr(rp, "VehicleState", GuardedState)  # the start state
    monkeypatch.setattr(rp, "VehicleTruth", GuardedHistory)  # the R-MAX's truth history (app/rmax_parts.rmax_parts)


def test_the_guard_sees_a_read_from_elsewhere(monkeypatch):
    """The check can fail: a state read from this test module is caught."""
    _guard(monkeypatch)
    import visnav.vehicles.rmax as vr

    s = vr.RmaxModel(position=(0.0, 0.0, -10.0)).state
    assert isinstance(s, GuardedState)
    LEAKS.clear()
    with pytest.raises(AssertionError, match="truth read from"):
        _ = s.position
    assert LEAKS == [f"{__name__} read truth .position"]
    LEAKS.clear()


@pytest.mark.parametrize("name", RMAX_SCENARIOS)
def test_no_truth_outside_the_sensors_the_log_and_nav_init(monkeypatch, name):
    from visnav.app.loop import Simulation

    _guard(monkeypatch)
    LEAKS.clear()
    sim = Simulation(load_scenario(name, ["run.duration_s=3"]))
    assert isinstance(sim.vehicle.state, GuardedState)
    res = sim.run()
    assert LEAKS == [], LEAKS
    assert res.error is None, res.error
    est = res.log.get("estimate")
    assert len(est["t"]) >= 25 and np.isfinite(np.asarray(est["position"], float)).all()
