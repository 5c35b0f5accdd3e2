"""Fault injection on the deck and CONDOR simulations (issue #18): their sensors differ from the R-MAX's (the
deck's IMU sends an ``ImuSample`` alone, its LED camera renders an image; CONDOR's autopilot IMU, gimbal camera
and GPS), so every fault of their ``FAULT_SETS`` is checked on the real sensor objects of a built simulation:
inside its window it changes exactly what it says, outside nothing."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from visnav.app.fault_campaign import FAULT_SETS
from visnav.measurements import Frame, GpsSample, ImuSample
from visnav.scenarios.config_integrity import FaultConfig
from visnav.scenarios.schema import load_scenario
from visnav.sensors.faults import FaultySensor, GustyWind, apply_faults, target_of
from visnav.app.loop import Simulation
from visnav.sim.parts import CurrentTruth

START, DUR = 0.1, 0.1
TIMES = (0.0, 0.05, 0.1, 0.12, 0.16, 0.2, 0.25)  # the window is [0.1, 0.2)


@pytest.fixture(scope="module")
def sims():
    return {"deck": Simulation(load_scenario("deck-moving")), "condor": Simulation(load_scenario("condor-orbit"))}


def _pairs(sim, f):
    """(t, clean, faulted) samples of the fault's sensor: two copies of the simulation's own sensor in the
    same state, one wrapped."""
    name = target_of(f)
    clean, inner = copy.deepcopy(sim.sensors[name]), copy.deepcopy(sim.sensors[name])
    wrapped = apply_faults({name: inner}, [f], np.random.default_rng(0))[name]
    assert isinstance(wrapped, FaultySensor)
    # CONDOR's truth is the aircraft now (CurrentTruth): the sensors see the start state at every t here
    truth = (lambda t: sim.truth(sim.truth.now)) if isinstance(sim.truth, CurrentTruth) else sim.truth
    return [(t, clean.sample(t, truth, sim.world), wrapped.sample(t, truth, sim.world)) for t in TIMES]


def _cases():
    for mtype, faults in FAULT_SETS.items():
        if mtype in ("deck", "condor"):
            for d in faults:
                if d["kind"] != "wind_gust":
                    yield mtype, d


@pytest.mark.parametrize("mtype,d", list(_cases()), ids=lambda x: x if isinstance(x, str) else x.get("kind"))
def test_each_fault_changes_its_sensor_only_inside_the_window(sims, mtype, d):
    kw = {**d, "start_s": START, "duration_s": DUR}
    if d["kind"] == "imu_drop":
        kw["drop_probability"] = 1.0
    f = FaultConfig(**kw)
    sim = sims[mtype]
    before = None
    rows = _pairs(sim, f)
    for t, c, w in rows:
        if c is None:  # not a sample instant of this sensor
            assert w is None
            continue
        inside = f.active(t)
        if isinstance(c, Frame):
            if not inside:
                assert w.t == c.t and np.array_equal(w.image, c.image)
                before = c.image
                continue
            if f.kind == "clock_jump":
                assert w.t == pytest.approx(c.t + f.jump_s) and np.array_equal(w.image, c.image)
                continue
            assert w.t == c.t and w.index == c.index
            if f.kind == "camera_blackout":
                assert c.image.any() and not w.image.any()
            elif f.kind == "camera_frozen":
                assert before is not None and np.array_equal(w.image, before)
            elif f.kind == "camera_brightness":
                ref = np.clip(np.rint(c.image.astype(np.float32) * f.gain + f.offset_dn), 0, 255)
                np.testing.assert_array_equal(w.image, ref)
            elif f.kind == "camera_blur":  # the bright spots / the tent smeared: lower peak, same mean
                assert w.image.std() < c.image.std()
                assert abs(float(w.image.mean()) - float(c.image.mean())) < 1.0
            else:
                raise AssertionError(f"{f.kind} on a frame")
        elif isinstance(c, ImuSample):
            if f.kind == "imu_drop":
                assert (w is None) == inside
                if not inside:
                    np.testing.assert_array_equal(w.gyro, c.gyro)
                continue
            gyro = np.radians(f.bias) if f.kind == "imu_gyro_bias" and inside else 0.0
            accel = np.asarray(f.bias) if f.kind == "imu_accel_bias" and inside else 0.0
            assert w.t == c.t
            np.testing.assert_allclose(w.gyro - c.gyro, gyro, atol=1e-12)
            np.testing.assert_allclose(w.accel - c.accel, accel, atol=1e-12)
        elif isinstance(c, GpsSample):
            assert f.kind == "gps_spoof"
            a = np.radians(f.walk_deg)
            d_ = np.array([np.cos(a), np.sin(a), 0.0]) * f.walk_mps
            np.testing.assert_allclose(w.position - c.position, d_ * (t - f.start_s) if inside else 0.0, atol=1e-9)
            np.testing.assert_allclose(w.velocity - c.velocity, d_ if inside else 0.0, atol=1e-12)
        else:
            raise AssertionError(f"{f.kind}: unexpected {type(c).__name__}")
    assert any(f.active(t) and c is not None for t, c, _ in rows), "no sample inside the window"


@pytest.mark.parametrize("scenario,target,kind", [
    ("deck-moving", "imu", "imu_drop"), ("deck-moving", "camera", "camera_blur"),
    ("condor-orbit", "imu", "imu_gyro_bias"), ("condor-orbit", "gps", "gps_spoof"),
    ("condor-orbit", "camera", "clock_jump")])
def test_the_simulation_wraps_exactly_the_target(scenario, target, kind):
    sim = Simulation(load_scenario(scenario, [f"faults=[{{kind='{kind}', start_s=1, duration_s=1}}]"]))
    wrapped = {n for n, s in sim.sensors.items() if isinstance(s, FaultySensor)}
    assert wrapped == {target}
    assert list(sim.sensors) == list(sim.parts.sensors)  # the sampling order is kept


@pytest.mark.parametrize("scenario", ["deck-moving", "condor-orbit"])
def test_a_gust_reaches_the_vehicle_environment(scenario):
    gust = FaultConfig(kind="wind_gust", start_s=1.0, duration_s=2.0, speed_mps=3.0, from_deg=90.0)
    sc = load_scenario(scenario, ["faults=[{kind='wind_gust', start_s=1, duration_s=2, speed_mps=3, from_deg=90}]"])
    clean, faulted = Simulation(load_scenario(scenario)), Simulation(sc)
    assert isinstance(faulted.world.wind, GustyWind)
    k = int(round(2.0 / clean.dt))  # mid-window: the gust's peak, from the east (blowing west)
    for k_, expect in ((0, 0.0), (k, 3.0)):
        e0 = clean.parts.hooks.environment(k_, k_ * clean.dt).wind_ned
        e1 = faulted.parts.hooks.environment(k_, k_ * clean.dt).wind_ned
        np.testing.assert_allclose(np.asarray(e1) - np.asarray(e0), [0.0, -expect, 0.0], atol=1e-9)


def test_a_camera_clock_jump_flies_through_condor():
    """A jumped frame arrives when it is taken (stamped ahead): the CONDOR loop's logger compares it with the
    truth of the step it arrives in, not of its stamp (which the one-step truth does not hold: it raised)."""
    sc = load_scenario("condor-orbit", ["run.duration_s=8",
                                        "faults=[{kind='clock_jump', sensor='camera', start_s=4, duration_s=2, jump_s=0.2}]"])
    res = Simulation(sc).run()
    assert res.error is None
    vis = res.log.get("vision")
    t = np.asarray(vis["t"], float)
    ahead = t[(t > 4.0) & (t < 6.3)]
    assert ahead.size > 10 and np.all(ahead >= 4.2 - 1e-9)  # the stamps in the window are the jumped ones
