"""Error-state Kalman filter (seed 002 App. A.1.2, §5.8.3, §5.9.1) on analytic flights with exact truth."""

import math

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from scipy.linalg import expm
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from visnav.estimation.eskf import EskfConfig, ErrorStateKF, heading_from_mag
from visnav.estimation.ins import NavState, euler_to_quat, quat_to_dcm
from visnav.geometry.rotations import euler_to_dcm, wrap_angle
from visnav.measurements import ImuSample
from visnav.sim.trajectory import SinusoidTrajectory, hover, manoeuvring_flight

D2R = math.pi / 180.0


def _errors(f: ErrorStateKF, d: dict, k: int, ba: np.ndarray) -> np.ndarray:
    """Truth minus estimate in the filter's error-state convention (eps: C_true = (I+[eps x]) C)."""
    eps = Rotation.from_matrix(d["dcm"][k] @ quat_to_dcm(f.x.quat).T).as_rotvec()
    return np.r_[d["position"][k] - f.x.position, d["velocity"][k] - f.x.velocity, eps, ba - f.x.accel_bias]


def _fly(traj, cfg, T, rng, *, dt=0.02, att_err_deg=(0.0, 0.0, 0.0), pos_err=(0.0, 0.0, 0.0),
         vel_err=(0.0, 0.0, 0.0), ba=(0.0, 0.0, 0.0), P0=None, pos_every=25, pos_sigma=1.0,
         pos_2d=False, compass_every=0, compass_sigma_deg=2.0, noise=True, check_every=50):
    t = np.arange(0.0, T + dt / 2, dt)
    d = traj.sample(t)
    ba = np.asarray(ba, dtype=float)
    acc = d["specific_force"] + ba
    gyr = d["gyro"].copy()
    if noise:
        acc = acc + rng.normal(0.0, cfg.accel_noise / math.sqrt(dt), acc.shape)
        gyr = gyr + rng.normal(0.0, cfg.gyro_noise / math.sqrt(dt), gyr.shape)
    e0 = d["euler"][0] + np.asarray(att_err_deg) * D2R
    s0 = NavState(0.0, d["position"][0] - pos_err, d["velocity"][0] - vel_err, euler_to_quat(e0))
    if P0 is None:
        P0 = np.r_[[max(3.0, 2 * np.max(np.abs(pos_err)))] * 3, [1.0] * 3, [7.0 * D2R] * 3, [0.1] * 3]
    f = ErrorStateKF(s0, P0, cfg)
    hist = []
    for k in range(len(t)):
        f.predict(ImuSample(t[k], acc[k], gyr[k]))
        if pos_every and k and k % pos_every == 0:
            z = d["position"][k] + rng.normal(0.0, pos_sigma, 3) * noise
            f.update_position(z[:2] if pos_2d else z, pos_sigma)
        if compass_every and k and k % compass_every == 0:
            f.update_heading(d["euler"][k, 2] + rng.normal(0.0, compass_sigma_deg * D2R) * noise,
                             compass_sigma_deg * D2R)
        if k % check_every == 0:
            err = _errors(f, d, k, ba)
            hist.append((t[k], err, f.P.copy(), f.x.euler - d["euler"][k]))
    return f, d, hist


def _euler_err_deg(hist, i=-1):
    e = hist[i][3]
    return np.abs(np.r_[e[:2], wrap_angle(e[2])]) / D2R


CFG = EskfConfig(accel_noise=0.02, gyro_noise=5e-4, accel_bias_noise=1e-4, earth_rotation=False,
                 gravity_mps2=9.81)


def test_perfect_position_updates_converge():
    """Exact IMU, exact 3-D positions at 2 Hz: all errors of the 12 states collapse."""
    rng = np.random.default_rng(1)
    f, d, hist = _fly(manoeuvring_flight(), CFG, 60.0, rng, att_err_deg=(3, -3, 4), pos_err=(4, -3, 2),
                      vel_err=(0.5, -0.5, 0.2), ba=(0.05, -0.04, 0.03), pos_sigma=0.05, noise=False)
    err = hist[-1][1]
    assert np.abs(err[:3]).max() < 0.01
    assert np.abs(err[3:6]).max() < 0.01
    assert np.abs(err[6:9]).max() < 0.05 * D2R
    assert np.abs(err[9:12]).max() < 2e-3
    assert f.stats["position3d"].rejected == 0


