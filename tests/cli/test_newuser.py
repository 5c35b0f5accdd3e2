"""What a new user still hit (issue #32) and the run outcome (issue #30 item 4): each test reproduces one
point of the issue on the code before it and checks the fix."""

import json
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from visnav.cli import app

SHORT = ["--set", "run.duration_s=1"]


def _invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _one_line_error(r, text):
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output and (r.exception is None or isinstance(r.exception, SystemExit)), r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and text in lines[0], r.stderr


# ------------------------------------------------------------------ point 1: --force refuses foreign folders
@pytest.mark.parametrize("make, text", [
    (lambda d: (d / "campaign.json").write_text("{}") or (d / "report.html").write_text("x"), "a campaign folder"),
    (lambda d: (d / "imu.csv").write_text("t_s\n") or (d / "camera.yaml").write_text(""), "a recording"),
    (lambda d: (d / "faults.csv").write_text("fault\n"), "a fault campaign folder"),
    (lambda d: (d / "bridge.tlog").write_bytes(b"") or (d / "metrics.json").write_text("{}"), "a bridge log folder"),
    (lambda d: (d / "thesis.txt").write_text("mine"), "a folder of other files (thesis.txt)"),
])
def test_force_refuses_a_folder_that_is_not_a_run_folder(tmp_path, make, text):
    d = tmp_path / "out"
    d.mkdir()
    make(d)
    before = {p.name: p.read_bytes() for p in d.iterdir()}
    r = _invoke("run", "pfcm-segment", *SHORT, "--out", d, "--force", "--no-report")
    _one_line_error(r, text)
    assert {p.name: p.read_bytes() for p in d.iterdir()} == before  # nothing replaced, nothing added


def test_force_refuses_home_and_root(monkeypatch, tmp_path):
    from visnav.app.runs import OutputDirError, folder_kind, prepare_out_dir

    assert folder_kind("/") == "the root directory"
    with pytest.raises(OutputDirError, match="is the root directory"):
        prepare_out_dir("/", force=True)
    home = tmp_path / "home"
    home.mkdir()
    (home / ".bashrc").write_text("")
    monkeypatch.setenv("HOME", str(home))
    assert folder_kind(home) == "your home directory"
    with pytest.raises(OutputDirError, match="your home directory"):
        prepare_out_dir(home, force=True, kind=None)
    assert (home / ".bashrc").exists()


def test_force_still_replaces_an_earlier_run(tmp_path):
    d = tmp_path / "run"
    assert _invoke("run", "pfcm-segment", *SHORT, "--out", d, "--no-report").exit_code == 0
    from visnav.app.runs import folder_kind

    assert folder_kind(d) == "a run folder"
    r = _invoke("run", "pfcm-segment", *SHORT, "--out", d, "--force", "--no-report", "--seed", "7")
    assert r.exit_code == 0, r.output
    assert "seed = 7" in (d / "scenario.toml").read_text()


