"""Geo-location metrics come from the flight log + the resolved scenario: a log.h5 read back scores the same."""

import math

import pytest

from visnav.analysis.geolocation_metrics import geolocation_metrics
from visnav.scenarios.schema import load_scenario
from visnav.flightlog import FlightLog
from visnav.app.missions import make_simulation


def test_metrics_from_log_h5(tmp_path):
    sc = load_scenario("mav-geolocation", ["run.duration_s=25", "mission.max_samples=5"])
    r = make_simulation(sc).run()
    assert r.error is None, r.error
    p = tmp_path / "log.h5"
    r.log.to_hdf5(p)
    back = geolocation_metrics(FlightLog.from_hdf5(p), sc, wall_time_s=1.0)
    assert set(back) <= set(r.metrics)
    for k, v in back.items():
        if k in ("wall_time_s", "real_time_factor"):
            continue
        a = r.metrics[k]
        if isinstance(a, float) and math.isnan(a):
            assert math.isnan(v), k
        else:
            assert v == pytest.approx(a, rel=1e-12, abs=1e-12), k
    assert back["frames"] > 0 and back["samples"] >= 1 and math.isfinite(back["target_error_m"])
