"""``visnav record`` + ``visnav replay`` for the deck and CONDOR navigators (issue #14).

Short flights (deck-moving and deck-static: 3 s of LED frames, IMU and the autopilot's roll / pitch;
condor-orbit: 10 s with the switch to the GPS-free vision orbit at 4 s, so that the ground station's
tracker, the radius fixes over the telemetry link and the vision position all run) are flown once
with the recording proxy; the replay of the folder must give the closed loop's estimate at every
output time (<= 1e-6 m). Control cases show that the comparison can fail: one IMU sample taken out
of the deck recording, one delivered fix taken out of CONDOR's link.csv.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from visnav.io.recording import Recording, RecordingError
from visnav.app.replay import replay
from visnav.scenarios.schema import load_scenario
from visnav.app.record import record

DECK = ["run.duration_s=3"]
CONDOR = ["run.duration_s=10", "mission.orbit.switch_time_s=4"]


@pytest.fixture(scope="module")
def deck_rec(tmp_path_factory):
    d = tmp_path_factory.mktemp("deck-rec")
    return d, record(load_scenario("deck-moving", DECK), d)


@pytest.fixture(scope="module")
def condor_rec(tmp_path_factory):
    d = tmp_path_factory.mktemp("condor-rec")
    return d, record(load_scenario("condor-orbit", CONDOR), d)


def _max_difference(closed, replayed) -> tuple[float, int]:
    """Largest position difference over the closed loop's output times (each must be replayed)."""
    a, b = closed.get("estimate"), replayed.get("estimate")
    idx = np.searchsorted(b["t"], a["t"])
    assert np.all(idx < len(b["t"])) and np.array_equal(b["t"][idx], a["t"]), "every closed-loop output time replayed"
    va = np.asarray(a["valid"], bool) if "valid" in a else np.ones(len(a["t"]), bool)
    vb = np.asarray(b["valid"], bool)[idx]
    assert np.array_equal(va, vb)
    pa, pb = np.asarray(a["position"])[va], np.asarray(b["position"])[idx][vb]
    return float(np.max(np.abs(pa - pb))), int(va.sum())


def _copy(src, dst):
    shutil.copytree(src, dst)
    return dst


def test_deck_replay_reproduces_the_closed_loop(deck_rec):
    d, rec = deck_rec
    assert rec.run.error is None
    res = replay(Recording.open(d), "deck")
    diff, n = _max_difference(rec.run.log, res.log)
    assert n == 301 and diff <= 1e-6
    m = res.metrics
    assert m["frames_used"] == rec.counts["frames"] == 101 and m["frames_dropped"] == 0
    assert m["imu_samples"] == rec.counts["imu"] == 301
    assert 0 < m["ate_rmse_m"] <= m["ate_max_m"] < 0.1  # deck-relative position against the relative truth
    # the navigator found the blobs itself in the replayed PNG frames: the same lights used as in the loop
    np.testing.assert_array_equal(res.log.get("camera")["lights_used"], rec.run.log.get("camera")["lights_used"])
    assert np.mean(res.log.get("camera")["lights_used"]) > 3


def test_deck_static_replay_reproduces_the_closed_loop(tmp_path):
    """deck-static starts from eq. 5.12-5.17 (a NavInit without a state), not from the motion-capture start."""
    rec = record(load_scenario("deck-static", DECK), tmp_path / "rec")
    res = replay(Recording.open(tmp_path / "rec"), "deck")
    diff, n = _max_difference(rec.run.log, res.log)
    assert n == 301 and diff <= 1e-6
    init = [json.loads(a)["kwargs"] for a, meth in zip(res.log.get("nav_request")["args"],
                                                        res.log.get("nav_request")["method"]) if meth == "initialize"]
    assert init and init[0]["state"] is None


def test_one_imu_sample_less_changes_the_deck_estimate(deck_rec, tmp_path):
    """Control: the same comparison fails when one IMU sample (t = 1 s) is missing from imu.csv."""
    d, rec = deck_rec
    f = _copy(d, tmp_path / "rec") / "imu.csv"
    lines = f.read_text().splitlines(keepends=True)
    del lines[101]
    f.write_text("".join(lines))
    res = replay(Recording.open(f.parent), "deck")
    assert res.metrics["imu_samples"] == 300
    diff, _ = _max_difference(rec.run.log, res.log)
    assert diff > 1e-6


def test_condor_replay_reproduces_the_closed_loop(condor_rec):
    d, rec = condor_rec
    assert rec.run.error is None
    res = replay(Recording.open(d), "condor")
    diff, n = _max_difference(rec.run.log, res.log)
    assert n >= 95 and diff <= 1e-6
    src = res.log.get("estimate")["source"]
    assert {"gps", "vision"} <= set(src)  # the vision position (eq. 3.23-3.24) was exercised
    m = res.metrics
    assert m["frames_used"] == rec.counts["frames"] > 60 and m["imu_samples"] == rec.counts["imu"]
    # the replay's ground station made every fix that link.csv says reached the aircraft
    assert m["link_fixes_delivered"] == rec.counts["link"] > 50 and m["link_fixes_missing"] == 0
    assert m["link_fixes"] >= m["link_fixes_delivered"]
    assert 0 < m["ate_rmse_m"] <= m["ate_max_m"]


