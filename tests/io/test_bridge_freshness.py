"""The bridge's input-freshness model (io/bridge_freshness.py) and what the bridge sends with it, without
sockets (the link's send is captured): the covariance growth against a Monte-Carlo of the drift it models,
which streams apply, stale / expired thresholds, GPS_INPUT's fix type, and IMU samples late or out of order."""

import numpy as np
import pytest

from tests.io.bridge_fixtures import GpsFollowNavigator, offline_link
from visnav.io import mavlink_messages as mm
from visnav.app.bridge import Bridge, BridgeConfig
from visnav.io.bridge_freshness import (DEFAULT_BUDGETS, Freshness, FreshnessConfig, StreamBudget, inflate,
                                        stream_of)
from visnav.io.camera_source import Captured
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import AttitudeSample, BaroSample, GpsSample, ImuSample, NavEstimate, RangeSample


def _est(t=10.0, source="gps", P=None):
    P = np.diag([0.04, 0.04, 0.09, 0.01, 0.01, 0.02]) if P is None else P
    return NavEstimate(t=t, position=np.zeros(3), velocity=np.zeros(3), attitude=np.zeros(3), covariance=P,
                       source=source)


def test_inflation_matches_a_monte_carlo_of_the_drift_it_models():
    """Eq. (1)-(3): a filter state (p, v) ~ N(0, P) extrapolated over tau without IMU while an unobserved
    acceleration a ~ N(0, a_imu^2) acts: p + v tau + a tau^2 / 2, v + a tau. Sample covariance vs the model."""
    rng = np.random.default_rng(1)
    A = rng.normal(size=(6, 6)) * 0.3
    P = A @ A.T + np.eye(6) * 0.01
    tau, a_imu = 0.7, 2.0
    n = 200_000
    x = rng.multivariate_normal(np.zeros(6), P, size=n)
    acc = rng.normal(0.0, a_imu, size=(n, 3))
    p = x[:, :3] + x[:, 3:] * tau + 0.5 * acc * tau**2
    v = x[:, 3:] + acc * tau
    C = np.cov(np.hstack([p, v]).T)
    M = inflate(P, {"imu": tau}, {"imu": StreamBudget(0.1, 1.0, a_imu)})
    np.testing.assert_allclose(M, C, atol=0.02 * np.abs(C).max())
    # the closed form of eq. (1) alone: P = 0 -> sigma_p = a tau^2 / 2, sigma_v = a tau
    M0 = inflate(np.zeros((6, 6)), {"imu": 1.0}, DEFAULT_BUDGETS)
    assert M0[0, 0] == pytest.approx((0.5 * 2.0) ** 2) and M0[3, 3] == pytest.approx(2.0**2)
    assert np.all(np.linalg.eigvalsh(M0) > -1e-12)
    # a height stream widens the vertical only
    Mz = inflate(np.zeros((6, 6)), {"height": 2.0}, DEFAULT_BUDGETS)
    assert Mz[0, 0] == 0.0 and Mz[2, 2] == pytest.approx((0.5 * 0.1 * 4.0) ** 2)


def test_streams_apply_by_source_and_only_once_seen():
    f = Freshness()
    assert f.ages(10.0, "gps") == {}  # nothing seen: nothing judged (a vehicle without a range finder)
    f.seen("imu", 9.9)
    f.seen("imu", 9.5)  # an older stamp does not make the stream fresher
    f.seen("gps", 9.0)
    f.seen("camera", 8.0)
    assert f.ages(10.0, "gps") == pytest.approx({"imu": 0.1, "gps": 1.0})
    assert f.ages(10.0, "mpe") == pytest.approx({"imu": 0.1, "camera": 2.0})
    assert f.ages(10.0, "inertial") == pytest.approx({"imu": 0.1})
    assert stream_of(ImuSample(0.0, np.zeros(3), np.zeros(3))) == "imu"
    assert stream_of(AttitudeSample(0.0, np.zeros(3))) == "imu" and stream_of(BaroSample(0.0, 1.0)) == "height"
    with pytest.raises(ValueError, match="unknown bridge input stream 'lidar'"):
        FreshnessConfig().with_overrides(lidar={"timeout_s": 1.0})


def test_quality_and_fix_fall_with_age_and_stop_past_the_timeout():
    f = Freshness()
    f.seen("gps", 10.0)
    q, sig, fix = [], [], []
    for age in (0.0, 0.05, 0.3, 0.6, 0.9, 1.2):
        f.newest["imu"] = 10.0 - age
        a = f.assess(_est(10.0))
        q.append(mm.quality_from(a.estimate, None))
        sig.append(mm.horizontal_sigma(a.estimate.covariance))
        fix.append(f.fix_type(a))
        assert a.send == (age <= 1.0) and ("imu" in a.stale) == (age > 0.2)
    assert all(np.diff(q) <= 0) and q[0] > 85 and q[-2] < 75, q
    assert all(np.diff(sig) > 0) and sig[0] == pytest.approx(0.2)  # the filter's own sigma when fresh
    assert fix == [mavlink.GPS_FIX_TYPE_3D_FIX] * 2 + [mavlink.GPS_FIX_TYPE_2D_FIX] * 3 + [mavlink.GPS_FIX_TYPE_NO_FIX]
    assert f.assess(_est(10.0)).reason() == "no IMU/attitude for 1.2 s"
    f.newest["imu"] = 10.0 - 0.15  # within the 0.2 s budget: 3D, but already wider
    assert f.fix_type(f.assess(_est(10.0))) == mavlink.GPS_FIX_TYPE_3D_FIX
    # an unknown covariance stays unknown (quality 0), never made up
    a = f.assess(_est(10.0, P=np.full((6, 6), np.nan)))
    assert mm.quality_from(a.estimate, None) == 0


