"""``visnav record`` + ``visnav replay`` for the MAV geo-location navigator (seed 002 ch. 7).

A 20 s mav-geolocation flight (the operator's click, frames and 5 Hz telemetry) is recorded; the
replay's navigator must make the same samples and the same recursive-least-squares target estimate
after each, bit for bit (see tests/navigation/test_geolocation_from_a_list.py), and end on the closed
loop's final estimate.
Control: the same recording without every other frame gives other samples and another estimate.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from visnav.io.recording import Recording
from visnav.app.replay import replay
from visnav.scenarios.schema import load_scenario
from visnav.app.record import record

GEO = ["run.duration_s=20"]


@pytest.fixture(scope="module")
def geo_rec(tmp_path_factory):
    d = tmp_path_factory.mktemp("geo-rec")
    return d, record(load_scenario("mav-geolocation", GEO), d)


def test_geolocation_replay_reproduces_the_closed_loop(geo_rec):
    d, rec = geo_rec
    assert rec.run.error is None
    assert rec.counts["telemetry"] == 100 and rec.counts["click"] == 1 and rec.counts["commands"] == 0
    res = replay(Recording.open(d), "geolocation")
    a, b = rec.run.log.get("sample"), res.log.get("sample")
    assert len(a["t"]) >= 10 and np.array_equal(a["t"], b["t"])
    np.testing.assert_array_equal(a["reg_used"], b["reg_used"])
    ea, eb = np.asarray(a["est_reg"], float), np.asarray(b["est_reg"], float)
    ok = np.isfinite(ea[:, 0])
    assert ok.sum() >= 5 and np.array_equal(ok, np.isfinite(eb[:, 0]))
    np.testing.assert_array_equal(eb, ea)
    for k in ("reg", "quality", "peak"):
        np.testing.assert_array_equal(b[k], a[k], err_msg=k)
    final = np.asarray(rec.run.log.get("geoloc_result")["est_reg"], float).reshape(-1)
    e = res.log.get("estimate")
    assert e["valid"][-1]
    np.testing.assert_array_equal(np.asarray(e["position"])[-1, :2], final)
    m = res.metrics
    assert m["frames_used"] == rec.counts["frames"] == 100 and m["frames_dropped"] == 0
    assert 0 < m["ate_rmse_m"] < 10.0  # target estimate against the true target (truth.csv)


def test_every_other_frame_missing_changes_the_geolocation_estimate(geo_rec, tmp_path):
    """Control: every other frame taken out (the operator's clicked frame kept, so the tracker still starts)."""
    d, rec = geo_rec
    f = shutil.copytree(d, tmp_path / "rec") / "frames.csv"
    t_click = float((d / "click.csv").read_text().splitlines()[1].split(",")[0])
    head, *rows = f.read_text().splitlines(keepends=True)
    keep = [r for i, r in enumerate(rows) if i % 2 == 0 or float(r.split(",")[0]) == t_click]
    f.write_text("".join([head] + keep))
    res = replay(Recording.open(f.parent), "geolocation")
    assert res.metrics["frames_used"] < rec.counts["frames"]
    b = res.log.get("sample")
    assert b and len(b["t"]) >= 3  # the tracker started and samples were made
    e = res.log.get("estimate")
    final = np.asarray(rec.run.log.get("geoloc_result")["est_reg"], float).reshape(-1)
    assert not np.max(np.abs(np.asarray(e["position"])[-1, :2] - final)) <= 1e-6
