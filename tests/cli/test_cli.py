"""The command line as a new user meets it (issue 12, points 3, 4, 5, 7, 8, 9): no traceback for a
user error, one line on stderr and exit 2; Ctrl-C keeps the run; help, --version, keys, --json."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from visnav.cli import app
from visnav.scenarios.schema import builtin_names

SHORT = ["--set", "run.duration_s=1"]
SRC = str(Path(__file__).resolve().parents[2] / "src")


def _invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _one_line_error(r, text):
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    assert r.exception is None or isinstance(r.exception, SystemExit)  # no uncaught exception
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and text in lines[0], r.stderr
    assert r.stdout == ""


# ----------------------------------------------------------------- point 3: names vs paths
def test_a_folder_named_like_a_scenario_does_not_shadow_the_builtin(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "palace-landing").mkdir()  # left by an earlier --out palace-landing
    (tmp_path / "palace-hover-drift").mkdir()
    r = _invoke("scenarios")
    assert r.exit_code == 0 and "palace-landing" in r.stdout, r.output
    r = _invoke("run", "palace-landing", *SHORT, "--no-report", "--out", "r")
    assert r.exit_code == 0, r.output
    assert "palace-landing" in (tmp_path / "r" / "scenario.toml").read_text()
    r = _invoke("montecarlo", "palace-hover-drift", "-n", "1", "--workers", "1", *SHORT, "--out", "mc")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "mc" / "runs.csv").read_text().count("\n") == 2


@pytest.mark.parametrize("make, arg, text", [
    (lambda p: (p / "mine").mkdir(), "mine", "'mine' is a directory, not a scenario"),
    (lambda p: (p / "x.toml").mkdir(), "x.toml", "'x.toml' is a directory, not a scenario"),
    (lambda p: (p / "notes.txt").write_text("[run]\n"), "notes.txt", "'notes.txt' is not a .toml file"),
    (lambda p: None, "missing.toml", "scenario file not found: missing.toml"),
    (lambda p: None, "palace-landin", "unknown scenario 'palace-landin'"),
])
def test_what_is_not_a_scenario_is_one_line(tmp_path, monkeypatch, make, arg, text):
    monkeypatch.chdir(tmp_path)
    make(tmp_path)
    for cmd in (["run", arg], ["montecarlo", arg, "-n", "1"], ["keys", arg]):
        _one_line_error(_invoke(*cmd), text)


def test_an_existing_toml_file_wins_over_the_builtin_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("palace-landing.toml").write_text('[run]\nname = "my-own"\nduration_s = 0.5\n')
    r = _invoke("run", "palace-landing.toml", "--no-report", "--out", "r")
    assert r.exit_code == 0, r.output
    assert 'name = "my-own"' in Path("r/scenario.toml").read_text()


# ----------------------------------------------------------------- point 4: --out, --force
def test_out_into_a_non_empty_directory_is_refused_unless_force(tmp_path):
    out = tmp_path / "r"
    out.mkdir()
    (out / "report.html").write_text("stale report of another scenario")
    (out / "mine.txt").write_text("not visnav's")
    _one_line_error(_invoke("run", "palace-landing", *SHORT, "--out", out), "is not empty; use --force")
    assert (out / "report.html").read_text().startswith("stale")
    r = _invoke("run", "palace-landing", *SHORT, "--out", out, "--force", "--no-report")
    assert r.exit_code == 0, r.output
    assert not (out / "report.html").exists()  # removed, not left stale
    assert (out / "mine.txt").exists() and (out / "metrics.json").exists()


def test_default_run_directories_are_new_and_timestamped(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for _ in range(2):
        assert _invoke("run", "palace-landing", *SHORT, "--no-report").exit_code == 0
    dirs = sorted(p.name for p in (tmp_path / "runs").iterdir())
    assert len(dirs) == 2 and all(d.startswith("palace-landing-20") for d in dirs)


# ----------------------------------------------------------------- point 7: unwritable --out
def _unwritable(tmp_path):
    (tmp_path / "afile").write_text("")
    return ["/proc/visnav-no/out", str(tmp_path / "afile" / "sub"), str(tmp_path / "afile")]


@pytest.mark.parametrize("cmd", [["run", "palace-landing", *SHORT], ["montecarlo", "palace-hover-drift", "-n", "1"],
                                 ["margins", "palace-sweep", "--altitudes", "12", "--delays", "0"]])
def test_unwritable_out_is_one_line_on_stderr_and_exit_2(tmp_path, cmd):
    for out in _unwritable(tmp_path):
        _one_line_error(_invoke(*cmd, "--out", out), str(out))


# ----------------------------------------------------------------- point 5: Ctrl-C
def test_ctrl_c_during_a_run_writes_what_it_has_and_exits_130(tmp_path, monkeypatch):
    from visnav.app.rmax_parts import RmaxLogger

    orig, calls = RmaxLogger.__call__, []

    def log_step(self, *a, **k):
        orig(self, *a, **k)
        calls.append(1)
        if len(calls) == 15:  # 1.4 s into the run
            raise KeyboardInterrupt

    monkeypatch.setattr(RmaxLogger, "__call__", log_step)
    out = tmp_path / "r"
    r = _invoke("run", "palace-landing", "--out", out, "--no-report")
    assert r.exit_code == 130, r.output
    assert len(r.stderr.strip().splitlines()) == 1 and "interrupted" in r.stderr
    m = json.loads((out / "metrics.json").read_text())
    assert m["interrupted"] is True and m["sim_time_s"] == pytest.approx(1.4, abs=0.11)
    with h5py.File(out / "log.h5") as f:
        assert len(f["truth/t"]) == 15
    assert (out / "scenario.toml").exists() and (out / "estimate.tum").exists()


@pytest.mark.realtime  # a signal at a wall-clock instant: run apart from the CPU-heavy suite
def test_sigint_to_a_running_visnav_run(tmp_path):
    out = tmp_path / "r"
    env = dict(os.environ, PYTHONPATH=SRC)
    # witas-homing: 143 s of flight, several seconds of wall time (a palace landing ends in ~1.5 s, before the
    # signal could come). SIGINT back to its default in the child: a suite started in the background of a
    # non-interactive shell (`make test &`) hands SIGINT down ignored, and a Python started so never raises
    # KeyboardInterrupt (the run then ended with rc 0 and nothing on stderr)
    p = subprocess.Popen([sys.executable, "-m", "visnav.cli", "run", "witas-homing", "--out", str(out),
                          "--no-report"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    t0 = time.monotonic()
    while not out.exists() and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.05)
    time.sleep(0.5)
    assert p.poll() is None, "the run ended before the signal could be sent"
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=120)
    assert p.returncode == 130, stderr
    assert "Traceback" not in stderr and "interrupted" in stderr
    assert json.loads((out / "metrics.json").read_text())["interrupted"] is True
    assert (out / "log.h5").exists()


# ----------------------------------------------------------------- point 8: help, version, keys, --json
def test_units_in_help_survive_rich_markup():
    import typer.main

    cmd = typer.main.get_command(app)
    seen = 0
    for name, sub in cmd.commands.items():
        out = " ".join(_invoke(name, "--help").stdout.split())
        for prm in sub.params:
            for token in re.findall(r"\[[a-z/]+\]", getattr(prm, "help", None) or ""):
                seen += 1
                assert token in out, (name, prm.name, token)
    assert seen >= 5


def test_version_and_scenario_names_in_run_help():
    import visnav

    r = _invoke("--version")
    assert r.exit_code == 0 and r.stdout.strip() == f"visnav {visnav.__version__}"
    text = " ".join(_invoke("run", "--help").stdout.split())
    assert all(n in text for n in builtin_names())


def test_keys_lists_every_settable_key_with_unit_range_and_description():
    r = _invoke("keys", "palace-landing", "--json")
    assert r.exit_code == 0, r.output
    rows = {k["key"]: k for k in json.loads(r.stdout)}
    k = rows["sensors.imu.delay_s"]
    assert k["value"] == 0.0 and k["unit"] == "s" and k["allowed"] == ">= 0 and <= 1.0"
    assert "UNKNOWN delay" in k["description"]
    assert rows["mission.glide_slope_deg"]["unit"] == "deg"
    assert rows["world.surface"]["allowed"] == "'concrete', 'asphalt', 'grass', 'gravel'"
    assert rows["sensors.imu.accel_noise"]["unit"] == "m/s^2"
    # every key it lists is accepted by --set with its own value
    from visnav.scenarios.schema import load_scenario

    sets = [f"{key}={json.dumps(v['value'])}" for key, v in rows.items() if v["value"] is not None]
    assert load_scenario("palace-landing", sets).model_dump() == load_scenario("palace-landing").model_dump()
    table = _invoke("keys", "deck-moving")
    assert table.exit_code == 0 and "mission.guidance.flare_s" in table.stdout


def test_run_json_is_machine_readable(tmp_path):
    r = _invoke("run", "palace-landing", *SHORT, "--out", tmp_path / "r", "--no-report", "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    assert d["run_dir"] == str(tmp_path / "r") and d["seed"] == 1 and d["metrics"]["sim_time_s"] > 0


# ----------------------------------------------------------------- point 9: margins scenario
def test_margins_says_which_scenarios_it_takes():
    _one_line_error(_invoke("margins", "palace-landing"), "built-in: palace-hover-drift, palace-sweep")
