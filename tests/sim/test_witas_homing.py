"""Closed-loop WITAS homing (seed 002 §5.9.1): a short loop by default, the 1 km loop and the real maps
marked slow or skipped without the data."""

from pathlib import Path

import numpy as np
import pytest

from tests.shared_data import missing_reason, shared_data_dir
from visnav.scenarios.schema import load_scenario
from visnav.app.missions import make_simulation


def _data() -> Path | None:
    d = shared_data_dir()
    return d if (d / "satellite_column.png").is_file() else None


def _fly(*sets):
    sim = make_simulation(load_scenario("witas-homing", list(sets)))
    return sim, sim.run()


def test_short_loop_returns_home_on_vision():
    sim, res = _fly("mission.path.size_north_m=140", "mission.path.size_east_m=90", "run.duration_s=120")
    m = res.metrics
    assert res.error is None
    assert {"pmf_error_max_m", "pmf_error_rms_m", "odometry_drift_pct", "ins_only_error_final_m",
            "velocity_error_rms_mps", "heading_error_final_deg", "path_length_m", "returned_home"} <= set(m)
    assert m["returned_home"] and m["home_error_m"] < 3.0
    assert 350 < m["path_length_m"] < 500
    assert m["pmf_error_max_m"] <= 5.0 and m["pmf_error_rms_m"] <= 2.5
    # the odometry-only track dead-reckons across the pond (60 m of a 400 m loop here): looser than 1 km
    assert m["odometry_drift_pct"] <= 5.0
    assert m["ins_only_error_final_m"] > 5 * m["pmf_error_max_m"]  # the free INS drifts far more
    assert m["registrations"] >= 30
    # the navigator flew on vision after the GPS loss, and the pond interrupted odometry and registration
    log = res.log
    st = log.get("estimate")
    assert np.all(np.asarray(st["source"])[st["t"] > 9.0] == "vision")
    notes = " ".join(sim.nav.h.notes)
    assert "textureless frame" in notes and "odometry skipped" in notes
    pmf = log.get("pmf")
    sig = np.sqrt(np.linalg.eigvalsh(pmf["cov"])[:, 1])
    assert sig[pmf["t"] > 20].max() > 1.5 and sig[-1] < 1.2  # grows over the pond, recovers over land


@pytest.mark.slow
def test_one_km_loop():
    _, res = _fly()
    m = res.metrics
    assert m["returned_home"] and 900 < m["path_length_m"] < 1100
    assert m["pmf_error_max_m"] <= 5.0 and m["pmf_error_rms_m"] <= 2.5 and m["odometry_drift_pct"] <= 2.5


@pytest.mark.parametrize("name", ["column", "strip"])
def test_real_map(name):
    d = _data()
    if d is None:
        pytest.skip(missing_reason(shared_data_dir() / "satellite_column.png"))
    sim, res = _fly(f"world.witas_map.file={d / f'satellite_{name}.png'}", "mission.path.size_north_m=140",
                    "mission.path.size_east_m=140", "run.duration_s=120")
    m = res.metrics
    assert res.error is None and m["returned_home"]
    assert m["pmf_error_max_m"] <= 8.0
    if name == "strip":  # over the lake the PMF uncertainty grows, over the forest it recovers
        pmf = res.log.get("pmf")
        sig = np.sqrt(np.linalg.eigvalsh(pmf["cov"])[:, 1])
        late = pmf["t"] > pmf["t"][0] + 3.0
        assert sig[late].max() > 2.0 and sig[-1] < 1.2
    ext = sim.world.ground.extent_ned()
    tp = res.log.get("truth")["position"]
    assert tp[:, 0].min() > ext[0] and tp[:, 0].max() < ext[1] and tp[:, 1].min() > ext[2] and tp[:, 1].max() < ext[3]


def _attitude_errors(res):
    from visnav.analysis.metrics import interp_rows

    log = res.log
    est, tr = log.get("estimate"), log.get("truth")
    te = interp_rows(est["t"], tr["t"], np.unwrap(tr["euler"], axis=0))
    err = np.degrees((est["euler"] - te + np.pi) % (2 * np.pi) - np.pi)
    return est["t"], np.abs(err)


@pytest.mark.parametrize("compass", [True, pytest.param(False, marks=pytest.mark.slow)])
def test_five_degree_initial_attitude_error_converges(compass):
    """§5.9.1 / Fig. 5.22: filter engaged 5 deg off in roll, pitch and heading."""
    _, res = _fly("mission.path.size_north_m=140", "mission.path.size_east_m=90", "run.duration_s=120",
                  "mission.filter.init_attitude_error_deg=[5.0, 5.0, 5.0]", f"mission.compass.enabled={str(compass).lower()}")
    t, err = _attitude_errors(res)
    t0 = res.log.get("vision_engaged")["t"][0]
    assert err[np.searchsorted(t, t0 + 0.5)].max() > 4.0  # it really started 5 deg off
    late = t > t[-1] - 10.0
    assert err[late, 0].max() < 1.0 and err[late, 1].max() < 1.0  # roll and pitch converge
    if compass:
        assert err[late, 2].max() < 2.0  # heading too, with the compass
    assert res.metrics["returned_home"]


def test_klt_worked_out_on_the_render_thread_flies_the_same_flight():
    """The navigator's ``frame_prework`` (KLT on the render thread right after each frame, issue #19) is taken by
    the odometry on nearly every frame, and the flight is the one without it, bit for bit."""
    import threading

    from visnav.vision import klt

    sets = ["run.duration_s=16", "mission.gps_loss_s=3", "mission.settle_s=1"]
    where = {"main": 0, "worker": 0}
    flow, detect = klt.KltTracker._flow, klt.KltTracker._detect
    detected = {"main": 0, "worker": 0}

    def counted(self, *a):
        where["main" if threading.current_thread() is threading.main_thread() else "worker"] += 1
        return flow(self, *a)

    def counted_detect(self, *a):
        detected["main" if threading.current_thread() is threading.main_thread() else "worker"] += 1
        return detect(self, *a)

    klt.KltTracker._flow, klt.KltTracker._detect = counted, counted_detect
    try:
        a = make_simulation(load_scenario("witas-homing", sets)).run()
        with_prework, detected_with = dict(where), dict(detected)
        sim = make_simulation(load_scenario("witas-homing", sets))
        sim.nav.frame_prework = None  # (the loop asks getattr: no work ahead)
        b = sim.run()
    finally:
        klt.KltTracker._flow, klt.KltTracker._detect = flow, detect
    assert a.error is None and b.error is None
    assert with_prework["worker"] >= 40 and with_prework["main"] <= 1
    # the top-up detections too ran on the render thread, after their frames were delivered
    assert detected_with["worker"] >= 40 and detected_with["main"] <= 2
    assert where["main"] - with_prework["main"] >= 40  # without it every frame was tracked on delivery
    for s in ("estimate", "odometry", "truth"):
        ea, eb = a.log.get(s), b.log.get(s)
        for k in ea:
            assert np.array_equal(np.asarray(ea[k]), np.asarray(eb[k]), equal_nan=ea[k].dtype.kind == "f"), f"{s}.{k}"
