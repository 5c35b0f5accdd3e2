"""Every real PX4 log of ../shared/data/px4 (four hardware / firmware generations) opens in the recording
reader with the streams it has, gives its one line, runs `visnav ahrs` within a bound of PX4's own attitude,
and a copy cut at 60 % or with garbage inside is read to the damage with one line and no traceback."""

from __future__ import annotations

import pytest

from tests.shared_data import missing_reason, shared_data_dir
from visnav.io.logs import open_recording

PX4 = shared_data_dir() / "px4"
# log -> the streams it holds (besides imu, attitude, magnetometer, mag_field)
LOGS = {
    "sample_px4_events.ulg": {"gps", "baro"},  # PX4 1.14-era: vehicle_gps_position (new fields), vehicle_air_data
    "sample_log_small.ulg": {"gps", "baro"},  # CubeOrange VTOL: older GPS fields, low-rate sensor topics
    "sample_appended_multiple.ulg": {"baro"},  # FMUv4pro, appended data: mag + baro inside sensor_combined
    "roboto_fmuv5_bench_9s.ulg": {"gps", "baro"},  # FMUv5 bench
}


def _log(name):
    p = PX4 / name
    if not p.is_file():
        pytest.skip(missing_reason(p))
    return p


@pytest.mark.parametrize("name", sorted(LOGS))
def test_real_log_streams_and_summary(name):
    rec = open_recording(_log(name))
    assert set(rec.streams) == {"imu", "attitude", "magnetometer", "mag_field"} | LOGS[name]
    assert "; to the end (" in rec.summary
    if "gps" in rec.streams:  # the shared PX4 logs have GPS: a replay no longer asks for gps.csv
        assert len(rec.streams["gps"]["t_s"]) >= 19


@pytest.mark.parametrize("name", sorted(LOGS))
def test_real_log_ahrs_against_px4_attitude(name):
    from visnav.analysis.ahrs_check import ahrs_check

    m = ahrs_check(_log(name))
    # measured 0.03-0.32 deg: a bound an order of magnitude under a wrong axis or a wrong time base
    assert m["roll_rms_diff_deg"] < 0.6 and m["pitch_rms_diff_deg"] < 0.6
    roll, pitch = _doc_rows()[name][-2:]  # and the figures docs/recordings.md publishes
    assert (f"{m['roll_rms_diff_deg']:.3f}", f"{m['pitch_rms_diff_deg']:.3f}") == (roll, pitch)


@pytest.mark.parametrize("name", sorted(LOGS))
def test_damaged_copies_of_real_logs(tmp_path, name):
    from typer.testing import CliRunner

    from visnav.cli import app

    b = _log(name).read_bytes()
    cut, bad = tmp_path / f"cut_{name}", tmp_path / f"garbage_{name}"
    cut.write_bytes(b[: int(0.6 * len(b))])
    at = len(b) // 2
    bad.write_bytes(b[:at] + bytes(range(256)) * 16 + b[at:])
    whole = open_recording(_log(name)).streams["imu"]["t_s"]
    rec = open_recording(cut)
    assert "cut at byte" in rec.summary and len(rec.streams["imu"]["t_s"]) < 0.8 * len(whole)
    rec = open_recording(bad)
    n_at = int(rec.summary.split("damaged at byte ")[1].split()[0])
    # to the damage at least (what pyulog recovers past garbage depends on the log generation: 75-98 %)
    assert at <= n_at <= at + 4096 + 2000 and len(rec.streams["imu"]["t_s"]) > 0.45 * len(whole)
    r = CliRunner().invoke(app, ["replay", str(cut), "--navigator", "witas", "--out", str(tmp_path / "r")])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert f"cut_{name}: read" in r.stderr and "frames.csv; not in the recording" in r.stderr


def _doc_rows() -> dict:
    """docs/recordings.md's table of the shared logs: name -> (seconds, GPS, baro, mag, roll, pitch) as text."""
    import re
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "recordings.md").read_text()
    assert "has no GPS" not in doc
    return {m.group(1): m.groups()[1:] for m in re.finditer(
        r"^\| (\S+\.ulg) \|[^|]*\| ([\d.]+) s, to the end \| (\d+|-)[^/]*/ (\d+)[^/]*/ (\d+) \| ([\d.]+) / ([\d.]+) \|$",
        doc, re.M)}


def test_docs_recordings_claims_about_the_shared_logs():
    """docs/recordings.md's table of the shared logs (seconds read, GPS / baro / mag counts) and its claim
    of their GPS and barometer topics hold for the files (issue 32 item 12: the docs said they had none)."""
    from pyulog import ULog

    rows = _doc_rows()
    assert set(rows) == set(LOGS)
    for name, (secs, gps, baro, mag, *_rp) in rows.items():
        rec = open_recording(_log(name))
        s = rec.streams
        assert f"{s['imu']['t_s'][-1] - s['imu']['t_s'][0]:.1f}" == secs
        assert (str(len(s["gps"]["t_s"])) if "gps" in s else "-") == gps
        assert (str(len(s["baro"]["t_s"])), str(len(s["mag_field"]["t_s"]))) == (baro, mag)
    topics = {d.name for d in ULog(str(_log("sample_px4_events.ulg"))).data_list}
    assert {"vehicle_gps_position", "sensor_gps", "vehicle_air_data", "sensor_baro"} <= topics


def test_a_replayed_real_log_scores_as_evo_and_visnav_eval_score_its_folder(tmp_path):
    """The replay's ATE in metrics.json is what `visnav eval RUN` (evo's defaults) gives for the TUM files it wrote,
    also where the reference (the log's GPS, ~13 Hz) and the estimates (10 Hz) are not on one clock grid: it was
    computed with a 20 ms association, 0.0156 m against eval's 0.0144 m on this log."""
    from visnav.analysis.trajectory_eval import evaluate, read_trajectory
    from visnav.app.replay import replay, write_replay

    res = replay(open_recording(_log("sample_px4_events.ulg")), "palace")
    write_replay(res, tmp_path, report=False)
    ref, est = read_trajectory(tmp_path / "truth.tum"), read_trajectory(tmp_path / "estimate.tum")
    folder = evaluate(ref, est).summary()["ate_rmse_m"]
    assert res.metrics["ate_rmse_m"] == pytest.approx(folder, rel=1e-3)  # (TUM files hold 9 digits)
    assert 0.001 < folder < 0.1  # GPS-fused estimate against the GPS: centimetres
