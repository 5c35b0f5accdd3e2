"""Issue #30: accelerometer-bias faults observable or detected, a stuck range sensor detected.

- ``PositionFilter`` with an accelerometer-bias state: the same numbers as a dense 3-state Kalman filter,
  the bias of a synthetic flight learnt from position fixes, and the dead reckoning after the last fix
  (PALACE's final metre) held by it where the two-state filter drifts;
- ``StuckRangeCheck``: repeated ranges while descending flag, noisy ones and a hover do not;
- ``TiltCheck``: a lasting tilt difference flags after ``persist_s``, its position bound in closed form;
- the PALACE navigator: a stuck laser gives no range to MPE (``laser_ok`` false) and leaves ``ok``.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.estimation.position_filter import PositionFilter
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.measurements import AttitudeSample, GpsSample, ImuSample, RangeSample
from visnav.navigation.integrity import StuckRangeCheck, TiltCheck
from visnav.navigation.palace import PalaceNavigator
from visnav.scenarios.schema import NavigationConfig


def test_bias_filter_is_the_dense_three_state_kalman_filter():
    rng = np.random.default_rng(0)
    f = PositionFilter(0.3, np.zeros(3), np.zeros(3), accel_bias_noise=0.05, sigma_b=0.1)
    f.t = 0.0
    x, P = np.zeros(3), np.diag([1.0, 0.25, 0.01])  # axis 0: (p, v, b)
    q, qb, dt, t = 0.09, 0.05**2, 0.01, 0.0
    for k in range(300):
        t += dt
        a = rng.normal(size=3)
        f.predict(t, a)
        F = np.array([[1, dt, -dt * dt / 2], [0, 1, -dt], [0, 0, 1]])
        x = F @ x + np.array([dt * dt / 2, dt, 0.0]) * a[0]
        P = F @ P @ F.T + np.array([[q * dt**3 / 3, q * dt**2 / 2, 0], [q * dt**2 / 2, q * dt, 0], [0, 0, qb * dt]])
        for every, m, r, upd in ((10, 0, 0.01, lambda z: f.update_position(z, 0.1)),
                                 (25, 1, 0.0025, lambda z: f.update_velocity(z, 0.05))):
            if k % every == 0:
                z = rng.normal(size=3)
                upd(z)
                H = np.eye(3)[m:m + 1]
                K = P @ H.T / (H @ P @ H.T + r)
                x = x + (K * (z[0] - x[m])).ravel()
                P = P - K @ H @ P
    np.testing.assert_allclose([f.p[0], f.v[0], f.b[0]], x, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(f.axis_covariance(0), P, rtol=1e-10, atol=1e-15)


def _dead_reckoning_error(bias_noise: float, bias=0.3, fixes_s=15.0, dark_s=2.5, seed=1) -> tuple[float, float]:
    """Hover with an accelerometer reading ``bias`` too much on x; 10 Hz position fixes (sigma 5 cm) for
    ``fixes_s``, then ``dark_s`` of dead reckoning. (bias estimate, position error at the end)."""
    rng = np.random.default_rng(seed)
    f = PositionFilter(0.3, np.zeros(3), np.zeros(3), accel_bias_noise=bias_noise, sigma_b=0.05 if bias_noise else 0)
    f.t = 0.0
    for k in range(1, int((fixes_s + dark_s) * 100) + 1):
        t = 0.01 * k
        f.predict(t, np.array([bias, 0.0, 0.0]) + rng.normal(0, 0.02, 3))
        if t <= fixes_s and k % 10 == 0:
            f.update_position(rng.normal(0, 0.05, 3), 0.05)
    return float(f.b[0]), float(abs(f.p[0]))


def test_bias_state_learns_a_step_and_holds_the_dead_reckoning():
    b, err = _dead_reckoning_error(0.05)
    assert abs(b - 0.3) < 0.05
    # the residual bias (< 0.05) over 2.5 s: < 0.05 * 2.5^2 / 2 + the fix noise
    assert err < 0.3
    _, err0 = _dead_reckoning_error(0.0)
    # without it the velocity the fixes left plus 0.3 * 2.5^2 / 2 = 0.94 m
    assert err0 > 0.8


def _ranges(check, stuck_from=math.inf, vz=0.6, t_end=4.0, sigma=0.02, seed=0):
    rng = np.random.default_rng(seed)
    out, stuck_value = [], None
    for k in range(int(t_end * 10) + 1):
        t = 0.1 * k
        r = 10.0 - vz * t + rng.normal(0, sigma)
        if t >= stuck_from - 1e-9:
            stuck_value = r if stuck_value is None else stuck_value
            r = stuck_value
        out.append((t, check.add(t, r, vz)))
    return out


def test_stuck_range_flags_on_the_third_repeated_reading_while_descending():
    c = StuckRangeCheck(samples=3, min_change_m=0.05)
    out = _ranges(c, stuck_from=2.0)
    first = next(t for t, s in out if s)
    assert math.isclose(first, 2.2, abs_tol=1e-9)  # readings at 2.0, 2.1, 2.2 identical
    assert c.onset == 2.0 and math.isclose(c.error_bound(3.0), 0.6 * 0.2)  # used until the flag, not after


def test_stuck_range_silent_on_noise_and_when_hovering():
    c = StuckRangeCheck()
    assert not any(s for _, s in _ranges(c, seed=3))  # live noisy ranges
    h = StuckRangeCheck()
    assert not any(s for _, s in _ranges(h, stuck_from=1.0, vz=0.0))  # a hover cannot tell (nor is misled)


def test_stuck_range_recovers_when_the_reading_moves():
    c = StuckRangeCheck()
    for k in range(5):
        c.add(0.1 * k, 8.0, 0.6)
    assert c.stuck
    assert not c.add(0.6, 7.6, 0.6) and not c.stuck


def test_tilt_check_flags_after_persisting_and_bounds_the_position_error():
    c = TiltCheck(limit_deg=1.5, persist_s=1.0)
    flags = []
    for k in range(100):
        t = 0.1 * k
        ang = math.radians(min(0.3 * t, 2.4))  # rises 0.3 deg/s to 2.4 deg (a 0.42 m/s^2 bias)
        flags.append((t, c.update(t, [ang, 0.0])))
    hit = [t for t, f in flags if f]
    assert len(hit) == 1  # once
    # above 0.75 deg from 2.5+ s (onset), above 1.5 deg after 5.0 s, flagged 1 s later
    assert math.isclose(c.onset, 2.6, abs_tol=1e-9) and math.isclose(hit[0], 6.1, abs_tol=1e-9)
    T = hit[0] - c.onset
    assert math.isclose(c.position_bound(), 9.81 * math.sin(c.angle) * T * T / 2)


def test_tilt_check_silent_below_the_limit_and_on_short_spikes():
    c = TiltCheck(limit_deg=1.5, persist_s=1.0)
    rng = np.random.default_rng(0)
    for k in range(2000):
        t = 0.1 * k
        ang = math.radians(0.4 + 0.3 * abs(rng.normal()) + (2.0 if k % 50 < 5 else 0.0))  # 0.5 s spikes
        assert not c.update(t, [ang, 0.0])


def test_palace_navigator_drops_a_stuck_laser_and_leaves_ok():
    nav = PalaceNavigator(NavigationConfig(), PinholeCamera.ideal(640, 480, 1073.0), FixedMount.depressed(60.0))
    vz = 0.5
    states = []
    for k in range(0, 401):
        t = 0.01 * k
        p = np.array([0.0, 0.0, -10.0 + vz * t])
        if k % 10 == 0:
            nav.update(AttitudeSample(t=t, euler=np.zeros(3)))
            nav.update(GpsSample(t=t, position=p, velocity=np.array([0.0, 0.0, vz]), sigma=0.05))
            r = (10.0 - vz * min(t, 2.0)) / math.cos(math.radians(60.0))  # stuck from 2 s
            nav.update(RangeSample(t=t, range=r, sensor="laser"))
            h = nav.health(t)
            states.append((t, h.laser_ok, h.integrity))
        nav.update(ImuSample(t=t, accel=np.array([0.0, 0.0, -9.81]), gyro=np.zeros(3)))
    before = [s for s in states if s[0] < 2.15]
    after = [s for s in states if s[0] >= 2.2]
    assert all(ok and i == "ok" for _, ok, i in before)
    assert all(not ok and i != "ok" for _, ok, i in after)
    assert all(math.isnan(m.range) for m in nav.lasers if m.t >= 2.2)


def test_short_window_inflation_is_relative_to_the_streams_usual_nis():
    from visnav.estimation.integrity import IntegrityConfig, IntegrityMonitor

    rng = np.random.default_rng(0)
    mon = IntegrityMonitor(IntegrityConfig(window=20, short_window=5, inflation_streams=("vision",)))
    off = IntegrityMonitor(IntegrityConfig(window=20, inflation_streams=("vision",)))
    k2 = []
    for k in range(300):  # a conservative fix noise: NIS/dof ~ exponential with mean 0.025 (chi2(2) / 2 / 40)
        nis = rng.chisquare(2) / 40
        mon.record(0.05 * k, "vision", nis, 2, True)
        off.record(0.05 * k, "vision", nis, 2, True)
        k2.append(mon.inflation())
    assert abs(mon.baseline("vision") - 0.025) < 0.005
    assert max(k2[60:]) < 5.0  # fault-free: at most a few times (a mean of 10 dof over its mean)
    for k in range(3):  # a fault: NIS per dof 50 times the usual level
        mon.record(15.0 + 0.05 * k, "vision", 50 * 0.05, 2, True)
        off.record(15.0 + 0.05 * k, "vision", 50 * 0.05, 2, True)
    assert mon.inflation() > 20.0  # 3 of the last 5 at 50x the usual level: (3 * 50 + 2) / 5 ~ 30
    assert off.inflation() == 1.0  # the absolute test alone sees NIS/dof 0.4 over 20: nothing
    assert abs(mon.baseline("vision") - 0.025) < 0.005  # the fault's updates stay out of the baseline


def test_witas_frame_stamped_ahead_of_the_imu_is_a_camera_gap_until_the_clock_agrees():
    from tests.navigation.test_witas_navigator import _engaged, _hover
    from visnav.measurements import Frame

    nav = _engaged()  # IMU delivered up to 2.99 s
    rng = np.random.default_rng(2)
    nav.update(Frame(3.2, rng.integers(0, 255, (288, 384), dtype=np.uint8)))  # 0.21 s ahead (> 0.1)
    h = nav.health(3.0)
    assert h.integrity != "ok" and "ahead of the IMU clock" in h.integrity_reason
    _hover(nav, 3.0, 3.3, gps=False)
    # 0.01 s behind the IMU: live (a queued frame is processed on the next frame's arrival)
    nav.update(Frame(3.28, rng.integers(0, 255, (288, 384), dtype=np.uint8)))
    assert "ahead" not in nav.health(3.3).integrity_reason
    assert nav.n_frames == 2 and nav.registrations == 0
    notes = " ".join(nav.h.notes)
    assert "3.2s odometry skipped: frame stamped 0.21 s ahead of the IMU clock" in notes
    assert "3.3s odometry skipped: frame stamped" not in notes
