"""``visnav replay PHOTOS --navigator vo --gps-until T`` on the real Seneca survey (../shared/data/survey_seneca):
a short stretch downscaled in the default run, the whole 80-photo flight as a slow case."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tests.shared_data import missing_reason, shared_data_dir

SENECA = shared_data_dir() / "survey_seneca"


def _need_seneca():
    if not SENECA.is_dir():
        pytest.skip(missing_reason(SENECA))


@pytest.fixture(scope="module")
def stretch(tmp_path_factory):
    """The first 9 photos (one straight leg, ~42 s) at half size with their EXIF, and camera.yaml scaled to it."""
    _need_seneca()
    from PIL import Image

    d = tmp_path_factory.mktemp("seneca9")
    for f in sorted((SENECA / "images").glob("*.jpg"))[:9]:
        with Image.open(f) as im:
            im.resize((600, 450), Image.Resampling.LANCZOS).save(d / f.name, exif=im.getexif(), quality=92)
    (d / "camera.yaml").write_text("image_size: [600, 450]\nintrinsics: {fx: 416.3, fy: 416.3, cx: 299.5, cy: 224.5}\n")
    return d


def test_vo_replay_of_a_survey_stretch_through_the_cli(stretch, tmp_path):
    from visnav.cli import app

    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["replay", str(stretch), "--navigator", "vo", "--gps-until", "20", "--out", str(out)])
    assert r.exit_code == 0, r.output
    m = json.loads((out / "metrics.json").read_text())
    for k in ("pairs_registered_share", "final_error_m", "final_error_pct_of_distance", "ate_rmse_m"):
        assert k in m and np.isfinite(m[k])
    assert m["reference"] == "gps.csv" and m["gps_withheld"] == 5 and m["photos"] == 9
    assert m["pairs_registered_share"] == 1.0  # every photo of the leg registers to the one before
    assert m["distance_denied_m"] > 80
    assert m["final_error_pct_of_distance"] < 10.0  # the bound (5 photos, ~135 m of VO after the last fix)
    assert m["vo_scale_m"] == pytest.approx(60, abs=12)  # the height above ground: a survey flight's tens of metres
    assert (out / "estimate.tum").is_file() and (out / "truth.tum").is_file()


def test_replay_refuses_a_photo_folder_without_gps(tmp_path):
    _need_seneca()
    from PIL import Image

    from visnav.cli import app

    f = sorted((SENECA / "images").glob("*.jpg"))[1]
    with Image.open(f) as im:
        ex = im.getexif()
        del ex[0x8825]  # the GPS IFD
        im.resize((120, 90)).save(tmp_path / "a.jpg", exif=ex)
    (tmp_path / "camera.yaml").write_text("image_size: [120, 90]\nintrinsics: {fx: 83, fy: 83, cx: 59.5, cy: 44.5}\n")
    r = CliRunner().invoke(app, ["replay", str(tmp_path), "--navigator", "vo", "--out", str(tmp_path / "run")])
    assert r.exit_code == 2 and "gps.csv" in r.output and "Traceback" not in r.output


@pytest.mark.slow
def test_vo_replay_whole_seneca_survey():
    """All 80 photos, GPS withheld after 30 s (~3.3 km of VO): the figures of docs/real-data.md."""
    _need_seneca()
    from visnav.io.logs import open_recording
    from visnav.app.replay import ReplayOptions, replay

    res = replay(open_recording(SENECA), "vo", ReplayOptions(gps_until_s=30.0))
    m = res.metrics
    assert m["photos"] == 80 and m["gps_withheld"] == 74
    assert m["pairs_registered_share"] >= 0.95
    assert m["final_error_pct_of_distance"] <= 10.0
    assert m["ate_rmse_denied_m"] < 20.0


def test_witas_and_geolocation_registration_on_survey_pairs(stretch):
    """Consecutive photos of the stretch registered to each other: the earlier photo orthorectified (its GPS fix,
    the VO's attitude and height) is the map; the later one is registered by WITAS NCC and by the geo-location
    edge correlation, searched 15 m around its GPS fix moved by (6, -4) m; errors against its GPS fix."""
    from visnav.analysis.survey_pairs import measure_pairs, summary
    from visnav.io.logs import open_recording
    from visnav.navigation.vo import VONavigator

    rec = open_recording(stretch)
    nav = VONavigator(rec.camera.camera, mount=rec.camera.mount)
    images = []
    for i in range(rec.count("frames")):
        nav.update(rec.sample("gps", i))
        f = rec.sample("frames", i)
        images.append(f.image)
        nav.update(f)
    g = rec.streams["gps"]
    gps = np.column_stack([g["n_m"], g["e_m"]])
    pairs = [(i - 1, i) for i in range(1, len(images))]
    res = measure_pairs(images, rec.camera.camera, rec.camera.mount, [nav.photo_pose(i) for i in range(len(images))],
                        gps, pairs, vo_offsets={p: nav.chain_offset(*p) for p in pairs})
    s = summary(res)
    print(s)
    assert s["witas_registered"] == 8 and s["geo_registered"] == 8
    # GPS noise of two EXIF fixes (metres each) is in every figure; the search recovered most of the 7.2 m offset
    assert s["witas_median_error_m"] < 10.0 and s["geo_median_error_m"] < 10.0
    assert s["feature_median_error_m"] < 4.0  # the feature homography: the best of the three on these fields


def test_denied_metrics_closed_form():
    """An estimate 3 m east of a reference that flies 100 m north after the cut, the error growing 0 -> 6 m:
    final 6 m over 100 m = 6 %, RMS over the denied samples by hand."""
    from visnav.app.replay import denied_metrics
    from visnav.flightlog import FlightLog

    log = FlightLog()
    t = np.arange(0.0, 21.0)
    north = np.where(t <= 10, 0.0, 10.0 * (t - 10))  # hovering until the cut at 10 s, then 10 m/s north
    err = np.where(t <= 10, 0.0, 0.6 * (t - 10))
    for i, ti in enumerate(t):
        log.record("truth", ti, position=np.array([north[i], 0.0, -50]), velocity=np.zeros(3), euler=np.zeros(3))
        log.record("estimate", ti, position=np.array([north[i], err[i], -50]), velocity=np.zeros(3),
                   euler=np.zeros(3), source="vo", valid=True)
    m = denied_metrics(log, 10.0)
    assert m["final_error_m"] == pytest.approx(6.0)
    assert m["distance_denied_m"] == pytest.approx(100.0)
    assert m["final_error_pct_of_distance"] == pytest.approx(6.0)
    assert m["ate_rmse_denied_m"] == pytest.approx(np.sqrt(np.mean(err[11:] ** 2)))
