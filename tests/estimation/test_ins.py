"""Strapdown mechanization (seed 002 eq. A.1) against closed forms and scipy."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.estimation.ins import (
    OMEGA_EARTH,
    NavState,
    StrapdownINS,
    dcm_to_quat,
    earth_rates,
    euler_to_quat,
    gravity_ned,
    integrate_gyro,
    quat_from_rotvec,
    quat_mult,
    quat_to_dcm,
)
from visnav.geometry.rotations import euler_to_dcm
from visnav.sim.trajectory import manoeuvring_flight


def _scipy_q(q):  # scalar-first -> scipy Rotation
    q = np.asarray(q)
    return Rotation.from_quat(np.r_[q[1:], q[0]])


def test_quaternion_algebra_matches_scipy():
    rng = np.random.default_rng(0)
    a, b = Rotation.random(2, random_state=1)
    qa = dcm_to_quat(a.as_matrix())
    qb = dcm_to_quat(b.as_matrix())
    np.testing.assert_allclose(quat_to_dcm(quat_mult(qa, qb)), (a * b).as_matrix(), atol=1e-12)
    rv = rng.normal(size=(5, 3))
    np.testing.assert_allclose(quat_to_dcm(quat_from_rotvec(rv)), Rotation.from_rotvec(rv).as_matrix(),
                               atol=1e-12)
    e = np.array([0.3, -0.4, 2.5])
    np.testing.assert_allclose(quat_to_dcm(euler_to_quat(e)), euler_to_dcm(e), atol=1e-12)


def test_gravity_model_closed_form_values():
    # WGS-84 normal gravity: 9.7803253 at the equator, 9.8321849 at the poles (Somigliana)
    assert gravity_ned(0.0, 0.0)[2] == pytest.approx(9.7803253359, abs=1e-9)
    assert gravity_ned(math.radians(89.9999), 0.0)[2] == pytest.approx(9.8321849378, abs=1e-7)
    # free-air gradient about -3.086e-6 s^-2
    g45 = gravity_ned(math.radians(45), 0.0)[2]
    assert (gravity_ned(math.radians(45), 1000.0)[2] - g45) / 1000.0 == pytest.approx(-3.086e-6, rel=2e-3)


def test_earth_and_transport_rates():
    lat = math.radians(58.4)
    w_ie, w_en = earth_rates(lat, 0.0, [10.0, 0.0, 0.0])
    assert np.linalg.norm(w_ie) == pytest.approx(OMEGA_EARTH)
    assert w_ie[1] == 0.0 and w_ie[2] < 0  # NED: down component negative in the north
    assert w_en[1] == pytest.approx(-10.0 / 6.38e6, rel=2e-2)


def test_stationary_level_imu_stays_put_with_earth_rotation():
    """A level IMU at rest on the rotating Earth reads -g and the Earth rate: nothing moves."""
    lat0 = 58.4
    ins = StrapdownINS(lat0_deg=lat0, h0_m=100.0, earth_rotation=True)
    yaw = 0.7
    q0 = euler_to_quat([0.0, 0.0, yaw])
    C = quat_to_dcm(q0)
    w_ie, _ = earth_rates(math.radians(lat0), 100.0, np.zeros(3))
    g = gravity_ned(math.radians(lat0), 100.0)
    n = 6000  # 60 s at 100 Hz
    t = np.arange(n) * 0.01
    out = ins.run(NavState(0.0, quat=q0), t, np.tile(C.T @ -g, (n, 1)), np.tile(C.T @ w_ie, (n, 1)))
    assert np.abs(out["position"]).max() < 1e-6
    assert np.abs(out["velocity"]).max() < 1e-7
    assert np.abs(out["euler"] - [0.0, 0.0, yaw]).max() < 1e-9


def test_earth_rate_is_felt_when_the_gyro_ignores_it():
    """A gyro reading zero on the rotating Earth means the body is inertially fixed: seen from
    NED it turns by -w_ie^n T (closed form C(T) = exp(-[w_ie x] T) C0); after 1 h at 58.4 N that
    is 15 deg about the Earth axis, 12.8 deg of heading."""
    lat0 = 58.4
    ins = StrapdownINS(lat0_deg=lat0, earth_rotation=True)
    s = NavState(0.0)
    g = gravity_ned(math.radians(lat0), 0.0)
    for _ in range(60):  # 60 steps of 60 s; the exponential map makes step size irrelevant
        s = ins.propagate(s, quat_to_dcm(s.quat).T @ -g, np.zeros(3), 60.0)
        s.position[:] = 0.0
        s.velocity[:] = 0.0
    w_ie, _ = earth_rates(math.radians(lat0), 0.0, np.zeros(3))
    np.testing.assert_allclose(quat_to_dcm(s.quat), Rotation.from_rotvec(-w_ie * 3600.0).as_matrix(),
                               atol=1e-12)
    assert s.euler[2] == pytest.approx(math.radians(12.8), abs=math.radians(0.1))


def test_constant_rotation_integrates_to_closed_form_quaternion():
    w = np.array([0.3, -0.2, 0.5])
    q0 = euler_to_quat([0.1, 0.2, -0.3])
    T, dt = 10.0, 0.01
    n = int(round(T / dt))
    t = np.arange(n + 1) * dt
    ins = StrapdownINS(earth_rotation=False, gravity=9.81)
    out = ins.run(NavState(0.0, quat=q0), t, np.zeros((n + 1, 3)), np.tile(w, (n + 1, 1)))
    exact = _scipy_q(q0) * Rotation.from_rotvec(w * T)
    np.testing.assert_allclose(quat_to_dcm(out["quat"][-1]), exact.as_matrix(), atol=1e-10)
    # the vectorised helper agrees
    q_hist = integrate_gyro(q0, np.tile(w, (n, 1)), dt)
    np.testing.assert_allclose(quat_to_dcm(q_hist[-1]), exact.as_matrix(), atol=1e-10)


def test_constant_acceleration_integrates_to_closed_form_position():
    """Tilted body, constant NED acceleration a: p = p0 + v0 t + a t^2 / 2 exactly."""
    a = np.array([0.8, -0.5, -0.3])
    g = 9.81
    e = np.array([0.2, -0.1, 1.0])
    C = euler_to_dcm(e)
    f_b = C.T @ (a - [0.0, 0.0, g])
    p0, v0 = np.array([1.0, 2.0, -50.0]), np.array([3.0, -1.0, 0.5])
    dt, n = 0.02, 1500
    t = np.arange(n + 1) * dt
    ins = StrapdownINS(earth_rotation=False, gravity=g)
    out = ins.run(NavState(0.0, p0, v0, euler_to_quat(e)), t, np.tile(f_b, (n + 1, 1)), np.zeros((n + 1, 3)))
    T = t[-1]
    np.testing.assert_allclose(out["position"][-1], p0 + v0 * T + 0.5 * a * T**2, atol=1e-8)
    np.testing.assert_allclose(out["velocity"][-1], v0 + a * T, atol=1e-10)


def test_manoeuvring_flight_free_inertial_is_second_order_accurate():
    """Exact IMU of an analytic flight: free INS error falls ~4x when the rate doubles."""
    tr = manoeuvring_flight()
    ins = StrapdownINS(earth_rotation=False, gravity=tr.g)
    errs = []
    for dt in (0.02, 0.01):
        t = np.arange(0.0, 20.0 + dt / 2, dt)
        d = tr.sample(t)
        s0 = NavState(0.0, d["position"][0], d["velocity"][0], euler_to_quat(d["euler"][0]))
        out = ins.run(s0, t, d["specific_force"], d["gyro"])
        errs.append(np.linalg.norm(out["position"][-1] - d["position"][-1]))
    assert errs[0] < 0.01
    assert 3.0 < errs[0] / errs[1] < 5.0


def test_bad_imu_values_are_refused():
    ins = StrapdownINS(earth_rotation=False)
    with pytest.raises(ValueError, match="accel"):
        ins.propagate(NavState(0.0), [np.nan, 0, 0], [0, 0, 0], 0.01)
    with pytest.raises(ValueError, match="dt"):
        ins.propagate(NavState(0.0), [0, 0, -9.8], [0, 0, 0], 0.0)


def test_quat_to_euler_of_one_quaternion_matches_vectorised_dcm_to_euler():
    """quat_to_euler of one quaternion gives dcm_to_euler's angles of the batch,
    including gimbal lock (pitch = +-90 deg) and yaw = pi (wrapped into (-pi, pi])."""
    from visnav.estimation.ins import quat_to_dcm, quat_to_euler
    from visnav.geometry.rotations import dcm_to_euler

    rng = np.random.default_rng(7)
    qs = list(rng.normal(size=(200, 4)))
    qs += [np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0]),  # pitch +90
           np.array([np.cos(np.pi / 4), 0.3, -np.sin(np.pi / 4), 0.1]),  # near -90
           np.array([0.0, 0.0, 0.0, 1.0])]  # yaw = pi
    ref = dcm_to_euler(quat_to_dcm(np.array(qs)))
    got = np.array([quat_to_euler(q) for q in qs])
    np.testing.assert_allclose(got, ref, atol=1e-12)
    assert got[-1, 2] == pytest.approx(np.pi)


def test_flat_earth_path_equals_the_general_path_with_zero_rates():
    """``earth_rotation=False`` skips the Earth-rate terms (attitude rate C^T w_in, Coriolis) and the ESKF
    leaves their F blocks at the template's zeros: the same numbers as the general path fed zero rates,
    state and covariance, over 200 noisy steps."""
    from visnav.estimation.eskf import EskfConfig, ErrorStateKF
    from visnav.estimation.ins import NavState, StrapdownINS, euler_to_quat

    class ZeroRates(StrapdownINS):  # the general path (earth_rotation on) with both rates zero
        def rates_at(self, position, velocity):
            return np.zeros(3), np.zeros(3)

    rng = np.random.default_rng(4)
    s0 = NavState(0.0, np.array([3.0, -2.0, -60.0]), np.array([8.0, 3.0, 0.5]), euler_to_quat([0.05, -0.03, 1.0]))
    cfg = EskfConfig(gravity_mps2=9.81, earth_rotation=False)
    fast = ErrorStateKF(s0, np.linspace(0.1, 1.0, 12), cfg)
    ref = ErrorStateKF(s0, np.linspace(0.1, 1.0, 12), cfg)
    ref.ins = ZeroRates(cfg.lat0_deg, cfg.h0_m, True, 9.81)
    for _ in range(200):
        acc = np.array([0.3, -0.2, -9.7]) + 0.2 * rng.standard_normal(3)
        gyr = np.array([0.01, -0.02, 0.03]) + 0.05 * rng.standard_normal(3)
        fast.propagate(acc, gyr, 0.02)
        ref.propagate(acc, gyr, 0.02)
    for k in ("position", "velocity", "quat"):
        np.testing.assert_allclose(getattr(fast.x, k), getattr(ref.x, k), rtol=1e-13, atol=1e-13, err_msg=k)
    np.testing.assert_allclose(fast.P, ref.P, rtol=1e-12, atol=1e-18)
    assert not np.array_equal(fast.x.position, s0.position)  # it moved


@pytest.mark.parametrize("angle", [0.0, 1e-13, 1e-7, 1e-3, 0.5, 2.0, 3.1, math.pi - 1e-9])
def test_rotvec_from_dcm_matches_scipy(angle):
    from visnav.estimation.ins import rotvec_from_dcm

    rng = np.random.default_rng(int(angle * 1e6) % 1000)
    for _ in range(200):
        axis = rng.normal(size=3)
        rv = axis / np.linalg.norm(axis) * angle
        C = Rotation.from_rotvec(rv).as_matrix()
        got = rotvec_from_dcm(C)
        np.testing.assert_allclose(got, Rotation.from_matrix(C).as_rotvec(), rtol=0, atol=2e-15 + 1e-15 * angle)
        if angle < 3.0:  # (at pi the sign of the axis is a convention)
            np.testing.assert_allclose(got, rv, rtol=0, atol=1e-14)
    # a product of rotations slightly off orthogonality (rounding) still gives its rotation
    C = np.eye(3)
    for _ in range(1000):
        C = C @ Rotation.from_rotvec(rng.normal(size=3) * 0.01).as_matrix()
    np.testing.assert_allclose(rotvec_from_dcm(C), Rotation.from_matrix(C).as_rotvec(), atol=1e-12)


def test_one_quaternion_and_batches_agree_with_scipy_at_every_angle_scale():
    """quat_mult / quat_from_rotvec / quat_to_dcm / quat_to_euler of one quaternion and of a batch against
    scipy's ``Rotation`` (composition, from_rotvec, as_matrix, ZYX angles), rotation vectors from 1e-12 rad
    (below any series switch) to 10 rad, quaternions not normalised."""
    from visnav.estimation.ins import quat_from_rotvec, quat_mult, quat_to_dcm, quat_to_euler

    def R(q):  # scipy's Rotation of a scalar-first quaternion
        return Rotation.from_quat(np.concatenate([q[..., 1:], q[..., :1]], axis=-1))

    rng = np.random.default_rng(4)
    p, q = rng.normal(size=(2, 200, 4))
    pq = quat_mult(p, q)
    np.testing.assert_allclose(np.array([quat_mult(a, b) for a, b in zip(p, q)]), pq, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(R(pq).as_matrix(), (R(p) * R(q)).as_matrix(), atol=1e-13)
    rv = rng.normal(size=(200, 3)) * np.repeat([1e-12, 1e-9, 1e-3, 1.0, 10.0], 40)[:, None]
    got = quat_from_rotvec(rv)
    np.testing.assert_allclose(np.array([quat_from_rotvec(v) for v in rv]), got, rtol=1e-15, atol=1e-16)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(R(got).as_matrix(), Rotation.from_rotvec(rv).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(got[:40, 1:], 0.5 * rv[:40], rtol=1e-15)  # q -> (1, θ/2) as θ -> 0
    C = quat_to_dcm(q)
    np.testing.assert_allclose(C, R(q).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(np.array([quat_to_dcm(x) for x in q]), C, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(np.array([quat_to_euler(x) for x in q]),
                               R(q).as_euler("ZYX")[:, ::-1], atol=1e-12)
    with pytest.raises(ValueError, match="quaternion"):
        quat_to_dcm(np.zeros(4))