# ------------------------------------------------------------------ a short simulated recording (points 2, 3, 4)
@pytest.fixture(scope="module")
def witas_rec(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec") / "witas"
    r = _invoke("record", "witas-homing", "--out", d, "--set", "run.duration_s=2")
    assert r.exit_code == 0, r.output
    return d


# ------------------------------------------------------------------ point 2: any navigator on any recording
@pytest.mark.filterwarnings("error::RuntimeWarning", "error::UserWarning")
@pytest.mark.parametrize("navigator", ["palace", "deck", "pad", "condor", "geolocation", "witas"])
def test_any_navigator_on_a_witas_recording_runs_or_says_what_it_lacks(witas_rec, tmp_path, navigator):
    r = _invoke("replay", witas_rec, "--navigator", navigator, "--out", tmp_path / "o")
    assert "Traceback" not in r.output and (r.exception is None or isinstance(r.exception, SystemExit)), r.output
    if r.exit_code == 2:  # one line naming the streams or the part it lacks
        _one_line_error(r, "needs")
        return
    assert r.exit_code == 0, r.output
    m = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert "error" not in m and m["imu_samples"] == 200, m
    if navigator != "witas":  # the settings come from its own scenario, and the user is told
        assert f"the {navigator} navigator takes its settings from" in " ".join(r.stdout.split())


# ------------------------------------------------------------------ point 4: outputs before inputs; eval empty
def test_replay_checks_out_before_reading_the_recording(tmp_path):
    f = tmp_path / "afile"
    f.write_text("x")
    r = _invoke("replay", tmp_path / "no-such-recording", "--navigator", "witas", "--out", f)
    _one_line_error(r, "exists and is not a directory")  # the output is refused, not the missing recording


def test_replay_leaves_no_empty_out_folder_on_an_input_error(tmp_path):
    r = _invoke("replay", tmp_path / "no-such-recording", "--navigator", "witas", "--out", tmp_path / "o")
    _one_line_error(r, "no-such-recording")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name, text", [("empty.tum", "no poses"), ("empty.csv", "no rows")])
def test_eval_of_an_empty_file_is_one_line_without_a_library_warning(tmp_path, name, text):
    import warnings

    f = tmp_path / name
    f.write_text("t_s,x_m,y_m,z_m\n" if name.endswith(".csv") else "")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = _invoke("eval", f, f)
    _one_line_error(r, text)
    assert not [w for w in caught if "numpy" in str(w.filename) or "input contained no data" in str(w.message)]


# ------------------------------------------------------------------ point 3: a truncated imu.csv
def _cut_imu(src: Path, dst: Path) -> tuple[int, int]:
    """A copy of the recording whose imu.csv is cut in the middle of a row; (that line's number, its columns)."""
    import shutil

    shutil.copytree(src, dst)
    lines = (dst / "imu.csv").read_text().splitlines()
    keep = len(lines) // 2
    cut_row = ",".join(lines[keep].split(",")[:5])
    (dst / "imu.csv").write_text("\n".join(lines[:keep] + [cut_row]))
    return keep + 1, 5


@pytest.mark.filterwarnings("error::RuntimeWarning", "error::UserWarning")  # no library warning on the console
def test_truncated_imu_csv_is_named_and_allow_truncated_replays_what_came_before(witas_rec, tmp_path):
    line, cols = _cut_imu(witas_rec, tmp_path / "cut")
    expected = len((witas_rec / "imu.csv").read_text().splitlines()[0].split(","))
    r = _invoke("replay", tmp_path / "cut", "--navigator", "witas", "--out", tmp_path / "o")
    _one_line_error(r, f"imu.csv: line {line} has {cols} columns, {expected} expected (truncated file?)")
    assert "usecols" not in r.output
    r = _invoke("replay", tmp_path / "cut", "--navigator", "witas", "--out", tmp_path / "o", "--allow-truncated")
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "o" / "metrics.json").read_text())["imu_samples"] == line - 2
    assert f"read the {line - 2} rows before it" in " ".join(r.stdout.split())


# ------------------------------------------------------------------ point 7: names never cut; 9: vrs, ate; #30.4
@pytest.fixture(scope="module")
def segment_run(tmp_path_factory):
    """A 3 s pfcm-segment run (on the path from 2 s) printed 80 columns wide (as `make run` off a terminal did)."""
    from rich.console import Console

    import visnav.cli as cli

    d = tmp_path_factory.mktemp("seg") / "run"
    old = cli.console
    cli.console = Console(width=80)
    try:
        r = _invoke("run", "pfcm-segment", "--set", "run.duration_s=3", "--out", d, "--no-report")
    finally:
        cli.console = old
    assert r.exit_code == 0, r.output
    return d, r.stdout


