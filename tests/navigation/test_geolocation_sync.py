"""Which telemetry a frame of the geo-location navigator is registered and ray-cast with (seed 002 §7.4.3:
the ground station recorded "camera images and corresponding telemetry" simultaneously)."""

from __future__ import annotations

import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.measurements import TelemetrySample
from visnav.navigation.geolocation import GeolocationNavigator
from visnav.world.rural import rural_map


@pytest.fixture(scope="module")
def ref():
    return rural_map(160.0, 0.5, np.random.default_rng(1))


def _nav(ref, sync):
    return GeolocationNavigator(ref, PinholeCamera.ideal(720, 576, 722.0), telemetry_sync=sync)


def _feed(nav):
    # 5 Hz samples of a MAV flying east at 13 m/s, heading turning 0.2 rad/s, climbing 1 m/s
    for k in range(5):
        t = 10.0 + 0.2 * k
        nav.update(TelemetrySample(t, np.array([0.0, 13.0 * (t - 10.0), -70.0]), 0.2 * (t - 10.0), 70.0 + (t - 10.0), 13.0))


def test_hold_takes_the_last_sample_before_the_frame(ref):
    nav = _nav(ref, "hold")
    _feed(nav)
    s = nav._telemetry_at(10.5)  # between the samples of 10.4 and 10.6
    assert s.t == pytest.approx(10.4) and s.position[1] == pytest.approx(13.0 * 0.4)
    assert s.heading == pytest.approx(0.08) and s.height == pytest.approx(70.4)
    assert nav._telemetry_at(10.8) is not None and nav._telemetry_at(10.81) is None  # no sample after it yet


def test_interpolate_takes_the_frame_time(ref):
    nav = _nav(ref, "interpolate")
    _feed(nav)
    s = nav._telemetry_at(10.5)
    assert s.position[1] == pytest.approx(13.0 * 0.5) and s.heading == pytest.approx(0.1)
    assert s.height == pytest.approx(70.5)
    # the hold is 0.1 s of flight behind it here: 1.3 m at 13 m/s
    assert s.position[1] - _hold_east(ref) == pytest.approx(1.3)


def _hold_east(ref):
    nav = _nav(ref, "hold")
    _feed(nav)
    return float(nav._telemetry_at(10.5).position[1])


def test_unknown_sync_is_one_clear_error(ref):
    with pytest.raises(ValueError, match="telemetry_sync"):
        _nav(ref, "nearest")


def test_frame_phase_is_a_step_within_one_frame_period():
    from visnav.app.geoloc_parts import frame_phase

    rng = np.random.default_rng(4)
    ph = [frame_phase(None, 5.0, 0.01, rng) for _ in range(400)]
    k = np.round(np.array(ph) / 0.01)
    np.testing.assert_allclose(np.array(ph), k * 0.01, atol=1e-12)
    assert set(k.astype(int)) == set(range(20))  # every step of the 0.2 s period is drawn
    assert frame_phase(0.1, 5.0, 0.01, rng) == pytest.approx(0.1)  # rounds 1-3
    assert frame_phase(0.33, 5.0, 0.01, rng) == pytest.approx(0.13)  # modulo the period
