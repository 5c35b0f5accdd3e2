"""``--map`` smaller than the WITAS loop: the loop is shrunk to fit and the user is told, with the
new length (issue 12, point 10)."""

import math

import cv2
import h5py
import numpy as np
from typer.testing import CliRunner

from visnav.cli import app


def _geo_png(path, size_px=600, res_m=0.5, lat=58.4, lon=15.6):
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 255, (size_px, size_px)).astype(np.uint8), (0, 0), 2)
    cv2.imwrite(str(path), img)
    dlat = res_m / 111_320.0
    dlon = res_m / (111_320.0 * math.cos(math.radians(lat)))
    path.with_suffix(".pgw").write_text(f"{dlon}\n0\n0\n{-dlat}\n{lon}\n{lat}\n")


def test_a_map_smaller_than_the_loop_shrinks_it_and_says_so(tmp_path):
    _geo_png(tmp_path / "small.png")
    out = tmp_path / "r"
    r = CliRunner().invoke(app, ["run", "witas-homing", "--map", str(tmp_path / "small.png"), "--set",
                                 "run.duration_s=0.2", "--no-report", "--out", str(out)])
    assert r.exit_code == 0, r.output
    notes = [ln for ln in r.stderr.splitlines() if "shrunk" in ln]
    assert len(notes) == 1, r.stderr
    with h5py.File(out / "log.h5") as f:
        length = float(f["witas_setup/loop_length"][0])
        assert "shrunk" in f["note/message"][0].decode()
    assert f"320 m x 200 m -> " in notes[0] and notes[0].endswith(f"-> {length:.0f} m")
    full = float(notes[0].split("loop length ")[1].split(" m")[0])
    assert length < full