def test_the_summary_never_cuts_a_metric_name(segment_run):
    d, out = segment_run
    names = [k for k, v in json.loads((d / "metrics.json").read_text()).items()
             if k != "provenance" and v is not None]
    assert "hpl_bound_violations" in names and "worst_error_while_ok_m" in names
    cells = {c.strip() for line in out.splitlines() for c in line.split("│")}
    assert [n for n in names if n not in cells] == []
    assert "…" not in out


def test_no_vortex_ring_approach_in_table_and_json_and_metrics_has_ate(segment_run):
    d, out = segment_run
    m = json.loads((d / "metrics.json").read_text())
    assert m["vrs_margin_min_mps"] == "no vortex-ring approach"  # a level segment: eq. 4.23 limits nothing
    row = [line for line in out.splitlines() if "vrs_margin_min_mps" in line][0]
    assert "no vortex-ring" in row and "inf" not in row.split("│")[2]  # (80 columns: the value folds)
    r = _invoke("metrics", d, "--json")
    assert r.exit_code == 0, r.output
    again = json.loads(r.stdout)
    assert again["vrs_margin_min_mps"] == "no vortex-ring approach"
    assert again["ate_rmse_m"] == pytest.approx(m["ate_rmse_m"], rel=1e-9)
    assert _invoke("metrics", d).stdout.startswith("outcome: safe")  # the table opens with the verdict too


def test_the_summary_opens_with_the_verdict(segment_run):
    d, out = segment_run
    m = json.loads((d / "metrics.json").read_text())
    assert m["outcome"] == "safe"
    assert out.splitlines()[0].startswith("outcome: safe")


def test_the_verdict_names_hpl_violations_while_ok():
    from visnav.analysis.outcome import verdict_line

    line = verdict_line({"outcome": "safe", "outcome_reason": "orbit radius error up to 12.0 m while ok",
                         "hpl_bound_violations": 6, "hpl_samples_ok": 23950, "worst_error_while_ok_m": 18.7})
    assert line.startswith("outcome: safe") and "6 steps of 23950" in line and "18.7 m" in line
    assert "HPL" not in verdict_line({"outcome": "safe", "hpl_bound_violations": 0})


def test_an_interrupted_run_reports_interrupted(tmp_path):
    from visnav.app.runs import write_run
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    sim = make_simulation(load_scenario("pfcm-segment", ["run.duration_s=3"]))

    def ctrl_c(t, total):
        if t > 0.5:
            raise KeyboardInterrupt

    res = sim.run(progress=ctrl_c)
    assert res.interrupted and res.metrics["outcome"] == "interrupted"
    write_run(res, tmp_path, report=False)
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["outcome"] == "interrupted" and m["interrupted"] is True
    assert json.loads(_invoke("metrics", tmp_path, "--json").stdout)["outcome"] == "interrupted"


def test_an_abort_without_touchdown_is_aborted_and_counts_safe_in_a_fault_campaign():
    import numpy as np

    from visnav.app.fault_campaign import fault_row
    from visnav.analysis.outcome import OUTCOMES, run_outcome
    from visnav.scenarios.schema import load_scenario

    log = {"mode": {"t": np.array([0.0, 40.0]), "mode": ["descend_mpe", "abort"],
                    "reason": ["", "integrity unusable"]}}
    out, why = run_outcome(log, load_scenario("palace-landing"), {"outcome": "safe",
                                                                 "outcome_reason": "no landing (held or aborted)"})
    assert (out, why) == ("aborted", "abort at t=40.0 s: integrity unusable") and out in OUTCOMES
    assert run_outcome({}, load_scenario("mav-geolocation-single"), {})[0] == "not_applicable"
    row = fault_row("x", [{"status": "ok", "outcome": "aborted"}, {"status": "ok", "outcome": "unsafe"},
                          {"status": "failed"}])
    assert (row["safe"], row["unsafe"]) == (1, 2)


