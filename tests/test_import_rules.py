"""DESIGN §1: algorithms never know where their inputs come from. No module in the algorithm and
decision layers imports the simulation, the synthetic world, the vehicle models or the sensor models
(at any depth: a function-level import counts too), so the same navigators run on recorded or live data."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "visnav"
LAYERS = ("navigation", "estimation", "vision", "guidance", "control", "mission")
FORBIDDEN = ("visnav.sim", "visnav.world", "visnav.vehicles", "visnav.sensors")


def _imports(path: Path) -> list[tuple[int, str]]:
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            out.extend((node.lineno, a.name) for a in node.names)
    return out


@pytest.mark.parametrize("layer", LAYERS)
def test_no_simulation_world_vehicle_or_sensor_import(layer):
    bad = [f"{p.relative_to(PKG)}:{line} imports {mod}" for p in sorted((PKG / layer).rglob("*.py"))
           for line, mod in _imports(p) if mod.startswith(FORBIDDEN)]
    assert bad == []


def test_the_check_sees_a_forbidden_import(tmp_path):
    f = tmp_path / "x.py"
    f.write_text("def f():\n    from visnav.sim.missions import MissionParts\n")
    assert _imports(f) == [(2, "visnav.sim.missions")]
