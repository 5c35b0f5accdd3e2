"""The detectors the innovations miss (issue #18): a GPS walk-off the filter follows (``GpsInertialCheck``)
and a map that disagrees with the odometry from the GPS hand-over (``HandoverCheck``), and the latched
suspicion they leave in ``NavIntegrity``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.measurements import AttitudeSample, GpsSample, Health, ImuSample
from visnav.navigation.integrity import GpsInertialCheck, HandoverCheck, NavIntegrity
from visnav.navigation.palace import PalaceNavigator
from visnav.scenarios.config_integrity import PalaceIntegrityConfig, WitasIntegrityConfig
from visnav.scenarios.schema import NavigationConfig


def _fly(check: GpsInertialCheck, walk_mps: float, t0: float = 5.0, t_end: float = 20.0, noise=0.0, accel_err=0.0,
         seed=0):
    """A vehicle swinging north-south (a = 2 sin t); GPS velocity at 10 Hz, walked off east by ``walk_mps`` from
    ``t0`` (the velocity consistent, as the spoofer does); the IMU integrates at 100 Hz with ``accel_err``."""
    rng = np.random.default_rng(seed)
    bias = rng.normal(0, accel_err, 2)
    for k in range(int(t_end * 100) + 1):
        t = 0.01 * k
        check.imu(t, np.array([2.0 * math.sin(t) + bias[0], bias[1], 0.0]))
        if k % 10 == 0:
            v = np.array([2.0 * (1 - math.cos(t)), 0.0]) + rng.normal(0, noise, 2)
            if t >= t0:
                v = v + np.array([0.0, walk_mps])
            check.gps(t, v)
    return check


def test_trigger_rate_is_the_chi2_quantile_of_the_velocity_noise_model():
    c = GpsInertialCheck(alpha=1e-7, window_s=1.0, vel_sigma_mps=0.03, accel_sigma_mps2=0.05)
    sigma = math.sqrt(2 * 0.03**2 + 0.05**2)
    assert c.bound == pytest.approx(chi2.ppf(1 - 1e-7, 2), rel=1e-12)
    assert c.bound == pytest.approx(-2 * math.log(1e-7), rel=1e-9)  # chi2(2): closed form
    assert c.trigger_rate == pytest.approx(sigma * math.sqrt(-2 * math.log(1e-7)), rel=1e-9)
    assert c.trigger_rate == pytest.approx(0.3723, abs=1e-3)


def test_walk_off_above_the_trigger_rate_is_flagged_below_it_not():
    rate = GpsInertialCheck().trigger_rate
    hit = _fly(GpsInertialCheck(), 1.05 * rate)
    assert hit.detected_t == pytest.approx(5.0, abs=0.05) and hit.rate_mps == pytest.approx(1.05 * rate, rel=1e-3)
    assert hit.onset == pytest.approx(4.0, abs=0.05)  # the window's start: the walk began after it
    assert hit.extra_hpl(13.0) == pytest.approx(9.0 * hit.rate_mps, rel=1e-6)  # 8 s of walk + the 1 s window
    miss = _fly(GpsInertialCheck(), 0.95 * rate)
    assert miss.onset is None and miss.extra_hpl(13.0) == 0.0


def test_no_false_alarm_from_receiver_noise_and_an_accelerometer_error_within_the_model():
    for seed in range(5):  # 200 s each at 10 Hz: 2000 tests per run at alpha 1e-7
        c = _fly(GpsInertialCheck(), 0.0, t_end=200.0, noise=0.02, accel_err=0.03, seed=seed)
        assert c.onset is None
        assert c.last_stat < c.bound
    # the 0.5 m/s walk-off of the fault campaign through the same noise: flagged at its start
    c = _fly(GpsInertialCheck(), 0.5, noise=0.02, accel_err=0.03, seed=1)
    assert c.detected_t == pytest.approx(5.0, abs=0.15)


def test_extra_hpl_stops_growing_when_the_fixes_stop():
    c = _fly(GpsInertialCheck(), 1.0, t_end=8.0)
    assert c.extra_hpl(8.0) == pytest.approx(4.0 * c.rate_mps, rel=1e-6)
    assert c.extra_hpl(60.0) == pytest.approx(c.extra_hpl(8.0))


def _palace_spoof(walk_mps, t_end=12.0):
    nav = PalaceNavigator(NavigationConfig(), PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0))
    rng = np.random.default_rng(3)
    states = {}
    for k in range(int(t_end * 100) + 1):
        t = 0.01 * k
        nav.update(AttitudeSample(t=t, euler=np.zeros(3)))
        nav.update(ImuSample(t=t, accel=np.array([0.0, 0.0, -9.81]), gyro=np.zeros(3)))
        if k % 10 == 0:
            w = walk_mps if t >= 4.0 else 0.0
            nav.update(GpsSample(t=t, position=np.array([0.0, w * max(t - 4.0, 0.0), -10.0]) +
                                 np.r_[rng.normal(0, 0.02, 2), 0.0],
                                 velocity=np.r_[rng.normal(0, 0.02, 2), 0.0] + np.array([0.0, w, 0.0]), sigma=0.02))
        if k % 50 == 25:
            h = nav.health(t)
            states[round(t, 2)] = (h.integrity, h.integrity_reason, h.hpl_m)
    return states


def test_palace_flags_a_gps_walk_off_the_filter_follows_and_its_hpl_covers_the_walk():
    clean = _palace_spoof(0.0)
    assert {s for t, (s, *_) in clean.items() if t > 1} == {"ok"}
    walk = _palace_spoof(0.5)
    assert walk[3.75][0] == "ok"
    s, why, hpl = walk[6.25]
    assert s == "degraded" and "walk-off" in why
    assert hpl > 0.5 * 2.25  # the walk so far (2.25 s at 0.5 m/s) is inside the HPL
    # 8 s of walk (4 m) + the filter's HPL: past PALACE's 4 m alert limit -> unusable
    assert walk[11.75][0] == "unusable" and walk[11.75][2] > 0.5 * 7.75


def test_handover_check_latches_a_persistent_offset_and_not_noise():
    h = HandoverCheck(alpha=1e-4, updates=3)
    assert h.bound == pytest.approx(chi2.ppf(1 - 1e-4, 2), rel=1e-12)
    rng = np.random.default_rng(0)
    for k in range(2000):  # fault-free: d ~ N(0, var I)
        assert not h.add(k * 0.4, rng.normal(0, 2.0, 2), 4.0)
    assert h.offset is None
    # two above the bound, then one below: no latch (not persistent)
    r = math.sqrt(h.bound * 4.0)
    assert not h.add(0, [1.1 * r, 0], 4.0) and not h.add(0, [1.1 * r, 0], 4.0) and not h.add(0, [0.9 * r, 0], 4.0)
    assert not h.add(1, [10.0, 0.5], 4.0) and not h.add(2, [10.4, -0.5], 4.0)
    assert h.add(3, [10.2, 0.0], 4.0)
    assert h.offset == pytest.approx([10.2, 0.0], abs=1e-9) and h.t == 3
    assert not h.add(4, [30.0, 0.0], 4.0) and h.offset == pytest.approx([10.2, 0.0])  # latched once


def test_suspicion_degrades_and_adds_to_the_hpl_and_goes_unusable_past_the_alert_limit():
    ni = NavIntegrity(WitasIntegrityConfig())
    P = np.diag([4.0, 1.0])
    ni.monitor.record(0.0, "vision", 2.0, 2, True)
    base = ni.fill(Health(source="vision"), 0.1, P)
    assert base.integrity == "ok"
    hpl0 = base.hpl_m
    ni.suspect("handover", "map off", lambda t: 10.0)
    h = ni.fill(Health(source="vision"), 0.2, P)
    assert h.integrity == "degraded" and "map off" in h.integrity_reason
    assert h.hpl_m == pytest.approx(hpl0 + 10.0, rel=1e-12)
    ni.suspect("gps_walk", "walk", lambda t: 30.0)  # the largest term counts (same error): 30 m + HPL > 30 m limit
    h = ni.fill(Health(source="vision"), 0.3, P)
    assert h.integrity == "unusable" and h.hpl_m == pytest.approx(hpl0 + 30.0, rel=1e-12)


def test_config_defaults_give_the_documented_trigger_rate():
    for c in (PalaceIntegrityConfig(), WitasIntegrityConfig()):
        from visnav.navigation.integrity import gps_check_from
        assert gps_check_from(c).trigger_rate == pytest.approx(0.3723, abs=1e-3)


def test_a_gap_in_the_fixes_restarts_the_window_instead_of_testing_across_it():
    c = GpsInertialCheck()
    for k in range(301):  # 3 s of fixes, then none for 5 s while the vehicle accelerates (the IMU sees it)
        t = 0.01 * k
        c.imu(t, np.zeros(3))
        if k % 10 == 0:
            c.gps(t, np.zeros(2))
    for k in range(301, 801):
        c.imu(0.01 * k, np.array([0.2, 0.0, 0.0]))  # 1 m/s gained by 8 s, felt by the IMU
    # GPS says 0.5 m/s: 0.1 m/s^2 of accelerometer error over the 5 s gap (2 sigma of the model there), but
    # 0.5 m/s against the 1 s window's sigma (0.066 m/s) would be far above its bound
    assert (0.5 / c.sigma) ** 2 > c.bound
    assert not c.gps(8.0, np.array([0.5, 0.0]))
    assert c.onset is None and len(c._fixes) == 1


def test_same_image_is_array_equal():
    """The frozen-link comparison (8-byte words for integer images) answers as ``np.array_equal``: a
    copy is the same, one changed byte anywhere (first, middle, last) is not, other shapes, dtypes,
    float images (NaN never equal) and a missing previous frame go through the reference."""
    from visnav.navigation.integrity import same_image

    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    assert same_image(img, img.copy()) and np.array_equal(img, img.copy())
    for idx in ((0, 0, 0), (24, 31, 1), (47, 63, 2)):
        b = img.copy()
        b[idx] ^= 1
        assert not same_image(img, b)
    assert not same_image(img, None)
    assert not same_image(img, img[:, :32])  # shapes differ
    odd = rng.integers(0, 256, (5, 7), dtype=np.uint8)  # 35 bytes: not whole words
    assert same_image(odd, odd.copy()) and not same_image(odd, odd + 1)
    f = rng.normal(size=(4, 4))
    f[0, 0] = np.nan
    assert same_image(f, f.copy()) == np.array_equal(f, f.copy()) is False
    assert same_image(img[:, ::2], img[:, ::2].copy())  # not contiguous: the reference path
def _rotate(check, bias, t_end=20.0, t_fault=10.0, offset=(0.0, 0.0, 0.0), seed=0, att_deg=0.03):
    """A vehicle turning (yaw 0.27 rad/s) and rocking; the autopilot's attitude at 50 Hz with ``att_deg`` noise
    (and a constant ``offset``); the gyros at 50 Hz with 2e-3 rad/s noise and ``bias`` from ``t_fault``.
    Returns (detection time or None, test statistics before it)."""
    from scipy.spatial.transform import Rotation

    from visnav.geometry.rotations import dcm_to_euler, euler_to_dcm

    rng = np.random.default_rng(seed)
    C, att, t, dt, stats = euler_to_dcm([0.1, -0.05, 1.0]), {}, 0.0, 0.02, []
    for k in range(int(t_end / dt)):
        w = np.array([0.2 * math.sin(0.5 * t), 0.1 * math.cos(0.3 * t), 0.27])
        t = round(t + dt, 6)
        C = C @ Rotation.from_rotvec(w * dt).as_matrix()
        att[t] = dcm_to_euler(C) + np.asarray(offset) + math.radians(att_deg) * rng.standard_normal(3)
        check.gyro(t, w + 2e-3 * rng.standard_normal(3) + (bias if t > t_fault else 0.0), dt)
        if k % 5 == 0:
            if check.check(lambda ti: att.get(round(ti, 6))):
                return t, np.array(stats)
            stats.append(check.last_stat)
    return None, np.array(stats)


def test_gyro_attitude_check_against_chi2_and_a_bias_step():
    from visnav.navigation.integrity import GyroAttitudeCheck

    g = GyroAttitudeCheck(alpha=1e-7, window_s=1.0, att_sigma_rad=math.radians(0.03), gyro_noise=2e-3,
                          gyro_bias=0.0, dt=0.02, att_bias_rad=0.0)
    assert g.bound == pytest.approx(chi2.ppf(1 - 1e-7, 3), rel=1e-12)
    det, stats = _rotate(g, np.zeros(3), t_end=120.0, offset=(0.0, 0.0, 0.3))  # a heading offset cancels
    assert det is None
    # with the model's own sigmas the statistic is chi-square(3): mean 3, 95 % quantile 7.81
    assert np.mean(stats) == pytest.approx(3.0, rel=0.15)
    assert np.mean(stats > chi2.ppf(0.95, 3)) == pytest.approx(0.05, abs=0.025)
    det, _ = _rotate(GyroAttitudeCheck(), np.radians([0.5, 0.5, 0.5]))
    assert det is not None and 10.0 < det <= 11.0
    det, _ = _rotate(GyroAttitudeCheck(), np.radians([0.05, 0.0, 0.0]))  # inside the turn-on bias: not a fault
    assert det is None
    # a roll / pitch bias of the attitude solution (0.15 deg) over the turns: inside the att_bias term
    det, _ = _rotate(GyroAttitudeCheck(), np.zeros(3), t_end=60.0, offset=(0.0026, -0.0026, 0.0))
    assert det is None


def test_gyro_attitude_check_rotation_equals_scipy_matrix_reference():
    """The check integrates the gyros as a quaternion and takes logs in scalar math (speed, issue #19): its
    statistic equals the rotation-matrix formula with scipy's exp / log (the earlier implementation) to
    rounding, on a turning flight with a bias step, sample by sample."""
    from scipy.spatial.transform import Rotation

    from visnav.geometry.rotations import euler_to_dcm
    from visnav.navigation.integrity import GyroAttitudeCheck

    g = GyroAttitudeCheck()
    rng = np.random.default_rng(3)
    R, hist, att, t, dt, n = np.eye(3), [], {}, 0.0, 0.02, 0
    for k in range(1500):
        w = np.array([0.2 * math.sin(0.5 * t), 0.1 * math.cos(0.3 * t), 0.27]) + (0.01 if k > 1000 else 0.0)
        t = round(t + dt, 6)
        att[t] = np.array([0.1 * math.sin(t), 0.05 * math.cos(0.7 * t), 0.27 * t]) + 1e-3 * rng.standard_normal(3)
        g.gyro(t, w, dt)
        R = R @ Rotation.from_rotvec(w * dt).as_matrix()
        hist.append((t, R.copy()))
        if k % 5 or k < 60:
            continue
        g.check(lambda ti: att.get(round(ti, 6)))
        (t1, R1), (t0, R0) = hist[-1], next(h for h in hist if h[0] >= t - g.window_s - 1e-9)
        dRa = euler_to_dcm(att[t0]).T @ euler_to_dcm(att[t1])
        d = Rotation.from_matrix(dRa.T @ (R0.T @ R1)).as_rotvec()
        turned = np.linalg.norm(Rotation.from_matrix(dRa).as_rotvec())
        ref = float(d @ d) / (g.sigma2 + (g.att_bias * turned) ** 2)
        assert g.last_stat == pytest.approx(ref, rel=1e-9, abs=1e-12)
        n += 1
    assert n > 250 and g.last_stat > g.bound  # the bias step is seen by both
