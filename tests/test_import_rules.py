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
    f.write_text("def f():\n    from visnav.app.missions import MissionParts\n")
    assert _imports(f) == [(2, "visnav.app.missions")]


# ------------------------------------------------------------------------------- no import cycle
from visnav.import_graph import cycles, import_graph, layer_diagram, layers, package_edges  # noqa: E402


def test_no_import_cycle_module_level_or_deferred():
    """Issue 13: the module graph has no cycle, neither over the module-level imports nor over all imports
    (a function-level import still makes two modules depend on each other). Anyone can run the same check:
    python -c "import visnav.import_graph as g; g.main()"."""
    top, deferred = import_graph(PKG)
    assert sum(map(len, top.values())) > 200 and sum(map(len, deferred.values())) > 50  # it saw the package
    assert cycles(top) == []
    assert cycles({m: top[m] | deferred[m] for m in top}) == []


def _package(tmp_path, files: dict[str, str]) -> Path:
    root = tmp_path / "pkg"
    for name, text in {"__init__.py": "", **files}.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return root


def test_the_check_sees_cycles_and_tells_deferred_from_module_level(tmp_path):
    root = _package(tmp_path, {
        "a.py": "from pkg.b import f\n",
        "b.py": "def f():\n    from . import c\n",
        "c.py": "import pkg.a as a\nfrom typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.d import X\n",
        "d.py": "from pkg import c\n",
        "sub/__init__.py": "from .e import g\n",
        "sub/e.py": "from ..a import f\n",
    })
    top, deferred = import_graph(root)
    assert top["pkg.a"] == {"pkg.b"} and deferred["pkg.b"] == {"pkg.c"}
    assert top["pkg.c"] == {"pkg.a"} and deferred["pkg.c"] == {"pkg.d"}
    assert top["pkg.sub"] == {"pkg.sub.e"} and top["pkg.sub.e"] == {"pkg.a"}
    assert cycles(top) == []  # a -> b only through b's function
    assert cycles({m: top[m] | deferred[m] for m in top}) == [["pkg.a", "pkg.b", "pkg.c", "pkg.d"]]


