"""Campaign runner: local pool == Dask cluster row for row, resume, failures kept, bad input."""

import csv
import json

import pytest
from typer.testing import CliRunner

from visnav.app.montecarlo import Campaign, CampaignError, parse_grid
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


# ---------------------------------------------------------------- issue 12: resume key, --new, rates, Ctrl-C
def _mc(out, *extra):
    args = ["montecarlo", "palace-hover-drift", "-n", "1", "--workers", "1", "--out", str(out)]
    args += [a for s in TINY for a in ("--set", s)]
    return CliRunner().invoke(app, args + list(extra))


def test_resume_with_another_configuration_is_refused_naming_the_keys(tmp_path):
    out = tmp_path / "c"
    assert _mc(out).exit_code == 0
    before = (out / "runs.csv").read_text(), (out / "campaign.json").read_text()
    r = _mc(out, "-n", "2", "--set", "sensors.imu.delay_s=0.05")
    assert r.exit_code == 2 and "Traceback" not in r.output
    line = r.stderr.strip()
    assert "\n" not in line and "another configuration" in line and "sensors.imu.delay_s: 0.0 -> 0.05" in line
    assert "--new" in line
    assert ((out / "runs.csv").read_text(), (out / "campaign.json").read_text()) == before  # untouched
    # the same configuration resumes, and says how much is left
    r = _mc(out, "-n", "2")
    assert r.exit_code == 0, r.output
    assert "1 already done, 1 to run" in r.stderr
    assert len(_rows(out / "runs.csv")) == 2


def test_new_starts_a_fresh_campaign_beside_and_says_where(tmp_path):
    out = tmp_path / "c"
    assert _mc(out).exit_code == 0
    r = _mc(out, "--set", "sensors.imu.delay_s=0.05", "--new", "--json")
    assert r.exit_code == 0, r.output
    assert f"starting a new one in {tmp_path / 'c-2'}" in " ".join(r.stderr.split())
    d = json.loads(r.stdout)
    assert d["campaign_dir"] == str(tmp_path / "c-2") and d["summary"]["count"] == 1
    assert json.loads((tmp_path / "c-2" / "campaign.json").read_text())["resolved"]["sensors"]["imu"]["delay_s"] == 0.05
    assert len(_rows(out / "runs.csv")) == 1


def test_summary_has_rates_of_boolean_metrics_and_the_thesis_figures():
    from visnav.app.montecarlo import summarize

    rows = [{"seed": str(s), "status": "ok", "error": "", "landed": v, "touchdown_error_m": str(e)}
            for s, v, e in ((1, "True", 0.1), (2, "False", 0.3), (3, "True", 0.2), (4, "True", 0.4))]
    rows.append({"seed": "5", "status": "failed", "error": "x", "landed": "", "touchdown_error_m": ""})
    s = summarize(rows, [], {"touchdown_error_m": "0.5 m", "landed": "8 of 8"})
    assert s["rates"]["landed"] == {"rate": 0.75, "count": 3, "n": 4, "published": "8 of 8"}
    assert s["metrics"]["touchdown_error_m"]["mean"] == pytest.approx(0.25)
    assert s["metrics"]["touchdown_error_m"]["published"] == "0.5 m" and "landed" not in s["metrics"]


def test_summary_counts_the_runs_inside_a_published_band():
    """A metric whose thesis figure is a band (the deck NEES's 95 % chi2(12) band 4.40-23.34): how many runs lie
    inside it, ends included, of those with a number."""
    from visnav.app.montecarlo import summarize

    rows = [{"seed": str(s), "status": "ok", "error": "", "nees_mean": str(v)}
            for s, v in enumerate((3.0, 4.404, 11.0, 23.337, 23.4, "nan"), 1)]
    s = summarize(rows, [], {}, {"nees_mean": (4.404, 23.337)})
    assert s["metrics"]["nees_mean"]["in_band"] == 3 and s["metrics"]["nees_mean"]["n"] == 5
    assert s["metrics"]["nees_mean"]["band"] == [4.404, 23.337]
    assert "in_band" not in summarize(rows, [])["metrics"]["nees_mean"]


def test_campaign_summary_json_carries_rates_and_source(tmp_path):
    out = tmp_path / "c"
    assert _mc(out).exit_code == 0
    s = json.loads((out / "summary.json").read_text())
    assert "aborted" not in s["metrics"] and s["published_source"]
    assert s["rates"] and all(set(v) >= {"rate", "count", "n"} for v in s["rates"].values())
    camp = json.loads((out / "campaign.json").read_text())
    assert s["provenance"]["scenario_hash"] == camp["scenario_hash"]  # the campaign's identity, not one run's
    assert s["provenance"]["visnav_version"] and s["provenance"]["date_utc"]


def test_ctrl_c_in_a_campaign_keeps_finished_rows_and_says_how_to_resume(tmp_path, monkeypatch):
    import visnav.app.montecarlo as mc

    orig, n = mc.run_job, []

    def job(j):
        n.append(1)
        if len(n) == 2:
            raise KeyboardInterrupt
        return orig(j)

    monkeypatch.setattr(mc, "run_job", job)
    out = tmp_path / "c"
    r = _mc(out, "-n", "3")
    assert r.exit_code == 130, r.output
    assert f"run the same command with --out {out}" in " ".join(r.stderr.split())
    rows = _rows(out / "runs.csv")
    assert [x["seed"] for x in rows] == ["1"] and rows[0]["status"] == "ok"
    monkeypatch.setattr(mc, "run_job", orig)
    r = _mc(out, "-n", "3")
    assert r.exit_code == 0 and "1 already done, 2 to run" in r.stderr
    assert [x["seed"] for x in _rows(out / "runs.csv")] == ["1", "2", "3"]