# ------------------------------------------------------------------ point 8: not applicable, not scored
def test_a_one_frame_geolocation_is_not_scored_against_the_rls_figures():
    from visnav.analysis.published import summary_rows
    from visnav.scenarios.schema import load_scenario

    metrics = {"target_error_m": 1.3, "samples_to_3m": 1.0, "single_frame_error_median_m": 3.0}
    single = {r.metric: r for r in summary_rows(load_scenario("mav-geolocation-single"), metrics)[0]}
    assert single["samples_to_3m"].verdict == "not scored" and "one frame" in single["samples_to_3m"].thesis
    assert single["target_error_m"].verdict == "not scored"
    assert single["single_frame_error_median_m"].verdict.startswith("meets")
    many = {r.metric: r for r in summary_rows(load_scenario("mav-geolocation"), metrics)[0]}
    assert many["samples_to_3m"].verdict.startswith("meets") and many["target_error_m"].verdict.startswith("meets")


# ------------------------------------------------------------------ point 10: the bank limit, by how much
def test_max_roll_over_the_bank_limit_says_by_how_much_and_how_long():
    import numpy as np

    from visnav.analysis.path_metrics import notes
    from visnav.analysis.published import PFCM, verdict
    from visnav.scenarios.schema import load_scenario

    p = next(x for x in PFCM if x.metric == "max_roll_deg")
    assert verdict(p, 15.623) == "does not meet (> 15 deg, by 0.623 deg)"
    assert verdict(p, 14.9) == "meets (<= 15 deg)"
    t = np.arange(0.0, 10.0, 0.01)
    roll = np.where((t > 4.0) & (t <= 4.5), np.radians(15.6), np.radians(10.0))
    log = {"truth": {"t": t, "euler": np.column_stack([roll, 0 * t, 0 * t])},
           "mode": {"t": np.array([1.0]), "mode": ["follow"]}}
    (line,) = notes(log, load_scenario("pfcm-spiral"), {})
    assert "exceeds the bank limit phi_max 15 deg by 0.6 deg, for 0.5 s of the 9 s on the path" in line
    assert "16.5 deg" in line  # the controller's command limit, said
    log["truth"]["euler"][:, 0] = np.radians(14.0)
    assert notes(log, load_scenario("pfcm-spiral"), {}) == []


# ------------------------------------------------------------------ point 6: long runs show progress
def test_progress_off_a_terminal_is_a_plain_line_every_10_s_of_wall_time():
    from io import StringIO

    from rich.console import Console

    from visnav.cli import RunProgress

    now = [0.0]
    con = Console(file=StringIO(), width=200)  # not a terminal
    with RunProgress("palace-landing", 120.0, con, clock=lambda: now[0]) as p:
        for wall, t in [(0.0, 0.0), (5.0, 3.0), (10.5, 6.0), (15.0, 9.0), (21.0, 12.6)]:
            now[0] = wall
            p.update(t, "mode descend_gps")
    lines = con.file.getvalue().splitlines()
    assert lines == ["palace-landing: t=6.0 s of 120 s (5 %), mode descend_gps, 10 s elapsed",
                     "palace-landing: t=12.6 s of 120 s (10 %), mode descend_gps, 21 s elapsed"]


def test_a_run_off_a_terminal_says_where_it_is(tmp_path, monkeypatch):
    from visnav.cli import RunProgress

    monkeypatch.setattr(RunProgress, "every_s", 0.0)  # a line at every step
    r = _invoke("run", "pfcm-segment", *SHORT, "--out", tmp_path / "r", "--no-report")
    assert r.exit_code == 0, r.output
    progress = [line for line in r.stderr.splitlines() if line.startswith("pfcm-segment: t=")]
    assert len(progress) >= 5 and "mode " in progress[-1]