# ---------------------------------------------------------------------------------- the bridge, no sockets
def _bridge(**cfg):
    link, sent = offline_link()
    notes = []
    nav = GpsFollowNavigator()
    br = Bridge(link, None, nav, BridgeConfig(**cfg), notify=notes.append)
    sent.clear()
    return br, nav, sent, notes


def _frame(t, i):
    return Captured(np.zeros((4, 4), np.uint8), t, t, i)


def _gps(t):
    return GpsSample(t=t, position=np.array([1.0, 2.0, -10.0]), velocity=np.zeros(3), sigma=0.5)


def _imu(t):
    return ImuSample(t=t, accel=np.array([0.0, 0.0, -9.8]), gyro=np.zeros(3))


def _odo(sent):
    return [m for m in sent if m.get_type() == "ODOMETRY"]


def test_imu_out_of_order_dropped_and_late_imu_inflates_then_stops_and_resumes():
    br, nav, sent, notes = _bridge()
    for t in (100.00, 100.02, 100.04, 100.03, 100.01, 100.06):  # 100.03 and 100.01 overtaken
        br._consume(_imu(t))
    assert nav.imu_t == [100.00, 100.02, 100.04, 100.06] and br.counts["samples_out_of_order"] == 2
    for sensor in ("laser", "sonar", "laser"):  # two range finders at one instant: both kept
        br._consume(RangeSample(t=100.05, range=10.0, sensor=sensor))
    assert nav.others == 3 and br.counts["samples_out_of_order"] == 2
    assert sum("ImuSample out of order" in n for n in notes) == 1
    br._consume(_gps(100.06))
    br._consume(_frame(100.07, 0))  # IMU 10 ms old
    fresh = _odo(sent)[-1]
    br._consume(_imu(100.08))  # late: the next frame at 100.60 has IMU 0.52 s old
    br._consume(_gps(100.58))
    br._consume(_frame(100.60, 1))
    late = _odo(sent)[-1]
    s_fresh, s_late = (mm.horizontal_sigma(mm.from_upper_triangle(m.pose_covariance)) for m in (fresh, late))
    assert s_fresh == pytest.approx(0.5, abs=1e-3)  # the navigator's own 0.5 m
    # eq. (3): the navigator's 0.5 m, its 0.2 m/s velocity sigma over 0.52 s, and 2 m/s^2 unobserved
    assert s_late == pytest.approx(np.sqrt(0.25 + 0.04 * 0.52**2 + (0.5 * 2.0 * 0.52**2) ** 2), rel=1e-3)
    assert late.quality < fresh.quality
    n_before = len(_odo(sent))
    br._consume(_gps(101.20))
    br._consume(_frame(101.20, 2))  # IMU 1.12 s old: past the 1 s timeout
    br._consume(_frame(101.25, 3))
    assert len(_odo(sent)) == n_before and br.counts["estimates_withheld"] == 2
    assert sum("estimates stopped: no IMU/attitude for 1.1 s (timeout IMU/attitude 1 s)" in n for n in notes) == 1
    texts = [m.text for m in sent if m.get_type() == "STATUSTEXT"]
    assert len(texts) == 1 and "no estimate" in texts[0]
    br._consume(_imu(101.29))
    br._consume(_frame(101.30, 4))  # the IMU is back, but the estimate crossed a 1.21 s gap: still withheld
    assert len(_odo(sent)) == n_before and br.counts["estimates_withheld"] == 3
    br._consume(_gps(101.31))  # an aiding fix after the gap
    br._consume(_frame(101.32, 5))
    assert len(_odo(sent)) == n_before + 1 and sum(n.startswith("estimates resumed:") for n in notes) == 1
    assert br.reset_counter == 1 and _odo(sent)[-1].reset_counter == 1


def test_gps_input_fix_type_and_accuracy_follow_the_age():
    from visnav.geometry.frames import LocalTangentPlane

    br, nav, sent, notes = _bridge(output="gps-input", origin=LocalTangentPlane(58.0, 15.0, 100.0))
    out = []
    for i, age in enumerate((0.02, 0.3, 0.8)):
        t = 200.0 + i
        br._consume(_imu(t - age))
        br._consume(_gps(t))
        br._consume(_frame(t, i))
        out.append([m for m in sent if m.get_type() == "GPS_INPUT"][-1])
    assert [m.fix_type for m in out] == [3, 2, 2]
    h = [m.horiz_accuracy for m in out]
    assert h[0] == pytest.approx(0.5, abs=1e-3) and h[1] < h[2]
    assert h[2] == pytest.approx(np.sqrt(0.25 + 0.04 * 0.8**2 + (0.5 * 2.0 * 0.8**2) ** 2), rel=1e-3)
    assert out[2].speed_accuracy == pytest.approx(np.sqrt(0.09 + (2.0 * 0.8) ** 2), rel=1e-3)