def test_the_one_line_check_runs(tmp_path):
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(PKG.parent)}
    r = subprocess.run([sys.executable, "-c", "import visnav.import_graph as g; g.main()"], capture_output=True,
                       text=True, env=env, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "module-level imports: 0 cycle(s)" in r.stdout and "all imports (module-level + deferred): 0 cycle(s)" \
        in r.stdout


#: package pairs that still import each other: none since the run assembly moved into ``visnav.app`` (issue #31
#: item 4). The set may only shrink: a new pair fails, and so does a listed pair that no longer exists.
KNOWN_MUTUAL: set[tuple[str, str]] = set()

#: the order among the packages that handle a run (docs/architecture.md): ``app`` (assemble and run: the navigator
#: registry, the mission builders and their parts, the loop, record / replay / SIL / bridge sessions, campaigns) over
#: ``analysis`` (metrics, reports; it reads ``io``'s files and the run's ``FlightLog``, the leaf ``visnav/flightlog.py``
#: every layer may import) over ``io`` and ``sim``, which import neither each other nor anything above them. package -> the packages it must not import.
FORBIDDEN_PACKAGES = {
    "io": {"sim", "analysis", "app", "cli"},
    "sim": {"io", "analysis", "app", "cli"},
    "analysis": {"app", "cli"},
    "app": {"cli"},
}
#: every package below the run's (algorithms, models, configuration) imports none of these
RUN_PACKAGES = {"app", "analysis", "io", "sim", "cli"}


def _package_edges(root: Path = PKG) -> dict[str, set[str]]:
    return package_edges(root)


def test_no_pair_of_packages_imports_each_other():
    e = _package_edges()
    assert {"app", "analysis", "io", "sim"} <= set(e)  # it saw the packages
    mutual = {tuple(sorted((a, b))) for a in e for b in e[a] if a in e.get(b, set())}
    assert mutual - KNOWN_MUTUAL == set(), f"new packages importing each other: {sorted(mutual - KNOWN_MUTUAL)}"
    assert KNOWN_MUTUAL - mutual == set(), f"no longer mutual (remove from KNOWN_MUTUAL): {KNOWN_MUTUAL - mutual}"
    assert "mission" not in e.get("world", set()) and "vision" not in e.get("estimation", set())


def test_app_is_above_analysis_above_io_and_sim():
    e = _package_edges()
    bad = sorted(f"{a} imports {b}" for a, forbidden in FORBIDDEN_PACKAGES.items() for b in e.get(a, set()) & forbidden)
    assert bad == []
    lower = sorted(f"{a} imports {b}" for a in e if a not in RUN_PACKAGES and a != "visnav"
                   for b in e[a] & RUN_PACKAGES)
    assert lower == []


def test_the_package_check_sees_a_mutual_pair_and_a_relative_import(tmp_path):
    root = _package(tmp_path, {"io/__init__.py": "", "io/a.py": "def f():\n    from ..sim import b\n",
                               "sim/__init__.py": "", "sim/b.py": "from pkg.io.a import f\n"})
    top, deferred = import_graph(root)
    assert deferred["pkg.io.a"] == {"pkg.sim.b"} and top["pkg.sim.b"] == {"pkg.io.a"}
    assert _package_edges(root) == {"pkg": set(), "io": {"sim"}, "sim": {"io"}}  # a mutual pair, one side inside a function


def test_the_layer_diagram_is_the_code():
    """docs/architecture.md's layer diagram is the one generated from the imports (issue #31 item 6)."""
    doc = (PKG.parents[1] / "docs" / "architecture.md").read_text()
    block = doc.split("<!-- layers:begin -->\n", 1)[1].split("\n<!-- layers:end -->", 1)[0]
    assert block == layer_diagram(), "regenerate it: python -m visnav.import_graph --layers"


def test_layers_and_the_diagram_on_a_small_package(tmp_path):
    root = _package(tmp_path, {
        "top.py": "from pkg.mid import a\nfrom pkg.low import b\n",
        "mid/__init__.py": "from pkg.low import b\n",
        "low/__init__.py": "",
    })
    e = package_edges(root)
    assert e == {"pkg": set(), "top": {"mid", "low"}, "mid": {"low"}, "low": set()}
    assert layers({k: v for k, v in e.items() if k != "pkg"}) == {"low": 0, "mid": 1, "top": 2}
    d = layer_diagram(root)
    assert "  top --> mid" in d and "  mid --> low" in d
    assert "  top --> low" not in d  # implied by top -> mid -> low
    with pytest.raises(ValueError, match="import each other"):
        layers({"a": {"b"}, "b": {"a"}})


# ------------------------------------------------------------------------------- function-level imports
#: visnav modules imported inside a function only where a module is loaded when it is used (issue #31: no
#: function-level import that exists to hide a cycle; the graph above has none to hide)
LAZY_VISNAV = {
    "cli.py": "each command imports what it runs: `visnav --help` takes ~0.2 s, importing every module ~2 s",
    "app/navigators.py": "the registry loads a navigator's modules when it is chosen",
    "app/missions.py": "the registry loads a system's parts when its mission is built",
}
#: third-party libraries imported inside functions: heavy, or used by a few commands only, loaded on use
LAZY_THIRD_PARTY = {
    "matplotlib": "reports and plots", "cv2": "image work outside the vision modules (reports, bridge, sources)",
    "scipy": "a few analyses", "h5py": "writing log.h5", "pymavlink": "MAVLink logs and links",
    "pyulog": "PX4 logs", "rosbags": "ROS bags", "rasterio": "GeoTIFF maps (optional)", "pymap3d": "geodesy",
    "skimage": "procedural textures", "distributed": "dask campaigns", "PIL": "EXIF of photos",
    "yaml": "camera.yaml / EuRoC sensor.yaml", "tomli_w": "writing scenario.toml", "numpy": "cli.py",
    "rich": "cli.py's progress bar",
}


def _function_level_imports(root: Path = PKG) -> list[tuple[str, int, str]]:
    out = []
    for p in sorted(root.rglob("*.py")):
        rel = str(p.relative_to(root))
        for fn in ast.walk(ast.parse(p.read_text())):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for s in ast.walk(fn):
                    if isinstance(s, ast.ImportFrom):
                        out.append((rel, s.lineno, "." * s.level + (s.module or "")))
                    elif isinstance(s, ast.Import):
                        out.extend((rel, s.lineno, a.name) for a in s.names)
    return sorted(set(out))


def test_no_function_level_import_except_the_listed_lazy_ones():
    found = _function_level_imports()
    assert len(found) > 50  # it saw the package
    bad = [f"{f}:{line} imports {mod}" for f, line, mod in found
           if not ((mod.startswith(("visnav", ".")) and f in LAZY_VISNAV)
                   or mod.split(".")[0] in LAZY_THIRD_PARTY)]
    assert bad == [], "move these to module level (or list a lazy load with its reason)"


def test_the_function_level_check_sees_one(tmp_path):
    root = _package(tmp_path, {"a.py": "def f():\n    import json\n    from pkg import b\n", "b.py": ""})
    assert _function_level_imports(root) == [("a.py", 2, "json"), ("a.py", 3, "pkg")]
