"""``visnav faults``: the campaign files, resume, and one-line errors."""

from __future__ import annotations

import csv

import pytest
from typer.testing import CliRunner

from visnav.cli import app

SHORT = ["--set", "run.duration_s=1"]


def _invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.mark.slow  # four 1 s runs; the table and the errors are covered quickly in tests/analysis
def test_fault_campaign_writes_faults_csv_and_resumes(tmp_path):
    out = tmp_path / "fc"
    r = _invoke("faults", "palace-landing", "--faults", "range_dropout", "-n", "1", "--workers", "1", *SHORT,
                "--out", out)
    assert r.exit_code == 0, r.output
    rows = list(csv.DictReader((out / "faults.csv").open()))
    assert [x["fault"] for x in rows] == ["none", "range_dropout"]
    assert list(rows[0]) == ["fault", "runs", "detected_share", "detection_delay_s", "false_alarms", "safe",
                             "unsafe", "worst_error_while_ok_m"]
    assert rows[0]["runs"] == "1" and int(rows[0]["safe"]) + int(rows[0]["unsafe"]) == 1
    assert (out / "faults.md").read_text().startswith("# Fault campaign: palace-landing")
    runs = list(csv.DictReader((out / "range_dropout" / "runs.csv").open()))
    assert runs[0]["faults_injected"] == "1" and runs[0]["outcome"] in ("safe", "unsafe")
    r = _invoke("faults", "palace-landing", "--faults", "range_dropout", "-n", "1", "--workers", "1", *SHORT,
                "--out", out)
    assert r.exit_code == 0 and "1 done, 0 to run" in r.stderr


def test_fault_campaign_errors_are_one_line(tmp_path):
    for args, text in ((["pfcm-segment"], "no fault set"), (["palace-landing", "--faults", "volcano"], "unknown fault")):
        r = _invoke("faults", *args, "-n", "1", "--out", tmp_path / "x")
        assert r.exit_code == 2, r.output
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error:") and text in lines[0], r.stderr
