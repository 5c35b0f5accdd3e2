"""log.h5: units, frame and description on every dataset; docs/log-format.md's example runs on a fresh log."""

import ast
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

from visnav.scenarios.schema import builtin_names, load_scenario
from visnav.sim import streams
from visnav.flightlog import STREAMS, FlightLog
from visnav.app.missions import make_simulation

ROOT = Path(__file__).resolve().parents[2]
#: short runs that still reach each scenario's vision streams
SHORT = {"witas-homing": ["run.duration_s=11", "mission.gps_loss_s=3", "mission.settle_s=1"],
         "condor-orbit": ["run.duration_s=2.5", "mission.orbit.switch_time_s=1"],
         "condor-ground-test": [], "palace-landing": ["run.duration_s=4"]}


def _short_log(name: str, tmp_path: Path) -> Path:
    over = SHORT.get(name, ["run.duration_s=3"])
    res = make_simulation(load_scenario(name, over)).run()
    assert res.error is None, res.error
    path = tmp_path / f"{name}.h5"
    res.log.to_hdf5(path, attrs={"scenario": name})
    return path


def _datasets(path: Path) -> list[tuple[str, h5py.Dataset]]:
    out = []
    with h5py.File(path) as f:
        f.visititems(lambda n, o: out.append((n, dict(o.attrs))) if isinstance(o, h5py.Dataset) else None)
    return out


@pytest.mark.parametrize("name", builtin_names())
def test_every_dataset_of_every_scenario_has_a_documented_unit(name, tmp_path):
    sets = _datasets(_short_log(name, tmp_path))
    assert len(sets) > 10
    undocumented = [n for n, a in sets if not a.get("units")]
    assert undocumented == [], f"{name}: datasets without units: {undocumented}"
    assert all(a.get("frame") is not None and a.get("description") is not None for _, a in sets)
    attrs = dict(sets)
    assert attrs["truth/t"]["units"] == ("1" if name == "condor-ground-test" else "s")  # there: the table row
    if name.startswith("deck"):  # the relative deck state, not a world pose
        assert attrs["truth/position"]["frame"] == "vehicle body FRD"
        assert attrs["vehicle/position"]["frame"].startswith("NED world")
    elif name != "condor-ground-test":
        assert (attrs["truth/position"]["units"], attrs["truth/euler"]["units"]) == ("m", "rad")
        assert attrs["truth/position"]["frame"].startswith("NED world")


def _recorded_fields() -> set[tuple[str, str]]:
    """(stream, field) of every ``record("stream", t, field=...)`` / ``recorder(...)`` call in the source."""
    out = set()
    for path in (ROOT / "src" / "visnav").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
                    and isinstance(node.args[0].value, str)):
                continue
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if name in ("record", "recorder", "mission_record"):
                out |= {(node.args[0].value, k.arg) for k in node.keywords if k.arg}
    return out


def test_every_field_recorded_anywhere_in_the_source_is_documented():
    """Also the streams a short run does not reach (touchdown, reinit, actuator, retarget_skipped, error)."""
    import importlib
    import pkgutil

    import visnav

    for m in pkgutil.walk_packages(visnav.__path__, "visnav."):  # each module registers its streams on import
        if m.name != "visnav.cli":
            importlib.import_module(m.name)
    tables = [STREAMS] + [v for k, v in vars(streams).items() if k.endswith("_STREAMS")]  # every simulation's
    fields = _recorded_fields()
    assert {("touchdown", "speed"), ("mpe", "position"), ("vision", "radius"), ("camera", "nis")} <= fields
    missing = sorted((s, k) for s, k in fields if not any(k in t.get(s, {}) for t in tables))
    assert missing == []


def test_an_unknown_field_gets_an_empty_unit(tmp_path):
    log = FlightLog(schema={"truth": {"position": ("m", "NED world", "x")}})
    log.record("truth", 0.0, position=np.zeros(3), mystery=1.0)
    log.to_hdf5(tmp_path / "l.h5")
    with h5py.File(tmp_path / "l.h5") as f:
        assert f["truth/mystery"].attrs["units"] == "" and f["truth/position"].attrs["units"] == "m"
        assert f["truth/t"].attrs["units"] == "s"
    back = FlightLog.from_hdf5(tmp_path / "l.h5")
    assert back.field("truth", "position").frame == "NED world"


def test_the_reading_example_of_docs_log_format_runs_on_a_fresh_log(tmp_path, capsys):
    doc = (ROOT / "docs" / "log-format.md").read_text()
    code = re.search(r"```python\n(.*?)```", doc, re.S).group(1)
    assert len(code.strip().splitlines()) <= 12
    path = _short_log("palace-landing", tmp_path)
    exec(compile(code, "log-format.md", "exec"), {"LOG": str(path)})
    out = capsys.readouterr().out
    assert "m | NED world (origin at the scenario's home)" in out
    assert "estimate/valid" in out and "bool" in out and "s logged, max height" in out
