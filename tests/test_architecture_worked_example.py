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


def _block(name: str) -> str:
    m = re.search(rf"<!-- example: {name}.*?-->\s*```python\n(.*?)```", DOC.read_text(), re.S)
    assert m, f"example block {name} not found in docs/architecture.md"
    return m.group(1)


def test_worked_system_flies_in_the_one_loop():
    """The second block: a point mass flown on the first block's sensor and navigator by the one Simulation,
    from parts of a builder; it reaches the goal up to the navigator's noise, and the metrics are the log's."""
    ns: dict = {}
    exec(compile(_example(), str(DOC), "exec"), ns)
    code = _block("add-system")
    assert 25 <= len(code.strip().splitlines()) <= 50
    exec(compile(code, str(DOC), "exec"), ns)
    run = ns["run"]
    assert run.error is None and not run.interrupted
    m = run.metrics
    # 15 m away at the start; a PD on a double integrator (wn 0.71 rad/s, zeta 0.71) settles in ~8 s, so after
    # 20 s what is left is the alpha-beta estimate's error (0.5 m GPS noise): the truth follows the estimate
    assert m["final_error_m"] < 1.5 and m["estimate_error_m"] < 1.5
    assert abs(m["final_error_m"] - m["estimate_error_m"]) < 0.6
    est, tr = run.log.get("estimate"), run.log.get("truth")
    assert len(est["t"]) == len(tr["t"]) == 200  # the mission's 10 Hz over 20 s
    assert np.linalg.norm(tr["position"][0] - [0.0, 0.0, -10.0]) < 1e-9
    init = run.log.get("nav_init")
    assert list(init["source"]) == ["survey"]  # the loop logged the explicit start it sent
    assert 0.0 < m["ate_rmse_m"] < 1.5  # the run's truth vs estimate (io/tum.py), as evo_ape gives it