@pytest.mark.parametrize("discretization", ["first_order", "van_loan"])
def test_nees_is_consistent_on_a_simulated_flight(discretization):
    """Average NEES of the 12 states over 8 noisy runs (t >= 10 s) lies in the two-sided 99 %
    chi-square interval of 12 dof per sample, widened 1.5x for the time correlation of the samples."""
    cfg = EskfConfig(accel_noise=0.02, gyro_noise=5e-4, accel_bias_noise=1e-4, earth_rotation=False,
                     gravity_mps2=9.81, discretization=discretization)
    rng = np.random.default_rng(7)
    nees = []
    for _ in range(8):
        ba = rng.normal(0.0, 0.05, 3)
        pe, ve, ae = rng.normal(0, 3.0, 3), rng.normal(0, 0.5, 3), rng.normal(0, 3.0, 3)
        P0 = np.r_[[3.0] * 3, [0.5] * 3, [3.0 * D2R] * 3, [0.05] * 3]
        _, _, hist = _fly(manoeuvring_flight(), cfg, 30.0, rng, att_err_deg=ae, pos_err=pe, vel_err=ve,
                          ba=ba, P0=P0, pos_sigma=1.0)
        nees += [e @ np.linalg.solve(P, e) for t, e, P, _ in hist if t >= 10.0]
    m = len(nees)
    lo, hi = chi2.ppf([0.005, 0.995], 12 * m) / m
    mean = float(np.mean(nees))
    assert lo / 1.5 < mean < hi * 1.5, (mean, lo, hi)
    assert 8.0 < mean < 16.0


def _F_level_stationary(g):
    """F of eq. A.4 written out for a level body at rest on a flat non-rotating Earth (C = I,
    f^n = (0, 0, -g)); constant gravity, so no vertical gravity gradient."""
    F = np.zeros((12, 12))
    F[0:3, 3:6] = np.eye(3)
    F[3, 7] = -g  # -(f x eps): f = (0,0,-g) -> dv_n' = -g eps_e, dv_e' = +g eps_n
    F[4, 6] = g
    F[3:6, 9:12] = -np.eye(3)
    return F


@pytest.mark.parametrize("discretization", ["first_order", "van_loan"])
def test_matches_filterpy_linear_kf_on_the_linearised_model(discretization):
    """Stationary level IMU with an accelerometer bias, small initial errors, noisy 3-D position
    fixes: the ESKF (nominal + fed-back error) equals a free-running INS plus a linear filterpy
    KalmanFilter on the error model, up to second-order terms: with errors ~5e-6 m they agree to
    1e-4 of the filter's sigmas (the mismatch falls >= 10x faster than the errors when they are
    scaled down: a linearisation residual, not a model difference)."""
    g, dt, n, pos_every = 9.81, 0.02, 1500, 10
    cfg = EskfConfig(accel_noise=0.02, gyro_noise=5e-4, accel_bias_noise=1e-4, earth_rotation=False,
                     gravity_mps2=g, discretization=discretization, gate_probability=1.0)
    F = _F_level_stationary(g)
    G = np.zeros((12, 9))
    G[3:6, 0:3] = -np.eye(3)
    G[6:9, 3:6] = -np.eye(3)
    G[9:12, 6:9] = np.eye(3)
    Qc = np.diag([0.02**2] * 3 + [5e-4**2] * 3 + [1e-4**2] * 3)
    if discretization == "first_order":
        Phi = np.eye(12) + F * dt
        Qk = Phi @ G @ Qc @ G.T @ Phi.T * dt
    else:  # Van Loan via one scipy expm of the block matrix
        M = np.block([[-F, G @ Qc @ G.T], [np.zeros((12, 12)), F.T]]) * dt
        E = expm(M)
        Phi = E[12:, 12:].T
        Qk = Phi @ E[:12, 12:]
    rng = np.random.default_rng(3)
    scale = 1e-5  # errors ~1e-5: the ESKF's second-order terms (~scale^2) vanish
    ba = np.array([0.4, -0.3, 0.2]) * scale
    p_err, v_err = np.array([2.0, -1.0, 0.5]) * scale, np.array([0.3, 0.2, -0.1]) * scale
    P0 = np.diag(np.r_[[2 * scale] * 3, [0.5 * scale] * 3, [1e-3] * 3, [0.5 * scale] * 3] ** 2)
    eskf = ErrorStateKF(NavState(0.0, -p_err, -v_err), P0, cfg)
    kf = KalmanFilter(dim_x=12, dim_z=3)
    kf.x = np.zeros(12)
    kf.P = P0.copy()
    kf.F, kf.Q = Phi, Qk
    kf.H = np.hstack([np.eye(3), np.zeros((3, 9))])
    sig = scale
    kf.R = np.eye(3) * sig**2
    f_meas = np.array([0.0, 0.0, -g]) + ba
    # the free-running INS nominal has the closed form p0 + v0 t + ba t^2/2 (level, constant bias)
    for k in range(n + 1):
        t = k * dt
        eskf.predict(ImuSample(t, f_meas, np.zeros(3)))
        if k:
            kf.predict()
        p_free = -p_err - v_err * t + 0.5 * ba * t**2
        if k and k % pos_every == 0:
            z = rng.normal(0.0, sig, 3)  # truth at rest at the origin
            eskf.update_position(z, sig)
            kf.update(z - p_free)
    p_free = -p_err - v_err * n * dt + 0.5 * ba * (n * dt) ** 2
    assert np.abs(p_free).max() > 5 * scale  # the free INS has drifted; the filters pull it back
    # differences measured in the filter's own standard deviations / correlation coefficients
    sd = np.sqrt(np.diag(kf.P))
    x_eskf = np.r_[eskf.x.position - p_free, eskf.x.accel_bias]
    x_lin = np.r_[kf.x[0:3], kf.x[9:12]]
    assert np.abs(x_eskf - x_lin).max() > 0.0  # two genuinely different computations
    np.testing.assert_array_less(np.abs(x_eskf - x_lin) / np.r_[sd[0:3], sd[9:12]], 1e-4)
    np.testing.assert_array_less(np.abs(eskf.P - kf.P) / np.outer(sd, sd), 1e-4)
    np.testing.assert_allclose(np.diag(eskf.P), np.diag(kf.P), rtol=1e-6)


