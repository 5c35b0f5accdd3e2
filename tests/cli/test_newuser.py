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
