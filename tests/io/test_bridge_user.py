"""What a new user of the bridge hits (issue 32, item 5): `--camera 0` without a camera says one line (no
OpenCV WARN on stderr, no empty bridge.tlog left), the SIL run's notes print as lines (not a Python list),
and the README's desk recipe runs the stand-in with a folder of frames."""

import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

from tests.io.mavlink_helpers import free_udp_port
from visnav.cli import app

README = Path(__file__).resolve().parents[2] / "README.md"


@pytest.mark.skipif(Path("/dev/video0").exists(), reason="a camera is connected at index 0")
def test_bridge_without_a_camera_one_line_no_opencv_warning_no_tlog(tmp_path, capfd):
    out = tmp_path / "log"
    r = CliRunner().invoke(app, ["bridge", "--mavlink", f"udpin:127.0.0.1:{free_udp_port()}", "--camera", "0",
                                 "--navigator", "palace", "--out", str(out)])
    err = capfd.readouterr().err  # what OpenCV's C++ wrote to the process's stderr
    assert r.exit_code == 2
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "camera 0: no video device answers at index 0" in lines[0], r.output
    assert "WARN" not in err and "VIDEOIO" not in err, err
    assert not (out / "bridge.tlog").exists() and not out.exists()


def test_sil_notes_print_as_lines_not_a_list():
    from visnav.analysis.published import summary_rows
    from visnav.analysis.report import metrics_table_html, run_notes
    from visnav.scenarios.schema import load_scenario

    sc = load_scenario("palace-landing")
    notes = ["the bridge did not end its session within 60 s: killed", "camera stalled: no frame for 1.0 s"]
    metrics = {"estimate_error_max_m": 1.5, "sil_notes": notes}
    rows, omitted, _ = summary_rows(sc, metrics)
    assert [r.metric for r in rows] == ["estimate_error_max_m"]
    lines = run_notes(SimpleNamespace(scenario=sc, log=None, metrics=metrics))
    assert [ln for ln in lines if ln.startswith("SIL: ")] == [f"SIL: {n}" for n in notes]
    assert "['" not in metrics_table_html(sc, metrics)


def test_readme_desk_recipe_uses_a_frame_folder():
    text = README.read_text()
    i = text.index("visnav sil-autopilot")
    following = text[i:].splitlines()[1]
    assert following.startswith("visnav bridge ") and "udpin:127.0.0.1:14540" in following
    camera = re.search(r"--camera (\S+)", following).group(1)
    assert not camera.isdigit() and "folder of images" in following


def test_input_timeout_option_bad_values_one_line(tmp_path):
    for bad, why in (("lidar=2", "unknown bridge input stream 'lidar'"), ("imu=-1", "positive number or none"),
                     ("imu", "positive number or none")):
        r = CliRunner().invoke(app, ["bridge", "--mavlink", "udpin:127.0.0.1:1", "--camera", "0", "--input-timeout",
                                     bad, "--out", str(tmp_path / "o")])
        assert r.exit_code == 2 and why in r.output and len([ln for ln in r.output.splitlines() if ln.strip()]) == 1


def test_input_timeout_option_sets_the_budget():
    from visnav.cli import _input_timeouts

    cfg = _input_timeouts(["camera=4", "gps=none", "imu=0.5"])
    assert cfg.budgets["camera"].timeout_s == 4.0 and cfg.budgets["gps"].timeout_s is None
    assert cfg.budgets["imu"].timeout_s == 0.5 and cfg.budgets["imu"].accel_mps2 == 2.0