def test_van_loan_and_first_order_agree_to_first_order_in_dt():
    """On a manoeuvring state both discretisations give the same Phi and Q_k to O(dt^2)."""
    d = manoeuvring_flight().sample(np.array([3.0]))
    cfg = EskfConfig(gyro_bias=True, earth_rotation=True)
    f = ErrorStateKF(NavState(0.0, d["position"][0], d["velocity"][0], euler_to_quat(d["euler"][0])),
                     np.ones(15), cfg)
    F, G = f.error_model(d["dcm"][0] @ d["specific_force"][0])
    out = {}
    for name in ("first_order", "van_loan"):
        f.cfg = EskfConfig(gyro_bias=True, discretization=name)
        out[name] = [f.discretize(F, G, dt) for dt in (0.02, 0.01)]
    dP = [np.abs(out["first_order"][i][0] - out["van_loan"][i][0]).max() for i in range(2)]
    dQ = [np.abs(out["first_order"][i][1] - out["van_loan"][i][1]).max() for i in range(2)]
    # Phi differs by F^2 dt^2 / 2: quartered when dt halves; Q by O(dt^2) as well
    assert dP[0] == pytest.approx(np.abs(F @ F).max() * 0.02**2 / 2, rel=0.2)
    assert 3.5 < dP[0] / dP[1] < 4.5 and 3.0 < dQ[0] / dQ[1] < 5.0
    np.testing.assert_allclose(out["van_loan"][1][0], expm(F * 0.01), atol=1e-12)


def test_taylor_expm_matches_scipy():
    from visnav.estimation.eskf import _expm

    rng = np.random.default_rng(0)
    for scale in (0.01, 0.3, 4.0):
        A = rng.normal(size=(24, 24)) * scale
        E = expm(A)
        np.testing.assert_allclose(_expm(A), E, atol=1e-13 * np.abs(E).max())


def _straight_flight():
    """Constant 10 m/s north-east at 60 m, level: no horizontal acceleration (§5.8.3)."""
    return SinusoidTrajectory(v0=(7.0, 7.0, 0.0), e0=(0.0, 0.0, 0.785))


def test_5_9_1_roll_pitch_converge_with_position_updates_only():
    """§5.9.1: initialised 5 deg off in roll, pitch and heading, 2-D position fixes (sigma 2 m,
    4 Hz, the PMF's output) and baro-free altitude from 3-D fixes during a manoeuvring flight:
    roll and pitch errors are below 0.5 deg after 60 s (thesis Fig. 5.22: 'converge rapidly')."""
    rng = np.random.default_rng(11)
    cfg = EskfConfig(accel_noise=0.02, gyro_noise=5e-4, accel_bias_noise=1e-4, earth_rotation=False,
                     gravity_mps2=9.81)
    f, d, hist = _fly(manoeuvring_flight(), cfg, 60.0, rng, att_err_deg=(5, 5, 5), pos_sigma=2.0,
                      pos_every=12, ba=(0.03, -0.02, 0.02))
    err = _euler_err_deg(hist)
    assert err[0] < 0.5 and err[1] < 0.5, err
    # the filter's own roll/pitch sigma agrees in size
    assert np.all(f.attitude_sigma[:2] < 0.5 * D2R)


