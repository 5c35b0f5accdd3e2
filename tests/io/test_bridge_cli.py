"""`visnav bridge` / `visnav sil-autopilot` on the command line: bad input -> one line and exit 2; a short
live run against the SIL stand-in on 127.0.0.1 writes metrics.json with the issue's keys and a tlog."""

import json
import re

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from tests.io.mavlink_helpers import free_udp_port
from visnav.cli import app
from visnav.io.mavlink_sil import SilAutopilot

pytestmark = pytest.mark.realtime  # paced to the wall clock: run apart from the CPU-heavy suite (Makefile)


def _lines(out: str) -> list[str]:
    return [ln for ln in out.splitlines() if ln.strip()]


def test_missing_serial_device(tmp_path):
    r = CliRunner().invoke(app, ["bridge", "--mavlink", "/dev/ttyVISNAV_NONE:921600", "--camera", "0",
                                 "--navigator", "palace", "--out", str(tmp_path)])
    assert r.exit_code == 2
    assert _lines(r.output) == [_lines(r.output)[0]] and "serial device /dev/ttyVISNAV_NONE does not exist" in r.output


def test_bad_output_and_origin(tmp_path):
    r = CliRunner().invoke(app, ["bridge", "--mavlink", "udpin:127.0.0.1:1", "--camera", "0", "--output", "mocap",
                                 "--out", str(tmp_path)])
    assert r.exit_code == 2 and "--output must be one of odometry, vision, gps-input" in r.output
    r = CliRunner().invoke(app, ["bridge", "--mavlink", f"udpin:127.0.0.1:{free_udp_port()}", "--camera", "0",
                                 "--origin", "58.4,north", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "--origin must be LAT_DEG,LON_DEG,ALT_M" in r.output and len(_lines(r.output)) == 1
    r = CliRunner().invoke(app, ["bridge", "--mavlink", "udpin:127.0.0.1:1", "--camera", "0", "--gps-sigma", "0",
                                 "--out", str(tmp_path)])
    assert r.exit_code == 2 and "--gps-sigma must be a positive number of metres, got 0" in r.output
    assert len(_lines(r.output)) == 1


def test_missing_camera(tmp_path):
    r = CliRunner().invoke(app, ["bridge", "--mavlink", f"udpin:127.0.0.1:{free_udp_port()}", "--camera",
                                 str(tmp_path / "nope.mp4"), "--navigator", "palace", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "no such file, folder or device index" in r.output


def test_sil_autopilot_refuses_non_loopback():
    r = CliRunner().invoke(app, ["sil-autopilot", "--mavlink", "udpout:10.0.0.5:14540", "--duration", "1"])
    assert r.exit_code == 2 and "127.0.0.1 / localhost only" in r.output


def test_bridge_cli_live_run_writes_metrics(tmp_path):
    frames = tmp_path / "frames"
    frames.mkdir()
    rng = np.random.default_rng(0)
    for i in range(60):
        cv2.imwrite(str(frames / f"{i:04d}.png"), (rng.random((48, 64)) * 255).astype(np.uint8))
    port = free_udp_port()
    sil = SilAutopilot(f"udpout:127.0.0.1:{port}")
    sil.start(12.0)
    try:
        r = CliRunner().invoke(app, ["bridge", "--mavlink", f"udpin:127.0.0.1:{port}", "--camera", str(frames),
                                     "--navigator", "palace", "--duration", "4", "--out", str(tmp_path / "log"),
                                     "--log-frames"])
    finally:
        sil.stop()
    assert r.exit_code == 0, r.output
    lines = _lines(r.output)  # off a terminal: the live status line and the summary are separate lines
    assert lines[-1].startswith("sent ") and not any(re.search(r"frames \d+sent", ln) for ln in lines), r.output
    log = (tmp_path / "log" / "bridge.log").read_text()  # what the console said, also in the log folder
    assert "seen on udpin" in log and "sent " in log.splitlines()[-1]
    m = json.loads((tmp_path / "log" / "metrics.json").read_text())
    for key in ("link_ok", "rate_in_hz", "rate_out_hz", "latency_capture_to_send_ms", "timesync_offset_ms",
                "timesync_rtt_ms", "reset_counter"):
        assert key in m
    assert m["rate_in_hz"]["HIGHRES_IMU"] > 10 and m["estimates_out"] > 5
    assert set(m["latency_capture_to_send_ms"]) == {"median", "p95", "n"}
    assert (tmp_path / "log" / "bridge.tlog").stat().st_size > 1000
    assert sil.stats.received.get("ODOMETRY", 0) > 5
    rows = (tmp_path / "log" / "frames" / "frames.csv").read_text().splitlines()
    assert rows[0] == "index,t,capture_t,file"
    assert len(rows) - 1 >= m["frames"] > 5  # every frame the navigator got (and any read as the loop stopped)
    first = cv2.imread(str(tmp_path / "log" / "frames" / rows[1].split(",")[3]), 0)
    np.testing.assert_array_equal(first, cv2.imread(str(frames / "0000.png"), 0))  # lossless


def test_run_sil_cli_writes_bridge_keys(tmp_path):
    r = CliRunner().invoke(app, ["run", "palace-landing", "--sil", "--set", "run.duration_s=3", "--out",
                                 str(tmp_path / "run"), "--no-report"])
    assert r.exit_code == 0, r.output
    m = json.loads((tmp_path / "run" / "metrics.json").read_text())
    for key in ("link_ok", "rate_in_hz", "rate_out_hz", "latency_capture_to_send_ms", "timesync_offset_ms",
                "timesync_rtt_ms", "reset_counter", "sil_stamp_error_ms_max"):
        assert key in m
    assert m["sil_stamp_error_ms_max"] < 2.0
