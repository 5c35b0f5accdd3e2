"""The relative deck model (seed 003 eq. 2.25-2.29, 3.1-3.8, 5.12-5.17) against world-frame kinematics."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.estimation import deck as dm
from visnav.geometry.rotations import dcm_to_euler, euler_to_dcm

LIGHTS = np.array([[-0.128, 0, 0], [0, -0.102, 0], [0, 0.102, 0], [0.058, 0, 0]])
CAM = dm.CameraGeometry(rho=np.array([0.101, 0.008, 0.11]),
                        T_cam=np.array([[0, 1, 0], [-np.sin(0.76), 0, np.cos(0.76)], [np.cos(0.76), 0, np.sin(0.76)]]))
G = np.array([0.0, 0.0, 9.81])
W_H = np.array([0.3, -0.2, 0.4])  # vehicle body rates (constant)
W_D = np.array([0.1, 0.15, -0.05])  # deck body rates (constant)
A_H = np.array([0.5, -0.3, -0.8])  # vehicle acceleration (NED, constant)
V_D = np.array([0.2, 0.1, -0.05])  # deck velocity (constant: zero deck acceleration)


def world(t):
    Ch = euler_to_dcm([0.1, -0.05, 0.3]) @ Rotation.from_rotvec(W_H * t).as_matrix()  # C_h^n
    Cd = euler_to_dcm([0.05, 0.08, 0.9]) @ Rotation.from_rotvec(W_D * t).as_matrix()  # C_d^n
    ph = np.array([-1.0, 0.2, -1.2]) + np.array([0.3, 0.0, 0.1]) * t + 0.5 * A_H * t * t
    vh = np.array([0.3, 0.0, 0.1]) + A_H * t
    pd = np.array([0.1, 0.0, 0.0]) + V_D * t
    return Ch, Cd, ph, vh, pd


def truth_state(t):
    Ch, Cd, ph, vh, pd = world(t)
    r = Ch.T @ (pd - ph)
    e = dcm_to_euler(Cd.T @ Ch)  # C_h^d
    v = Ch.T @ (V_D - vh) - np.cross(W_H, r)
    return np.r_[r, e, v, W_D]


def measured_bearings(t):
    Ch, Cd, ph, _, pd = world(t)
    p_h = (pd[None, :] + LIGHTS @ Cd.T - ph) @ Ch - CAM.rho
    s = p_h @ CAM.T_cam.T
    return np.stack([np.arctan(s[:, 0] / s[:, 2]), np.arctan(s[:, 1] / s[:, 2])], axis=-1)


def test_bearings_and_rates_match_world_geometry():
    t, h = 0.7, 1e-5
    bear, rate = dm.bearings_and_rates(truth_state(t)[None, :], LIGHTS, CAM, W_H)
    np.testing.assert_allclose(bear[0], measured_bearings(t), atol=1e-12)
    fd = (measured_bearings(t + h) - measured_bearings(t - h)) / (2 * h)
    np.testing.assert_allclose(rate[0], fd, atol=1e-7)


def test_process_model_integrates_world_kinematics():
    dt, t = 1e-3, 0.0
    x = truth_state(0.0)
    for _ in range(500):
        Ch = world(t)[0]
        u = dm.ImuInput(accel=Ch.T @ (A_H - G), gyro=W_H, gyro_dot=np.zeros(3), gravity_body=Ch.T @ G)
        x = dm.process_model(x[None, :], dt, u)[0]
        t += dt
    err = dm.residual_x(x[None, :], truth_state(t)[None, :])[0]
    assert np.max(np.abs(err[:3])) < 2e-3 and np.max(np.abs(err[3:6])) < 2e-3 and np.max(np.abs(err[6:9])) < 5e-3
    # a wrong model (gravity with the wrong sign) is off by far more
    x2 = truth_state(0.0)
    t = 0.0
    for _ in range(500):
        Ch = world(t)[0]
        u = dm.ImuInput(accel=Ch.T @ (A_H - G), gyro=W_H, gyro_dot=np.zeros(3), gravity_body=-Ch.T @ G)
        x2 = dm.process_model(x2[None, :], dt, u)[0]
        t += dt
    assert np.max(np.abs(x2[:3] - truth_state(t)[:3])) > 0.1


def test_process_noise_from_eq_3_8_is_symmetric_and_grows_with_imu_noise():
    x, _ = dm.initial_state_static()
    u = dm.ImuInput(np.array([0, 0, -9.81]), np.array([0.1, 0, 0]), np.zeros(3), G)
    q1 = dm.process_noise(x, 0.01, u, np.diag([0.05**2] * 3 + [0.005**2] * 3), np.zeros((6, 6)))
    q2 = dm.process_noise(x, 0.01, u, np.diag([0.1**2] * 3 + [0.005**2] * 3), np.zeros((6, 6)))
    np.testing.assert_allclose(q1, q1.T)
    assert q2[6, 6] - q1[6, 6] == pytest.approx(0.01**2 * (0.1**2 - 0.05**2))
    assert np.all(np.linalg.eigvalsh(q1) >= -1e-18)


def test_ship_acceleration_bound_eq_3_7():
    assert dm.ship_acceleration_bound(0.1, 1.0, 0.01, 0.1) == pytest.approx(0.13 * 1.3**2)


def test_initialisation_eq_5_12_to_5_17():
    x0, P0 = dm.initial_state_static()
    np.testing.assert_array_equal(x0, [1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(np.sqrt(np.diag(P0)), np.repeat([0.5, np.radians(20), 0.05, np.radians(2)], 3))
    P = dm.initial_covariance_sea_state([0.1] * 3, [1.0] * 3, [0.2] * 3, [0.5] * 3)
    assert P[0, 0] == pytest.approx(0.005) and P[9, 9] == pytest.approx(0.04 * 0.25 / 2)


def test_batch_helpers_match_scipy_numpy_and_the_euler_rate_relation():
    """C_h^d of a batch against scipy's rotation (a peer), E(e) against body_rates_to_euler_rates (eq. 2.13 written
    component by component), the broadcasting cross product against numpy's, the angle wrap keeps the angle."""
    from visnav.estimation.deck import euler_dcm_batch, wrap_state
    from visnav.geometry.rotations import body_rates_to_euler_rates, cross

    rng = np.random.default_rng(3)
    e = rng.uniform(-3, 3, (25, 3)) * [1.0, 0.45, 1.0]
    C, E = euler_dcm_batch(e, rate=True)
    np.testing.assert_allclose(C, Rotation.from_euler("ZYX", e[:, ::-1]).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(euler_dcm_batch(e), C, atol=0)
    w = rng.normal(size=(25, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", E, w), body_rates_to_euler_rates(e, w), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(dm.euler_rate_matrix(e[7]), E[7], rtol=1e-13, atol=1e-15)  # the one-vector path
    a, b = rng.normal(size=(25, 4, 3)), rng.normal(size=(1, 4, 3))
    np.testing.assert_allclose(cross(a, b), np.cross(a, b), atol=1e-14)
    np.testing.assert_allclose(cross(b[0, 0], a), np.cross(b[0, 0], a), atol=1e-14)
    x = rng.uniform(-10, 10, (5, 12))
    w = wrap_state(x)
    np.testing.assert_array_equal(np.delete(w, [3, 5], axis=1), np.delete(x, [3, 5], axis=1))
    assert np.all(np.abs(w[:, [3, 5]]) <= np.pi)
    np.testing.assert_allclose(np.cos(w[:, [3, 5]]), np.cos(x[:, [3, 5]]), atol=1e-12)


def _imu_jacobian(x, dt, u, h=1e-4):
    """d process_model / d (accel, gyro) by central differences (12, 6): an independent F_z of eq. 3.8."""
    J = np.zeros((12, 6))
    for j in range(6):
        d = np.zeros(6)
        d[j] = h
        up = dm.ImuInput(u.accel + d[:3], u.gyro + d[3:], u.gyro_dot, u.gravity_body)
        dn = dm.ImuInput(u.accel - d[:3], u.gyro - d[3:], u.gyro_dot, u.gravity_body)
        J[:, j] = (dm.process_model(x[None], dt, up)[0] - dm.process_model(x[None], dt, dn)[0]) / (2 * h)
    return J


def test_process_noise_imu_part_is_the_numerical_jacobian_of_the_process_model():
    """Q_imu = F_z Sigma F_z^T with F_z the Jacobian of one step of eq. 3.5 / 3.2 in the IMU readings: against
    central differences of process_model over random states, rates and step lengths."""
    rng = np.random.default_rng(8)
    for _ in range(40):
        x = rng.normal(size=12) * [1, 1, 1, 0.5, 0.4, 1, 0.5, 0.5, 0.5, 0.2, 0.2, 0.2]
        u = dm.ImuInput(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
        dt = float(rng.uniform(1e-3, 0.05))
        imu = np.diag(rng.uniform(1e-4, 1e-1, 6))
        J = _imu_jacobian(x, dt, u)
        got = dm.process_noise(x, dt, u, imu, np.zeros((6, 6)))
        ref = J @ imu @ J.T  # (the model is quadratic in the readings: central differences are exact but for rounding)
        np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-8 * np.abs(ref).max())
        bad = dm.process_noise(x, dt, dm.ImuInput(u.accel, -u.gyro, u.gyro_dot, u.gravity_body), imu, np.zeros((6, 6)))
        assert not np.allclose(bad, ref, rtol=1e-3, atol=1e-8 * np.abs(ref).max())  # the check can fail


def test_process_noise_ship_part_closed_form():
    """An isotropic deck acceleration sigma^2 I (deck frame) stays isotropic in the vehicle frame whatever the
    relative attitude: Q_rr = (dt^2/2)^2 sigma^2 I, Q_vv = dt^2 sigma^2 I, Q_rv = dt^3/2 sigma^2 I; an angular one
    gives Q_ww = dt^2 sigma^2 I on the deck rates (eq. 3.8 with F_ship)."""
    rng = np.random.default_rng(4)
    x = rng.normal(size=12)
    u = dm.ImuInput(*rng.normal(size=(4, 3)))
    dt, s2 = 0.02, 0.3
    q = dm.process_noise(x, dt, u, np.zeros((6, 6)), np.diag([s2] * 3 + [0.0] * 3))
    np.testing.assert_allclose(q[dm.POS, dm.POS], (dt * dt / 2) ** 2 * s2 * np.eye(3), atol=1e-18)
    np.testing.assert_allclose(q[dm.VEL, dm.VEL], dt * dt * s2 * np.eye(3), atol=1e-15)
    np.testing.assert_allclose(q[dm.POS, dm.VEL], dt**3 / 2 * s2 * np.eye(3), atol=1e-17)
    assert np.all(q[dm.ATT] == 0) and np.all(q[dm.RATE] == 0)
    q = dm.process_noise(x, dt, u, np.zeros((6, 6)), np.diag([0.0] * 3 + [s2] * 3))
    np.testing.assert_allclose(q[dm.RATE, dm.RATE], dt * dt * s2 * np.eye(3), atol=1e-15)
    assert np.all(q[dm.POS] == 0) and np.all(q[dm.VEL] == 0)


def test_consider_parameters_give_the_bearings_of_the_perturbed_calibration():
    """With the calibration's consider parameters in the state the predicted bearings are those of the true
    system (issue 30): lights b_i + db_i, the camera turned by R(dth) (scipy's rotation; the model's small angle
    within 1e-4 rad at 1 deg), the normalised coordinates (1 + eps) s_xy / s_z + dc, and with a time offset tau
    the bearing tau earlier: b - tau db/dt; zero parameters give the thesis' model bit for bit."""
    from scipy.spatial.transform import Rotation

    lights = np.array([[-0.128, 0, 0], [0, -0.102, 0], [0, 0.102, 0], [0.058, 0, 0]])
    T = dm.camera_rotation(np.radians(43.5), np.radians(-3.4))
    cam = dm.CameraGeometry(rho=np.array([0.101, 0.008, 0.11]), T_cam=T)
    k = dm.ConsiderLayout(dm.N_STATE, len(lights))
    camk = dm.CameraGeometry(rho=cam.rho, T_cam=T, consider=k)
    rng = np.random.default_rng(5)
    x = np.r_[1.1, 0.05, 0.9, np.radians([2.0, -3.0, 10.0]), 0.1, -0.05, 0.2, np.radians([1.0, -2.0, 0.5])]
    db = 0.01 * rng.standard_normal((4, 3))
    dth = np.radians(1.0) * rng.standard_normal(3)
    eps, dc, tau = 0.01, np.array([0.004, -0.006]), 0.01
    gyro = np.array([0.1, -0.2, 0.05])
    xa = np.r_[x, db.ravel(), dth, eps, dc, tau][None, :]
    bear, rate = dm.bearings_and_rates(xa, lights, camk, gyro)
    cam_true = dm.CameraGeometry(rho=cam.rho, T_cam=Rotation.from_rotvec(dth).as_matrix() @ T)
    b0, r0 = dm.bearings_and_rates(x[None, :], lights + db, cam_true, gyro)
    s, _, _ = dm.light_vectors(x[None, :], lights + db, cam_true)
    u = (1 + eps) * s[..., :2] / s[..., 2:3] + dc
    uz = s[..., :2] / s[..., 2:3]
    want_rate = (1 + eps) * r0 * (1 + uz * uz) / (1 + u * u)  # d/dt atan(u) through u = (1 + eps) tan(b0) + dc
    np.testing.assert_allclose(rate, want_rate, atol=2e-4)
    np.testing.assert_allclose(bear, np.arctan(u) - tau * want_rate, atol=1e-4)
    assert not np.allclose(bear, b0, atol=1e-3)  # the errors matter: more than a milliradian
    zero = np.r_[x, np.zeros(k.size)][None, :]
    np.testing.assert_array_equal(dm.bearings_only(zero, lights, camk), dm.bearings_only(x[None, :], lights, cam))


def test_position_from_bearings_inverts_eq_2_25_2_26_and_its_covariance_is_the_scatter():
    x = truth_state(0.7)
    bear = measured_bearings(0.7)
    r, C = dm.position_from_bearings(bear, np.arange(4), x[3:6], LIGHTS, CAM, 1e-3)
    np.testing.assert_allclose(r, x[0:3], atol=1e-9)  # noise-free bearings: the exact position
    r3, _ = dm.position_from_bearings(bear[1:], np.arange(1, 4), x[3:6], LIGHTS, CAM, 1e-3)
    np.testing.assert_allclose(r3, x[0:3], atol=1e-9)  # any three lights
    rng = np.random.default_rng(5)
    sig = 2e-3
    draws = np.array([dm.position_from_bearings(bear + rng.normal(0, sig, bear.shape), np.arange(4), x[3:6], LIGHTS,
                                                CAM, sig)[0] for _ in range(3000)])
    _, C = dm.position_from_bearings(bear, np.arange(4), x[3:6], LIGHTS, CAM, sig)
    u = x[0:3] / np.linalg.norm(x[0:3])
    # the range's spread (the largest, along the sight line) within 10 % of the stated sigma (3000 draws: +-2.6 %)
    assert np.std(draws @ u) == pytest.approx(np.sqrt(u @ C @ u), rel=0.1)
    np.testing.assert_allclose(np.cov(draws.T), C, atol=0.15 * np.max(np.diag(C)))
    # the range follows the lights' spread in the image, hardly the attitude: 10 deg moves it by 3 % at most
    for d in ([0.0, np.radians(10), 0.0], [np.radians(10), 0.0, 0.0]):
        r_off, _ = dm.position_from_bearings(bear, np.arange(4), x[3:6] + d, LIGHTS, CAM, sig)
        assert 0.0 < abs(np.linalg.norm(r_off) / np.linalg.norm(x[0:3]) - 1.0) < 0.035


def test_locate_lights_finds_which_light_each_blob_is_and_the_position():
    x = truth_state(0.7)
    bear = measured_bearings(0.7)
    rng = np.random.default_rng(2)
    for order in (np.array([2, 0, 3, 1]), np.array([3, 1, 0])):  # shuffled, and one light missing
        idx, r, _, rms = dm.locate_lights(bear[order] + rng.normal(0, 2e-4, (len(order), 2)), x[3:6], LIGHTS, CAM,
                                          2e-4)
        np.testing.assert_array_equal(idx, order)
        np.testing.assert_allclose(r, x[0:3], atol=5e-3)
        assert rms < 5e-4
    assert dm.locate_lights(bear[:2], x[3:6], LIGHTS, CAM, 2e-4) is None  # two blobs: no position


@pytest.mark.parametrize("yaw_deg", [-135.0, -46.0, 0.0, 44.0, 91.0, 179.0])
def test_locate_level_deck_finds_the_relative_yaw_the_assignment_and_the_position(yaw_deg):
    """A level deck (relative roll and pitch = the vehicle's, here 3 and -4 deg) seen 1.4 m ahead and 1.5 m below
    from any relative yaw: the blobs, shuffled and with 0.01 deg of noise, give back the yaw within 0.3 deg (the
    grid's 10 deg refined), which light each is, and the position within 1 cm; a pose 90 deg off (the other
    side of the near-symmetric layout) reprojects far worse."""
    rng = np.random.default_rng(int(yaw_deg) + 200)
    x = np.zeros(12)
    x[0:3] = [1.4, 0.05, 1.5]
    x[3:6] = np.radians([3.0, -4.0, yaw_deg])
    order = np.array([2, 0, 3, 1])
    bear = dm.bearings_only(x[None], LIGHTS, CAM)[0].reshape(-1, 2)[order]
    bear = bear + rng.normal(0.0, np.radians(0.01), bear.shape)
    psi, idx, r, _, rms = dm.locate_level_deck(bear, x[3], x[4], LIGHTS, CAM, np.radians(0.01))
    assert np.degrees(abs(dm.residual_x(np.r_[np.zeros(5), psi], x[:6])[5])) < 0.3
    np.testing.assert_array_equal(idx, order)
    np.testing.assert_allclose(r, x[0:3], atol=0.01)
    assert rms < np.radians(0.03)
    other = dm.locate_lights(bear, x[3:6] + np.radians([0.0, 0.0, 90.0]), LIGHTS, CAM, np.radians(0.01))
    assert other is None or other[3] > 10 * rms


def test_survey_pose_covariance_is_the_scatter_of_least_squares_fits_to_a_perturbed_layout():
    """A constant survey error of each light tilts the pose a fit of their bearings gives; the linearised consider
    covariance against scipy's least_squares fitting the surveyed layout to the exact bearings of 400 perturbed ones,
    seen from 1.4 m, 45 deg down (the moving deck's hover). The attitude's spread is 1.5x the plane through the
    lights (sqrt(2 / S) sigma_s, the attitude floor) there."""
    from scipy.optimize import least_squares

    x = np.zeros(12)
    x[0:3] = [1.0, 0.0, 1.0]
    sig = 0.01
    S = dm.survey_pose_covariance(x, LIGHTS, CAM, np.arange(4), sig)
    rng = np.random.default_rng(11)
    err = []
    for _ in range(400):
        z = dm.bearings_only(x[None], LIGHTS + rng.normal(0.0, sig, LIGHTS.shape), CAM)[0]
        fit = least_squares(lambda p: dm.bearings_only(np.r_[p, x[6:]][None], LIGHTS, CAM)[0] - z, x[0:6])
        err.append(fit.x - x[0:6])
    sd = np.std(err, axis=0)
    # 400 draws: +-3.5 % on a sigma; the linearisation adds a few %
    np.testing.assert_allclose(np.sqrt(np.diag(S))[[0, 2, 3, 4, 5]], sd[[0, 2, 3, 4, 5]], rtol=0.15)
    plane = sig * np.sqrt(2.0 / ((LIGHTS - LIGHTS.mean(0)) ** 2).sum())
    assert np.sqrt(S[3, 3]) > 1.3 * plane and np.sqrt(S[4, 4]) > 1.3 * plane
    np.testing.assert_allclose(dm.survey_pose_covariance(x, LIGHTS, CAM, np.arange(4), 2 * sig), 4 * S, rtol=1e-9)
    assert dm.survey_pose_covariance(x, LIGHTS, CAM, np.arange(2), sig) is None  # two lights fix no pose


def test_rates_predicted_at_the_frame_intervals_midpoint_match_the_backward_difference_of_the_bearings():
    """A vehicle over a static deck turning with constant angular acceleration (1 rad/s + 5 rad/s^2 t about a tilted
    axis, 1 m behind and 1.2 m above the deck, no translation): the tracker's rate, the backward difference of the
    bearings over a frame interval (1/30 s), is eq. 2.27 at the interval's midpoint: the state taken back half an
    interval by the process model (``measurement_model``'s ``rates_at``) with the gyro of the midpoint. Predicted at
    the frame with its own gyro it is 0.08 rad/s off, at the midpoint 2 mrad/s (the second-order rest)."""
    axis = np.array([0.3, 1.0, 0.4]) / np.linalg.norm([0.3, 1.0, 0.4])
    w0, alpha, dt, t1 = 1.0, 5.0, 1.0 / 30.0, 0.1
    p_v = np.array([-1.0, 0.0, -1.2])  # the vehicle in the deck (= inertial) frame

    def omega(t):
        return axis * (w0 + alpha * t)

    def state(t):  # r = C_d^h (0 - p_v), C_h^d the vehicle's attitude, v = dr/dt seen from the turning vehicle
        C = Rotation.from_rotvec(axis * (w0 * t + 0.5 * alpha * t * t)).as_matrix()
        r = -C.T @ p_v
        return np.r_[r, dcm_to_euler(C), -np.cross(omega(t), r), np.zeros(3)]

    lights = np.asarray(LIGHTS, float)
    idx = np.arange(len(lights))
    measured = (dm.bearings_only(state(t1)[None], lights, CAM)
                - dm.bearings_only(state(t1 - dt)[None], lights, CAM))[0] / dt
    # the IMU input at the frame: no specific force beyond gravity's (no translation), the angular acceleration
    u = dm.ImuInput(accel=np.zeros(3), gyro=omega(t1), gyro_dot=axis * alpha, gravity_body=np.zeros(3))
    x = state(t1)[None]
    n = 2 * len(lights)
    at_frame = dm.measurement_model(x, lights, CAM, omega(t1), idx, idx)[0, n:]
    at_mid = dm.measurement_model(x, lights, CAM, omega(t1 - dt / 2), idx, idx,
                                  rates_at=lambda s: dm.process_model(s, -dt / 2, u))[0, n:]
    assert np.abs(at_frame - measured).max() > 0.05
    assert np.abs(at_mid - measured).max() < 0.004
    # the bearings are the frame's either way
    np.testing.assert_array_equal(dm.measurement_model(x, lights, CAM, omega(t1), idx, idx[:0])[0],
                                  dm.measurement_model(x, lights, CAM, omega(t1), idx, idx[:0], rates_at=np.negative)[0])


def test_the_deck_oscillator_pulls_the_rates_towards_level_by_its_frequency_squared():
    """``process_model``'s ``deck_omega2``: over a deck rolled 4 deg and pitched -3 deg (the vehicle level: gravity
    straight down in its frame) one step changes p_d, q_d by -Omega^2 phi_d dt, -Omega^2 theta_d dt and leaves r_d and
    every other state as the constant-rate model has them; ``ship_oscillator`` gives the Stewart preset's roll and
    pitch frequencies squared (0.9^2, 0.7^2) and their restoring term's bound ((w + 3 sigma_w)^2 - w^2)(A + 3 sigma_A)
    as eq. 3.7's white acceleration (yaw: eq. 3.7's own)."""
    phi, theta = np.radians(4.0), np.radians(-3.0)
    C_hd = Rotation.from_euler("ZYX", [0.0, theta, phi]).as_matrix()  # the deck's attitude, the vehicle level
    x = np.r_[1.0, 0.0, 1.2, dcm_to_euler(C_hd.T), 0.1, -0.05, 0.02, 0.03, -0.02, 0.01][None]
    u = dm.ImuInput(accel=np.array([0.0, 0.0, -9.81]), gyro=np.array([0.02, -0.01, 0.03]), gyro_dot=np.zeros(3),
                    gravity_body=np.array([0.0, 0.0, 9.81]))
    w2 = np.array([0.81, 0.49, 0.0])
    dt = 0.01
    a, b = dm.process_model(x, dt, u), dm.process_model(x, dt, u, deck_omega2=w2)
    np.testing.assert_allclose(b[0, 9:12] - a[0, 9:12], -dt * w2 * [phi, theta, 0.0], rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(a[0, :9], b[0, :9])
    omega2, var = dm.ship_oscillator("stewart", 1.0, 1.0, dt)
    np.testing.assert_allclose(omega2, [0.81, 0.49, 0.0], rtol=1e-12)
    A, W, sA, sW = dm.SEA_STATES["stewart"]
    roll = ((W[3] + 3 * sW[3]) ** 2 - W[3] ** 2) * (A[3] + 3 * sA[3])
    assert var[0] == pytest.approx(roll**2 / W[3] / dt, rel=1e-12)
    assert var[2] == pytest.approx(dm.ship_process_noise("stewart", 1.0, 1.0, dt)[5], rel=1e-12)
    assert roll < dm.ship_acceleration_bound(A[3], W[3], sA[3], sW[3]) / 2  # (5.7 against 13 deg/s^2)