def test_5_8_3_heading_weakly_observable_without_compass_converges_with_it():
    """Low-acceleration (straight) flight, 5 deg off in all three angles, position fixes only:
    roll and pitch converge but heading stays off (§5.8.3, Fig. 5.22: 5-10 deg off throughout);
    adding a 1 Hz compass (sigma 2 deg) makes the heading converge (< 1 deg)."""
    rng = np.random.default_rng(5)
    kw = dict(att_err_deg=(5, 5, 5), pos_sigma=2.0, pos_every=12, ba=(0.03, -0.02, 0.02))
    f, d, hist = _fly(_straight_flight(), CFG, 60.0, rng, **kw)
    err = _euler_err_deg(hist)
    assert err[0] < 0.5 and err[1] < 0.5, err
    assert err[2] > 3.0, err  # heading not observed
    f, d, hist = _fly(_straight_flight(), CFG, 60.0, rng, compass_every=50, **kw)
    err = _euler_err_deg(hist)
    assert err[0] < 0.5 and err[1] < 0.5 and err[2] < 1.0, err


def test_at_rest_on_the_rotating_earth_with_wgs84_gravity():
    """Earth rate, transport rate and the gravity-gradient term in use (58.4 N, 100 m): an ideal IMU
    at rest (reading -g and the Earth rate) with 1 Hz position fixes: the filter stays at rest, its
    NEES stays chi-square-sized and nothing is rejected."""
    from visnav.estimation.ins import earth_rates, gravity_ned

    lat = math.radians(58.4)
    cfg = EskfConfig(accel_noise=0.02, gyro_noise=5e-4, accel_bias_noise=1e-4, h0_m=100.0)
    w_ie, _ = earth_rates(lat, 100.0, np.zeros(3))
    g = gravity_ned(lat, 100.0)
    q = euler_to_quat([0.02, -0.01, 0.8])
    C = quat_to_dcm(q)
    f = ErrorStateKF(NavState(0.0, quat=q), np.r_[[1.0] * 3, [0.1] * 3, [0.01] * 3, [0.01] * 3], cfg)
    rng = np.random.default_rng(9)
    for k in range(3001):
        f.predict(ImuSample(0.02 * k, C.T @ -g, C.T @ w_ie))
        if k and k % 50 == 0:
            f.update_position(rng.normal(0.0, 0.5, 3), 0.5)
    e = np.r_[-f.x.position, -f.x.velocity]
    assert np.all(np.abs(e) < 4.0 * np.sqrt(np.diag(f.P)[:6]))  # within 4 sigma on every axis
    assert np.abs(f.x.velocity).max() < 0.15 and np.abs(f.x.position).max() < 0.5
    assert e @ np.linalg.solve(f.P[:6, :6], e) < chi2.ppf(0.999, 6)
    assert f.stats["position3d"].rejected == 0 and f.x.t == pytest.approx(60.0)
    assert np.abs(f.x.euler - [0.02, -0.01, 0.8]).max() < 0.2 * D2R


def test_horizontal_position_update_and_baro():
    """A 2-D fix shrinks only N/E variance; a baro altitude then fixes D."""
    s0 = NavState(0.0, np.array([10.0, -5.0, -60.0]))
    f = ErrorStateKF(s0, np.r_[[10.0] * 3, [1.0] * 3, [0.05] * 3, [0.1] * 3], CFG)
    r = f.update_position([0.0, 0.0], np.diag([1.0, 4.0]))
    assert r.accepted and r.kind == "position2d"
    P = f.P
    # scalar KF per axis: posterior variance 100*1/(100+1) and 100*4/(100+4)
    assert P[0, 0] == pytest.approx(100 / 101, rel=1e-9)
    assert P[1, 1] == pytest.approx(400 / 104, rel=1e-9)
    assert P[2, 2] == pytest.approx(100.0)
    assert f.x.position[0] == pytest.approx(10.0 - 10.0 * 100 / 101)
    r = f.update_baro(55.0, 0.5)
    assert r.accepted
    assert f.x.position[2] == pytest.approx(-60.0 + 5.0 * 100 / 100.25)


