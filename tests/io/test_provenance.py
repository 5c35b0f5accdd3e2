"""Provenance (visnav version, git commit, command line, date, scenario hash) in metrics.json and every report."""

import json
import subprocess
from datetime import datetime, timedelta, timezone
from pathlib import Path

import pytest

from visnav.io import provenance as pv
from visnav.scenarios.schema import load_scenario, scenario_hash

PKG = Path(pv.__file__).resolve().parents[1]


def _git_head():
    try:
        r = subprocess.run(["git", "-C", str(PKG), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5)
    except OSError:
        return None
    return r.stdout.strip() if r.returncode == 0 else None


def test_fields_name_the_code_the_command_the_date_and_the_scenario():
    sc = load_scenario("palace-landing", ["run.duration_s=50"])
    p = pv.provenance(sc, argv=["visnav", "run", "palace-landing", "--set", "run.duration_s=50", "--out", "a b"])
    from importlib.metadata import PackageNotFoundError, version

    try:
        assert p["visnav_version"] == version("visnav")
    except PackageNotFoundError:
        from visnav import __version__

        assert p["visnav_version"] == __version__
    head = _git_head()
    if head is None:
        assert p["git_commit"] is None
    else:
        assert p["git_commit"].split("+")[0] == head and len(head) == 40
    assert p["command_line"] == "visnav run palace-landing --set run.duration_s=50 --out 'a b'"
    date = datetime.fromisoformat(p["date_utc"])
    assert date.utcoffset() == timedelta(0) and abs(datetime.now(timezone.utc) - date) < timedelta(minutes=1)
    assert p["scenario_hash"] == scenario_hash(sc)
    assert p["scenario_hash"] != pv.provenance(load_scenario("palace-landing"))["scenario_hash"]


def test_no_git_gives_none_not_an_error(monkeypatch):
    pv.git_commit.cache_clear()
    monkeypatch.setenv("PATH", "/nonexistent")
    try:
        assert pv.git_commit() is None
    finally:
        pv.git_commit.cache_clear()


@pytest.fixture(scope="module")
def ground_run():
    from visnav.app.missions import make_simulation

    return make_simulation(load_scenario("condor-ground-test")).run()


def test_run_directory_carries_provenance(ground_run, tmp_path):
    import h5py

    from visnav.app.runs import write_run

    write_run(ground_run, tmp_path)
    m = json.loads((tmp_path / "metrics.json").read_text())
    prov = m.pop("provenance")
    assert set(prov) >= {"visnav_version", "git_commit", "command_line", "date_utc", "scenario_hash"}
    assert prov["scenario_hash"] == scenario_hash(ground_run.scenario)
    assert all(not isinstance(v, (dict, list)) for v in m.values())  # the metrics stay flat
    html = (tmp_path / "report.html").read_text()
    assert "<h2>Provenance</h2>" in html and prov["scenario_hash"] in html and prov["date_utc"] in html
    with h5py.File(tmp_path / "log.h5") as f:
        assert f.attrs["scenario_hash"] == prov["scenario_hash"]
        assert f.attrs["visnav_version"] == prov["visnav_version"]
