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
    from visnav.io.runs import OutputDirError, folder_kind, prepare_out_dir

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
    from visnav.io.runs import folder_kind

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