def test_gating_rejects_and_reports_outliers():
    f = ErrorStateKF(NavState(0.0), np.r_[[1.0] * 3, [0.1] * 3, [0.01] * 3, [0.01] * 3], CFG)
    r = f.update_position([100.0, 0.0, 0.0], 1.0)
    assert not r.accepted and r.nis > r.gate == pytest.approx(chi2.ppf(0.9997, 3))
    assert f.stats["position3d"].rejected == 1 and f.rejections[0][1] == "position3d"
    np.testing.assert_array_equal(f.x.position, 0.0)  # nothing injected
    r = f.update_heading(math.radians(90), math.radians(1))
    assert not r.accepted and f.stats["heading"].rejected == 1
    assert f.update_position([1.0, 0.0, 0.0], 1.0).accepted


def test_bad_samples_are_skipped_and_counted():
    f = ErrorStateKF(NavState(0.0), np.ones(12), CFG)
    assert f.predict(ImuSample(0.0, np.array([0, 0, -9.81]), np.zeros(3)))
    assert not f.predict(ImuSample(0.01, np.array([np.nan, 0, -9.81]), np.zeros(3)))
    assert not f.predict(ImuSample(0.0, np.array([0, 0, -9.81]), np.zeros(3)))  # not after the last
    assert f.predict(ImuSample(0.02, np.array([0, 0, -9.81]), np.zeros(3)))
    assert f.rejected_samples == 2
    assert not f.update_position([np.nan, 0, 0], 1.0).accepted
    with pytest.raises(ValueError, match="P0"):
        ErrorStateKF(NavState(0.0), np.ones(5), CFG)
    with pytest.raises(ValueError, match="discretization"):
        EskfConfig(discretization="rk4")


def test_heading_and_gravity_jacobians_match_finite_differences():
    rng = np.random.default_rng(2)
    e = np.array([0.3, -0.2, 2.0])
    f = ErrorStateKF(NavState(0.0, quat=euler_to_quat(e)), np.ones(12), CFG)
    C = euler_to_dcm(e)
    H = f.heading_jacobian()
    g = np.array([0.0, 0.0, 9.81])
    for _ in range(3):
        eps = rng.normal(0.0, 1e-6, 3)
        Ct = Rotation.from_rotvec(eps).as_matrix() @ C
        dyaw = wrap_angle(math.atan2(Ct[1, 0], Ct[0, 0]) - e[2])
        assert dyaw == pytest.approx(H @ eps, abs=1e-11)
        df = Ct.T @ -g - C.T @ -g
        Hg = -C.T @ np.array([[0, -g[2], g[1]], [g[2], 0, -g[0]], [-g[1], g[0], 0]])
        np.testing.assert_allclose(df, Hg @ eps, atol=1e-10)


def test_magnetometer_heading_is_tilt_compensated():
    m_ned = np.array([0.18, 0.01, 0.48])  # a northern-hemisphere field (Gauss), declination ~3 deg
    decl = math.atan2(m_ned[1], m_ned[0])
    for e in ([0.2, -0.3, 1.1], [-0.1, 0.25, -2.5]):
        m_b = euler_to_dcm(e).T @ m_ned
        assert heading_from_mag(m_b, e[0], e[1], decl) == pytest.approx(e[2], abs=1e-12)


def test_gravity_aid_levels_a_static_ahrs():
    """AHRS mode: a hovering IMU, 5 deg roll/pitch error, gravity pseudo-measurements at 10 Hz:
    tilt converges below 0.2 deg in 20 s."""
    rng = np.random.default_rng(4)
    traj = hover((0.1, -0.05, 0.5))
    dt = 0.01
    t = np.arange(0.0, 20.0, dt)
    d = traj.sample(t)
    f = ErrorStateKF(NavState(0.0, d["position"][0], quat=euler_to_quat(d["euler"][0] + [0.087, -0.087, 0])),
                     np.r_[[1.0] * 3, [1.0] * 3, [0.1] * 3, [0.02] * 3], CFG)
    for k in range(len(t)):
        a = d["specific_force"][k] + rng.normal(0, 0.05, 3)
        f.predict(ImuSample(t[k], a, d["gyro"][k] + rng.normal(0, 1e-3, 3)))
        if k % 10 == 0:
            f.update_gravity(a, 0.1)
            f.update_velocity(np.zeros(3), 0.1)
    err = np.abs(f.x.euler - d["euler"][-1])[:2]
    assert np.all(err < 0.2 * D2R), err / D2R
