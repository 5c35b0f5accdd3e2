"""Fault injection (issue #18): each kind changes exactly what it says, only inside its window."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from visnav.measurements import AttitudeSample, Frame, GpsSample, ImuSample, PanTiltFrame, RangeSample
from visnav.scenarios.base import ScenarioError
from visnav.scenarios.config_integrity import FaultConfig
from visnav.scenarios.schema import load_scenario
from visnav.sensors.faults import FaultySensor, GustyWind, apply_faults, blur_kernel, inject_faults, map_faults


class FakeCamera:
    rate_hz, latency_s = 10.0, 0.03

    def __init__(self):
        self.k = 0

    def sample(self, t, truth_at=None, world=None):
        self.k += 1
        img = np.random.default_rng(self.k).integers(0, 256, (48, 64), dtype=np.uint8)
        return Frame(t=t, image=img, index=self.k)


class FakeImu:
    rate_hz, latency_s = 100.0, 0.0

    def sample(self, t, truth_at=None):
        return (ImuSample(t=t, accel=np.array([0.1, 0.2, -9.8]), gyro=np.array([0.01, -0.02, 0.03])),
                AttitudeSample(t=t, euler=np.array([0.01, 0.02, 0.3])))


class FakeRange:
    rate_hz, latency_s = 10.0, 0.0

    def sample(self, t, truth_at=None):
        return RangeSample(t=t, range=10.0 + t, sensor="laser", beam_offset=0.01)


class FakeGps:
    rate_hz, latency_s = 10.0, 0.05

    def sample(self, t, truth_at=None):
        return GpsSample(t=t, position=np.array([1.0, 2.0, -3.0]), velocity=np.array([0.5, 0.0, 0.0]), sigma=0.02)


def fault(**kw):
    kw.setdefault("start_s", 1.0)
    kw.setdefault("duration_s", 2.0)
    return FaultConfig(**kw)


def run(sensor, f, times=(0.5, 1.0, 2.0, 2.99, 3.0, 4.0), seed=0):
    clean = type(sensor)()
    wrapped = FaultySensor(type(sensor)(), [f], np.random.default_rng(seed))
    return [(t, clean.sample(t), wrapped.sample(t)) for t in times]


def same_frame(a, b):
    return a.t == b.t and a.index == b.index and np.array_equal(a.image, b.image)


@pytest.mark.parametrize("kind", ["camera_blackout", "camera_brightness", "camera_blur", "camera_frozen"])
def test_camera_faults_change_the_image_only_inside_the_window(kind):
    f = fault(kind=kind)
    rows = run(FakeCamera(), f)
    before = rows[0][1].image  # the last image before the fault (t = 0.5)
    for t, c, w in rows:
        assert w.t == c.t and w.index == c.index
        if not f.active(t):
            assert same_frame(c, w)
            continue
        if kind == "camera_blackout":
            assert not w.image.any()
        elif kind == "camera_brightness":
            np.testing.assert_array_equal(w.image, np.clip(np.rint(c.image * 1.6 + 40.0), 0, 255).astype(np.uint8))
        elif kind == "camera_blur":
            # a horizontal 9 px box along x: the blurred image is the row-wise mean of 9 neighbours
            ref = np.clip(np.rint(np.apply_along_axis(
                lambda r: np.convolve(np.pad(r.astype(float), 4, mode="edge"), np.ones(9) / 9, "valid"), 1,
                c.image)), 0, 255)
            assert np.abs(w.image.astype(float) - ref).max() <= 1.0
            assert w.image.std() < 0.6 * c.image.std()
        elif kind == "camera_frozen":
            np.testing.assert_array_equal(w.image, before)


def test_blur_kernel_is_a_normalised_line():
    k = blur_kernel(9, 90.0)
    assert k.sum() == pytest.approx(1.0)
    assert np.count_nonzero(k) == 9 and np.count_nonzero(k[:, 4]) == 9  # vertical line


def test_pantilt_frames_keep_their_encoder_angles():
    f = fault(kind="camera_blackout")
    w = FaultySensor(SimpleNamespace(sample=lambda t: PanTiltFrame(t=t, image=np.full((4, 4), 9, np.uint8),
                                                                   index=3, pan=0.2, tilt=-0.4)), [f], None)
    out = w.sample(1.5)
    assert isinstance(out, PanTiltFrame) and out.pan == 0.2 and out.tilt == -0.4 and not out.image.any()


@pytest.mark.parametrize("kind,field", [("imu_gyro_bias", "gyro"), ("imu_accel_bias", "accel")])
def test_imu_bias_steps(kind, field):
    bias = [0.5, -1.0, 2.0]
    f = fault(kind=kind, bias=bias)
    for t, (ci, ca), (wi, wa) in run(FakeImu(), f):
        other = "accel" if field == "gyro" else "gyro"
        np.testing.assert_array_equal(getattr(wi, other), getattr(ci, other))
        np.testing.assert_array_equal(wa.euler, ca.euler)  # the attitude solution is untouched
        expect = np.radians(bias) if field == "gyro" else np.array(bias)
        np.testing.assert_allclose(getattr(wi, field) - getattr(ci, field), expect if f.active(t) else 0.0,
                                   atol=1e-15)
        assert wi.t == ci.t and wa.t == ca.t


def test_imu_drop_loses_the_share_asked_for_and_only_in_the_window():
    f = fault(kind="imu_drop", drop_probability=0.3, start_s=1.0, duration_s=50.0)
    w = FaultySensor(FakeImu(), [f], np.random.default_rng(4))
    ts = np.arange(0.0, 60.0, 0.01)
    out = [w.sample(t) for t in ts]
    inside = np.array([f.active(t) for t in ts])
    lost = np.array([o[0] is None for o in out])
    assert all(o[1] is None for o in out if o[0] is None)  # the whole IMU message
    assert not lost[~inside].any()
    n = inside.sum()
    assert abs(lost[inside].mean() - 0.3) < 4 * math.sqrt(0.3 * 0.7 / n)


def test_clock_jump_moves_the_stamps_not_the_data():
    f = fault(kind="clock_jump", sensor="laser", jump_s=0.25)
    for t, c, w in run(FakeRange(), f):
        assert w.range == c.range and w.beam_offset == c.beam_offset
        assert w.t == pytest.approx(c.t + (0.25 if f.active(t) else 0.0))


def test_clock_jump_arrives_when_the_unjumped_stamp_would():
    """A sensor whose clock jumped still sends on time: stamp + latency is the unjumped delivery time, so the
    navigator sees a measurement stamped ahead of its own clock (issue #30; the loop schedules stamp + latency)."""
    f = fault(kind="clock_jump", sensor="gps", jump_s=0.2)
    w = FaultySensor(FakeGps(), [f], np.random.default_rng(0))
    for t in (0.5, 1.0, 2.0, 2.99, 3.0, 4.0):
        m = w.sample(t)
        jump = 0.2 if f.active(t) else 0.0
        assert m.t == pytest.approx(t + jump)
        assert w.latency_s == pytest.approx(0.05 - jump)
        assert m.t + w.latency_s == pytest.approx(t + 0.05)


def test_range_dropout_and_stuck():
    f = fault(kind="range_dropout")
    for t, c, w in run(FakeRange(), f):
        assert (math.isnan(w.range) if f.active(t) else w.range == c.range) and w.t == c.t
    f = fault(kind="range_stuck")
    for t, c, w in run(FakeRange(), f):
        assert w.range == (11.0 if f.active(t) else c.range)  # the first range in the fault (t = 1)


def test_gps_spoof_walks_off_consistently_then_the_fix_is_lost():
    f = fault(kind="gps_spoof", walk_mps=2.0, walk_deg=90.0)
    g = apply_faults({"gps": FakeGps()}, [f], np.random.default_rng(0))["gps"]
    for t in (0.5, 1.0, 2.0, 2.5):
        c, w = FakeGps().sample(t), g.sample(t)
        d = np.array([0.0, 2.0, 0.0]) * (t - 1.0 if f.active(t) else 0.0)
        np.testing.assert_allclose(w.position - c.position, d, atol=1e-12)
        np.testing.assert_allclose(w.velocity - c.velocity, [0.0, 2.0, 0.0] if f.active(t) else 0.0, atol=1e-12)
    assert g.sample(3.0) is None and g.sample(10.0) is None
    kept = apply_faults({"gps": FakeGps()}, [fault(kind="gps_spoof", lost_after=False)], None)["gps"]
    np.testing.assert_array_equal(kept.sample(3.0).position, FakeGps().sample(3.0).position)


def test_wind_gust_is_one_minus_cos_over_the_window():
    inner = SimpleNamespace(velocity_ned=lambda t, *a, **k: np.array([1.0, 0.0, 0.0]), steady="s")
    w = GustyWind(inner, [fault(kind="wind_gust", speed_mps=4.0, from_deg=0.0)])
    np.testing.assert_allclose(w.velocity_ned(0.5, 0.05), [1.0, 0.0, 0.0])
    np.testing.assert_allclose(w.velocity_ned(2.0, 0.05), [1.0 - 4.0, 0.0, 0.0])  # peak mid-window, from north
    np.testing.assert_allclose(w.velocity_ned(3.0, 0.05), [1.0, 0.0, 0.0])
    assert w.steady == "s"


def test_map_faults_shift_the_reference_and_flood_an_area():
    from visnav.world.maps import GeoImage

    rng = np.random.default_rng(0)
    geo = GeoImage(rng.integers(0, 256, (200, 300), dtype=np.uint8), 100.0, -150.0, 1.0)
    off = map_faults(geo, [FaultConfig(kind="map_offset", offset_m=[12.0, -5.0])], "reference")
    assert off.north0 == 112.0 and off.east0 == -155.0 and np.array_equal(off.image, geo.image)
    assert map_faults(geo, [FaultConfig(kind="map_offset")], "world") is geo  # the world is the world
    wet = map_faults(geo, [FaultConfig(kind="feature_poor", centre_m=[0.0, 0.0], size_m=[40.0, 60.0])], "world")
    changed = wet.image != geo.image
    rows, cols = np.nonzero(changed)
    north, east = 100.0 - rows, -150.0 + cols
    assert np.all(np.abs(north) <= 20.0) and np.all(np.abs(east) <= 30.0)
    inside = wet.image[80:121, 120:181].astype(float)  # rows north 20..-20, cols east -30..30
    assert inside.std() < 3.0 and abs(inside.mean() - 62.0) < 2.0


def test_inject_faults_wraps_the_named_sensors_of_a_simulation():
    sensors = dict(imu=FakeImu(), gps=FakeGps(), laser=FakeRange(), sonar=FakeRange(), camera=FakeCamera())
    world = SimpleNamespace(wind="w")
    out = inject_faults(sensors, world, [fault(kind="range_dropout", sensor="sonar")], np.random.default_rng(0))
    assert isinstance(out["sonar"], FaultySensor) and not isinstance(out["laser"], FaultySensor)
    assert out["sonar"].rate_hz == 10.0 and world.wind == "w" and list(out) == list(sensors)
    with pytest.raises(ValueError, match="needs a 'baro' sensor"):
        apply_faults({"imu": FakeImu()}, [fault(kind="clock_jump", sensor="baro")], None)


def test_scenario_faults_are_validated_in_one_line():
    sc = load_scenario("palace-landing", ["faults=[{kind='camera_blackout', start_s=50, duration_s=5}]"])
    assert sc.faults[0].end_s == 55.0
    with pytest.raises(ScenarioError, match="do not apply to mission.type 'palace'"):
        load_scenario("palace-landing", ["faults=[{kind='map_offset'}]"])
    with pytest.raises(ScenarioError, match="faults.0.kind"):
        load_scenario("palace-landing", ["faults=[{kind='volcano'}]"])


def test_a_wrapped_sensor_renders_asynchronously_only_where_the_sensor_itself_does():
    """The loop renders on its second thread where ``hasattr(sensor, "sample_async")``: a faulted GPS (which has
    no such method) must not claim one (the palace GPS-spoof campaign failed at t = 0 when it did)."""

    class AsyncCamera(FakeCamera):
        def sample_async(self, t, truth_at=None, world=None, pool=None):
            return None

    gps = apply_faults({"gps": FakeGps()}, [fault(kind="gps_spoof")], np.random.default_rng(0))["gps"]
    cam = apply_faults({"camera": AsyncCamera()}, [fault(kind="camera_blackout")], np.random.default_rng(0))["camera"]
    assert not hasattr(gps, "sample_async")
    assert hasattr(cam, "sample_async") and cam.sample_async(0.0) is None
