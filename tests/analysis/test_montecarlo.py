"""Campaign runner: local pool == Dask cluster row for row, resume, failures kept, bad input."""

import csv

import pytest
from typer.testing import CliRunner

from visnav.analysis.montecarlo import Campaign, CampaignError, parse_grid
from visnav.cli import app

TINY = ["mission.hold_s=3", "run.duration_s=8", "mission.settle_s=1", "mission.coherence_time_s=0.5",
        "world.field_size_m=30"]


def _rows(path):
    with open(path, newline="") as f:
        return sorted(csv.DictReader(f), key=lambda r: (r["seed"], r.get("mission.altitude_m", "")))


def test_local_pool_and_dask_cluster_give_identical_rows(tmp_path):
    distributed = pytest.importorskip("distributed")
    seeds = list(range(1, 9))
    Campaign("palace-hover-drift", seeds, tmp_path / "local", TINY, workers=2).run()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        Campaign("palace-hover-drift", seeds, tmp_path / "dask", TINY, scheduler=client).run()
    a, b = _rows(tmp_path / "local" / "runs.csv"), _rows(tmp_path / "dask" / "runs.csv")
    assert len(a) == 8 and a == b
    assert all(r["status"] == "ok" for r in a)
    assert float(a[0]["drift_px"]) >= 0


def test_resume_runs_only_the_missing_seeds(tmp_path):
    out = tmp_path / "c"
    Campaign("palace-hover-drift", [1, 2], out, TINY, grid={"mission.altitude_m": [6]}, workers=1).run()
    first = _rows(out / "runs.csv")
    camp = Campaign("palace-hover-drift", [1, 2, 3], out, TINY, grid={"mission.altitude_m": [6]}, workers=1)
    assert [j.seed for j in camp.pending()] == [3]
    summary = camp.run()
    rows = _rows(out / "runs.csv")
    assert len(rows) == 3 and rows[:2] == first
    assert summary["count"] == 3 and (out / "summary.json").exists() and (out / "report.html").exists()


def test_a_failing_run_is_recorded_and_the_campaign_goes_on(tmp_path):
    out = tmp_path / "f"
    s = Campaign("palace-hover-drift", [1], out, TINY,
                 grid={"world.map_file": ["/no/such/map.png"]}, workers=1).run()
    rows = _rows(out / "runs.csv")
    assert s["failed"] == 1 and rows[0]["status"] == "failed" and "/no/such/map.png" in rows[0]["error"]


@pytest.mark.parametrize("args, text", [
    (["-n", "0"], "-n must be at least 1"),
    (["--grid", "mission.altitud_m=6,12"], "unknown scenario key 'mission.altitud_m'"),
    (["--grid", "mission.altitude_m="], "grid 'mission.altitude_m' is empty"),
    (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler at tcp://127.0.0.1:9"),
])
def test_bad_campaigns_give_one_line_and_exit_2(tmp_path, args, text):
    r = CliRunner().invoke(app, ["montecarlo", "palace-hover-drift", "--out", str(tmp_path / "x")] + args)
    assert r.exit_code == 2, r.output
    assert text in r.output and "Traceback" not in r.output


def test_parse_grid_values_are_toml():
    g = parse_grid(["mission.altitude_m=6, 12.5", 'world.surface="grass","asphalt"', "world.surface=grass"])
    assert g["mission.altitude_m"] == [6, 12.5]
    assert g["world.surface"] == ["grass"]
    with pytest.raises(CampaignError):
        parse_grid(["nokey"])
