"""CONDOR metrics come from the flight log + the resolved scenario: a log.h5 read back scores the same."""

import math

import pytest

from visnav.analysis.condor_metrics import condor_metrics
from visnav.scenarios.schema import load_scenario
from visnav.flightlog import FlightLog
from visnav.app.missions import make_simulation


def _same(a: dict, b: dict) -> None:
    assert set(a) - set(b) <= {"ate_rmse_m"} and set(b) <= set(a)  # RunResult adds the ATE from truth.tum
    for k, v in b.items():
        v, b_k = a[k], v
        if k in ("wall_time_s", "real_time_factor"):
            continue
        if isinstance(v, str):
            assert b_k == v, k
        elif isinstance(v, float) and math.isnan(v):
            assert math.isnan(b_k), k
        else:
            assert b_k == pytest.approx(v, rel=1e-12, abs=1e-12), k


@pytest.mark.parametrize("overrides", [
    ["run.duration_s=75", "mission.orbit.switch_time_s=10", "mission.orbit.transition_s=20"],
    None,
], ids=["orbit", "ground_test"])
def test_metrics_from_log_h5(tmp_path, overrides):
    sc = load_scenario("condor-orbit", overrides) if overrides else load_scenario("condor-ground-test")
    r = make_simulation(sc).run()
    assert r.error is None, r.error
    p = tmp_path / "log.h5"
    r.log.to_hdf5(p)
    from visnav.analysis.run_metrics import compute_metrics  # the condor metrics + the integrity ones (issue #18)

    back = compute_metrics(FlightLog.from_hdf5(p), sc, wall_time_s=1.0)
    _same(r.metrics, back)
    if overrides:
        assert back["switched_at_s"] == pytest.approx(10.0, abs=0.05)
        assert 0.0 < back["link_drop_fraction"] < 0.3 and math.isfinite(back["orbit_radius_error_rms_m"])
    else:
        assert back["ours_mean_abs_error_pct"] <= 1.0
