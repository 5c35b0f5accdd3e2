"""The worked example of docs/architecture.md ("How to add a vehicle, a sensor, a navigator or a mission")
runs as printed: its navigator conforms to navigation/base.Navigator and follows the ramp it is fed."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"


def _example() -> str:
    m = re.search(r"<!-- example: add-sensor-navigator.*?-->\s*```python\n(.*?)```", DOC.read_text(), re.S)
    assert m, "example block not found in docs/architecture.md"
    return m.group(1)


def test_worked_example_runs_and_tracks_the_ramp():
    code = _example()
    assert 25 <= len(code.strip().splitlines()) <= 50
    ns: dict = {}
    exec(compile(code, str(DOC), "exec"), ns)
    est, nav = ns["est"], ns["nav"]
    # an alpha-beta filter has no steady-state lag on a constant velocity: the estimate at t = 20 s is the
    # truth up to the 0.5 m sensor noise it smooths (alpha 0.5) and the 0.2 s it extrapolates
    assert np.linalg.norm(est.position - np.array([40.0, -20.0, -10.0])) < 1.0
    assert np.allclose(est.velocity, [2.0, -1.0, 0.0], atol=0.6)
    assert np.all(nav.v == 0.0)  # the NavCommand reached _cmd_reset_velocity
    with pytest.raises(ValueError, match="no command 'land'"):
        nav.command(ns["NavCommand"](20.0, "land"))
    # the sensor stamps the instant it describes: sample at t is truth at t plus noise
    s = ns["PositionSensor"](np.random.default_rng(0), sigma_m=0.0)
    m = s.sample(3.0, ns["truth"])
    assert m.t == 3.0 and np.allclose(m.position, [6.0, -3.0, -10.0])