# ------------------------------------------------------------------ point 11: reports open with the outcome
def test_the_report_opens_with_the_outcome_and_the_headline_figures():
    from visnav.analysis.report import headline_html
    from visnav.scenarios.schema import load_scenario

    sc = load_scenario("condor-orbit")
    m = {"outcome": "safe", "outcome_reason": "orbit radius error up to 12.0 m while ok", "hpl_bound_violations": 6,
         "hpl_samples_ok": 23950, "worst_error_while_ok_m": 18.7, "radius_est_error_max_pct": 22.0,
         "tracking_lost_s": 6.0, "radius_est_error_rms_pct": 5.0}
    top = headline_html(sc, m)
    assert top.index("outcome: safe") < top.index("radius_est_error_max_pct")
    assert "6 steps of 23950" in top and "#ffe0e0" in top  # HPL violations while ok: not shown as all well
    assert "does not meet (&gt; 4 s, by 2 s)" in top  # tracking_lost_s against Fig. 7.1's 4 s
    assert "radius_est_error_rms_pct" not in top  # no bound in the thesis: not a headline


def test_the_report_page_has_the_verdict_above_the_metrics_table(tmp_path):
    from visnav.analysis.report import write_report
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    res = make_simulation(load_scenario("pfcm-segment", ["run.duration_s=3"])).run()
    write_report(res, tmp_path / "report.html")
    page = (tmp_path / "report.html").read_text()
    assert page.index("<b>outcome: safe") < page.index("headline figure") < page.index("<h2>Metrics")


def test_the_witas_pmf_map_panel_has_a_legend(monkeypatch):
    import numpy as np

    import visnav.analysis.witas_metrics as witas_metrics
    from visnav.analysis.witas_metrics import plots
    from visnav.scenarios.schema import load_scenario

    figs = []

    class Enough(Exception):
        pass

    def keep(fig):
        figs.append(fig)
        raise Enough

    monkeypatch.setattr(witas_metrics, "_fig_to_img", keep)
    t = np.linspace(0.0, 10.0, 11)
    pos = np.column_stack([t * 5.0, t * 2.0, -60.0 + 0 * t])
    log = {"truth": {"t": t, "position": pos},
           "pmf": {"t": t, "position": pos[:, :2] + 1.0, "cov": np.tile(np.eye(2) * 4.0, (t.size, 1, 1))}}
    with pytest.raises(Enough):
        plots(log, load_scenario("witas-homing"))
    panels = figs[0].axes[:2]
    texts = [[x.get_text() for x in a.get_legend().get_texts()] if a.get_legend() else [] for a in panels]
    assert "PMF 3-sigma north/east ellipse" in texts[1] and "PMF" in texts[1], texts


def test_a_campaign_counts_its_outcomes_and_its_runs_over_the_hpl():
    from visnav.app.montecarlo import summarize
    from visnav.analysis.outcome import outcome_text

    rows = [{"seed": "1", "status": "ok", "outcome": "safe", "hpl_bound_violations": "0"},
            {"seed": "2", "status": "ok", "outcome": "safe", "hpl_bound_violations": "6"},
            {"seed": "3", "status": "ok", "outcome": "aborted", "hpl_bound_violations": "0"}]
    s = summarize(rows, [])
    assert s["outcomes"] == {"safe": 2, "aborted": 1, "hpl_violated_while_ok": 1}
    assert outcome_text(s["outcomes"]) == "outcomes: 2 safe, 1 aborted; 1 run with steps over the HPL while ok"


def test_a_replay_off_a_terminal_says_where_it_is(witas_rec, tmp_path, monkeypatch):
    from visnav.cli import RunProgress

    monkeypatch.setattr(RunProgress, "every_s", 0.0)
    r = _invoke("replay", witas_rec, "--navigator", "witas", "--out", tmp_path / "o")
    assert r.exit_code == 0, r.output
    lines = [x for x in r.stderr.splitlines() if x.startswith("replay on witas: ")]
    n = int(lines[0].split(" of ")[1].split()[0])
    assert lines and n > 200 and lines[0].startswith("replay on witas: 0 of ")  # the events of 2 s of flight
