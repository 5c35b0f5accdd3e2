"""The navigator rejects and counts bad samples instead of crashing (NaN, negative, out of order)."""

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.measurements import AttitudeSample, GpsSample, ImuSample, RangeSample
from visnav.navigation.palace import PalaceNavigator
from visnav.scenarios.schema import NavigationConfig


def _nav():
    return PalaceNavigator(NavigationConfig(), PinholeCamera.ideal(), FixedMount.depressed(60.0))


def test_bad_samples_are_counted_not_fatal():
    nav = _nav()
    nav.update(GpsSample(0.0, np.array([0.0, 0.0, -10.0]), np.zeros(3)))
    nav.update(AttitudeSample(0.0, np.zeros(3)))
    nav.update(ImuSample(0.01, np.array([0.0, 0.0, -9.81]), np.zeros(3)))
    nav.update(ImuSample(0.02, np.array([np.nan, 0.0, -9.81]), np.zeros(3)))  # NaN
    nav.update(ImuSample(0.005, np.array([0.0, 0.0, -9.81]), np.zeros(3)))  # out of order
    nav.update(AttitudeSample(0.02, np.array([np.nan, 0.0, 0.0])))
    nav.update(GpsSample(0.1, np.array([np.nan, 0.0, -10.0]), np.zeros(3)))
    nav.update(RangeSample(0.1, -2.0, "laser"))
    nav.update(RangeSample(0.1, float("nan"), "laser"))  # no return: not an error, but laser not ok
    h = nav.health(0.1)
    assert h.rejected_samples == 4
    assert h.rejected_ranges == 1
    assert h.laser_ok is False
    est = nav.estimate(0.1)
    assert np.all(np.isfinite(est.position)) and abs(est.position[2] + 10.0) < 1e-3


def test_hover_prediction_keeps_position():
    nav = _nav()
    nav.update(GpsSample(0.0, np.array([1.0, 2.0, -10.0]), np.zeros(3)))
    for k in range(1, 101):
        t = k * 0.01
        nav.update(AttitudeSample(t, np.zeros(3)))
        nav.update(ImuSample(t, np.array([0.0, 0.0, -9.81]), np.zeros(3)))
    np.testing.assert_allclose(nav.estimate(1.0).position, [1.0, 2.0, -10.0], atol=1e-9)
    # a constant 1 m/s^2 northward specific force (level) integrates to 0.5 a t^2
    for k in range(101, 201):
        t = k * 0.01
        nav.update(AttitudeSample(t, np.zeros(3)))
        nav.update(ImuSample(t, np.array([1.0, 0.0, -9.81]), np.zeros(3)))
    assert abs(nav.estimate(2.0).position[0] - 1.5) < 1e-9


def test_late_gps_velocity_is_carried_to_the_filter_time():
    """Constant 2 m/s^2 north; GPS describes 50 ms before the IMU time the filter is at. Fused as if
    current, the velocity would sit a*lag = 0.1 m/s behind; carried forward, it matches the truth."""
    a, lag = 2.0, 0.05
    nav = _nav()
    nav.update(GpsSample(0.0, np.array([0.0, 0.0, -10.0]), np.zeros(3)))
    for k in range(1, 301):
        t = k * 0.01
        nav.update(AttitudeSample(t, np.zeros(3)))
        nav.update(ImuSample(t, np.array([a, 0.0, -9.81]), np.zeros(3)))
        if k % 10 == 0:  # 10 Hz fixes, delivered 50 ms after the instant they describe
            tg = t - lag
            nav.update(GpsSample(tg, np.array([0.5 * a * tg**2, 0.0, -10.0]), np.array([a * tg, 0.0, 0.0])))
    v = nav.estimate(3.0).velocity[0]
    assert abs(v - a * 3.0) < 0.01, v


def test_mpe_fix_sigma_adds_the_laser_and_attitude_noise_per_axis():
    """Default: eq. 3.3's pixel share only (floored at 2 cm); configured: the laser's σ0 + k R along
    the ground offset (linear in R) and the attitude noise times its length, in quadrature."""
    from visnav.estimation.mpe import MpeFix
    from visnav.scenarios.schema import MpeConfig

    off = np.array([31.0, 0.0, 54.0])  # camera -> point at 60° down, R = 62.3 m
    R = float(np.linalg.norm(off))
    fix = MpeFix(t=0.0, camera_position=np.zeros(3), position=np.zeros(3), ground_offset=off,
                 sigma_px_m=R / (1073.0 * np.sqrt(12.0)))
    assert _nav()._fix_sigma(fix, R) == 0.02
    cfg = NavigationConfig(mpe=MpeConfig(range_sigma0_m=0.015, range_sigma_per_m=0.003, attitude_sigma_deg=0.03))
    s = PalaceNavigator(cfg, PinholeCamera.ideal(), FixedMount.depressed(60.0))._fix_sigma(fix, R)
    sl = 0.015 + 0.003 * R
    sa = np.radians(0.03) * R
    np.testing.assert_allclose(s, np.sqrt(0.02**2 + (sl * off / R) ** 2 + sa**2))
    assert s[0] > 5 * 0.02 and s[1] < 0.04  # along track the laser dominates; across it does not enter