def test_one_fix_lost_on_the_link_changes_the_condor_estimate(condor_rec, tmp_path):
    """Control: one fix of the vision phase taken out of link.csv (lost on the uplink) moves the estimate."""
    d, rec = condor_rec
    f = _copy(d, tmp_path / "rec") / "link.csv"
    lines = f.read_text().splitlines(keepends=True)
    t = np.array([float(x.split(",")[0]) for x in lines[1:]])
    del lines[1 + int(np.searchsorted(t, 6.0))]
    f.write_text("".join(lines))
    res = replay(Recording.open(f.parent), "condor")
    assert res.metrics["link_fixes_delivered"] == rec.counts["link"] - 1
    diff, _ = _max_difference(rec.run.log, res.log)
    assert diff > 1e-6


def test_cli_replay_of_the_deck_writes_a_deck_relative_run_directory(deck_rec, tmp_path):
    from visnav.cli import app

    d, _ = deck_rec
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["replay", str(d), "--navigator", "deck", "--out", str(out)])
    assert r.exit_code == 0, r.output
    m = json.loads((out / "metrics.json").read_text())
    for k in ("frames_used", "frames_dropped", "imu_samples", "ate_rmse_m", "ate_max_m", "rpe_rmse_m",
              "replay_wall_s", "replay_real_time_factor", "replay_cpu_s"):
        assert k in m
    head = (out / "estimate.tum").read_text().splitlines()[:3]
    assert any("deck-relative" in h for h in head if h.startswith("#"))
    assert (out / "report.html").is_file() and (out / "log.h5").is_file()


@pytest.mark.parametrize("file, edit, expect", [
    ("camera_attitude.csv", lambda s: s.replace("tilt_rad", "tilt"), "missing column(s) tilt_rad"),
    ("link.csv", lambda s: _swap_rows(s, 3, 4), "timestamps out of order"),
    ("pan.csv", lambda s: s.replace("pan_rad", "pan_deg"), "missing column(s) pan_rad"),
    ("click.csv", lambda s: s.replace("u_px", "u"), "missing column(s) u_px"),
])
def test_bad_condor_streams_give_one_line_naming_the_file(condor_rec, tmp_path, file, edit, expect):
    from visnav.cli import app

    d, _ = condor_rec
    f = _copy(d, tmp_path / "rec") / file
    f.write_text(edit(f.read_text()))
    with pytest.raises(RecordingError, match=file.replace(".", r"\.")):
        Recording.open(f.parent)
    r = CliRunner().invoke(app, ["replay", str(f.parent), "--navigator", "condor", "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    lines = [x for x in r.output.strip().splitlines() if x.strip()]
    text = " ".join(lines)
    assert file in text and expect in text and "Traceback" not in r.output


def _swap_rows(s: str, i: int, j: int) -> str:
    lines = s.splitlines(keepends=True)
    lines[i], lines[j] = lines[j], lines[i]
    return "".join(lines)


def test_a_deck_recording_without_frames_names_what_the_navigator_needs(deck_rec, tmp_path):
    d, _ = deck_rec
    rec = _copy(d, tmp_path / "rec")
    (rec / "frames.csv").unlink()
    with pytest.raises(RecordingError, match="the deck navigator needs frames.csv"):
        replay(Recording.open(rec), "deck")


def test_the_condor_ground_test_is_refused_with_a_message(tmp_path):
    with pytest.raises(RecordingError, match="'ground_test' experiment has no navigator"):
        record(load_scenario("condor-ground-test"), tmp_path / "g")
    assert not (tmp_path / "g").exists()


@pytest.mark.parametrize("text, expect", [
    ("t_s,n_m,e_m,d_m,heading_rad,height_m\n0,1,2,-70,0.1,70\n", "missing column(s) ground_speed_mps"),
    ("t_s,n_m,e_m,d_m,heading_rad,height_m,ground_speed_mps\n0.2,1,2,-70,0.1,70,13\n0.0,1,2,-70,0.1,70,13\n",
     "line 3: timestamps out of order"),
    ("t_s,airspeed_mps\n0,13\n0.1,fast\n", "line 3: column airspeed_mps holds 'fast'"),
])
def test_bad_telemetry_or_airspeed_csv_is_one_line_naming_the_file(tmp_path, text, expect):
    name = "airspeed.csv" if "airspeed_mps" in text.splitlines()[0] else "telemetry.csv"
    (tmp_path / name).write_text(text)
    with pytest.raises(RecordingError) as err:
        Recording.open(tmp_path)
    msg = str(err.value)
    assert msg.startswith(str(tmp_path / name)) and expect in msg and "\n" not in msg
