"""Issue 13: every R-MAX mission's (and the geo-location's) metrics come from the flight log and the resolved scenario only. A short
run of each, its log written to log.h5 and read back, gives the same metrics as the run itself; a run
directory is scored again by `visnav metrics RUN_DIR`."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from visnav.analysis.run_metrics import METRICS, RunDirError, compute_metrics, from_run_dir, metrics_function
from visnav.cli import app
from visnav.scenarios.schema import load_scenario
from visnav.flightlog import FlightLog
from visnav.app.missions import REGISTRY, make_simulation

#: short runs that reach each mission's metrics (the pad landing from 5 m lands; pfcm-segment completes)
SHORT = {
    "palace-landing": ["run.duration_s=25"],
    "palace-hover-drift": ["run.duration_s=25"],
    "pfcm-segment": [],
    "witas-homing": ["run.duration_s=11", "mission.gps_loss_s=3", "mission.settle_s=1"],
    "mav-geolocation": ["world.geo_map.rural_size_m=260", "mission.max_samples=10", "run.duration_s=60"],
    "pad-landing": ["mission.start_height_m=5.0", "mission.start_ne_m=[1.0, -0.8]", "mission.settle_s=1.0",
                    "mission.slow_height_m=3.0", "world.field_size_m=30.0", "run.duration_s=30.0"],
}


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


def _differences(m1: dict, m2: dict) -> dict:
    return {k: (m1.get(k), m2.get(k)) for k in sorted(set(m1) | set(m2)) if not _same(m1.get(k), m2.get(k))}


def test_every_rmax_mission_has_metrics_from_the_log():
    assert set(REGISTRY) <= set(METRICS)
    for kind in REGISTRY:
        assert callable(metrics_function(kind))
    with pytest.raises(ValueError, match="no metrics from the log for mission.type 'nope'"):
        metrics_function("nope")


@pytest.mark.parametrize("name", sorted(SHORT))
def test_metrics_from_log_h5_are_the_run_metrics(name, tmp_path):
    sc = load_scenario(name, SHORT[name], seed=3 if name == "mav-geolocation" else 2)
    res = make_simulation(sc).run()
    assert res.error is None, res.error
    path = tmp_path / "log.h5"
    res.log.to_hdf5(path)
    back = compute_metrics(FlightLog.from_hdf5(path), sc, wall_time_s=res.metrics["wall_time_s"], error=res.error)
    live = dict(res.metrics)  # the ATE and the outcome too (issue #32: `visnav metrics` left ate_rmse_m out)
    assert _differences(live, back) == {}
    # the runs reach the metrics that need the new log fields
    if name == "palace-landing":
        assert live["time_under_vision_s"] >= 0.0 and "mpe_error_rms_m" in live
    if name == "pfcm-segment":
        assert live["path_completed"] is True and live["final_mode"] == "done"
        assert live["input_saturation_s"] >= 0.0 and set(live) >= {f"{c}_saturation_s" for c in
                                                                   ("ail", "ele", "rud", "thr")}
    if name == "pad-landing":
        assert live["landed"] is True
    if name == "palace-hover-drift":
        assert np.isfinite(live["drift_px"])
    if name == "mav-geolocation":  # the navigator's final estimate and counters come from geoloc_result
        assert live["samples"] == 10 and np.isfinite(live["target_error_m"]) and live["frames_tracked"] > 0


def test_visnav_metrics_recomputes_a_run_directory(tmp_path):
    run = tmp_path / "run"
    r = CliRunner().invoke(app, ["run", "pfcm-segment", "--set", "run.duration_s=20", "--out", str(run),
                                 "--no-report"])
    assert r.exit_code == 0, r.output
    written = json.loads((run / "metrics.json").read_text())
    m = from_run_dir(run)
    for k, v in m.items():
        if k in ("real_time_factor",):
            continue
        w = written[k]
        if isinstance(v, (str, bool)):
            assert w == v, k
        else:
            assert (w is None and not math.isfinite(v)) or w == pytest.approx(v, rel=1e-12), k
    r = CliRunner().invoke(app, ["metrics", str(run), "--json", "--out", str(tmp_path / "m.json")])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["cross_track_rms_m"] == pytest.approx(written["cross_track_rms_m"], rel=1e-12)
    assert json.loads((tmp_path / "m.json").read_text())["path_length_m"] == pytest.approx(written["path_length_m"])
    # the log itself names its run directory
    assert from_run_dir(run / "log.h5")["cross_track_rms_m"] == pytest.approx(written["cross_track_rms_m"], rel=1e-12)


def test_visnav_metrics_on_a_missing_or_broken_directory_is_one_line(tmp_path):
    r = CliRunner().invoke(app, ["metrics", str(tmp_path / "nothing")])
    assert r.exit_code == 2 and "not a run directory" in r.output and "Traceback" not in r.output
    (tmp_path / "x.json").write_text("{}")
    r = CliRunner().invoke(app, ["metrics", str(tmp_path / "x.json")])
    assert r.exit_code == 2 and "a file, not a folder" in r.output and "Traceback" not in r.output
    (tmp_path / "d").mkdir()
    r = CliRunner().invoke(app, ["metrics", str(tmp_path / "d")])
    assert r.exit_code == 2 and "no log.h5" in r.output
    (tmp_path / "d" / "log.h5").write_text("not hdf5")
    (tmp_path / "d" / "scenario.toml").write_text('[mission]\ntype = "pfcm"\n')
    r = CliRunner().invoke(app, ["metrics", str(tmp_path / "d")])
    assert r.exit_code == 2 and "not a readable flight log" in r.output and len(r.output.strip().splitlines()) == 1
    (tmp_path / "d" / "scenario.toml").write_text('[mission]\ntype = "nope"\n')
    with pytest.raises(RunDirError, match="scenario.toml"):
        from_run_dir(tmp_path / "d")


def test_a_log_without_the_new_streams_gives_nan_not_zero():
    """A log written before palace_progress / status counters / geoloc_result existed: unknown, not 0."""
    from visnav.analysis.geolocation_metrics import geolocation_metrics
    from visnav.analysis.metrics import palace_metrics

    log = FlightLog()
    for k in range(5):
        log.record("truth", 0.1 * k, position=np.zeros(3), velocity=np.zeros(3), euler=np.zeros(3),
                   body_rates=np.zeros(3))
        log.record("status", 0.1 * k, mode="settle", source="gps", coherence=1.0, mpe_rate_hz=0.0, laser_ok=True,
                   tracking=False)
    m = palace_metrics(log, load_scenario("palace-landing"), wall_time_s=1.0)
    for k in ("time_under_vision_s", "reinitializations", "mpe_fallbacks", "rejected_samples", "rejected_ranges"):
        assert math.isnan(m[k]), k
    assert m["final_mode"] == "settle" and m["sim_time_s"] == pytest.approx(0.4)
    g = geolocation_metrics(log, load_scenario("mav-geolocation"), wall_time_s=1.0)
    assert math.isnan(g["samples_rejected"]) and math.isnan(g["frames_tracked"]) and g["samples"] == 0
