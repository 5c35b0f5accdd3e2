"""The deck navigator's handling of bad input: NaN bearings, empty frames, IMU out of order."""

import numpy as np

from visnav.estimation import deck as dm
from visnav.navigation.deck import DeckNavigator
from visnav.world.deck import LEDS_EQ_5_10

CAM = dm.CameraGeometry(rho=np.array([0.101, 0.008, 0.11]),
                        T_cam=np.array([[0, 1, 0], [-np.sin(0.76), 0, np.cos(0.76)], [np.cos(0.76), 0, np.sin(0.76)]]))
G = np.array([0.0, 0.0, 9.81])


def _nav():
    x0, P0 = dm.initial_state_static()
    return DeckNavigator(LEDS_EQ_5_10, CAM, x0, P0, np.eye(6) * 1e-4, np.eye(6) * 1e-4, np.radians(2), np.radians(2))


def test_out_of_order_and_nan_imu_samples_are_dropped_and_counted():
    nav = _nav()
    acc = np.array([0, 0, -9.81])
    assert nav.imu(0.00, acc, np.zeros(3), G)
    assert nav.imu(0.01, acc, np.zeros(3), G)
    x = nav.x.copy()
    assert not nav.imu(0.005, acc, np.zeros(3), G)
    assert not nav.imu(0.01, acc, np.zeros(3), G)
    assert not nav.imu(0.02, [np.nan, 0, 0], np.zeros(3), G)
    np.testing.assert_array_equal(nav.x, x)
    assert nav.stats.imu_dropped == 3 and nav.stats.imu_samples == 2


def test_empty_frame_and_nan_bearings_change_nothing_bad():
    nav = _nav()
    nav.imu(0.0, [0, 0, -9.81], np.zeros(3), G)
    x, P = nav.x.copy(), nav.P.copy()
    assert nav.camera(np.zeros((0, 2)), np.zeros((0, 2))) == 0
    assert nav.camera(np.full((3, 2), np.nan), np.full((3, 2), np.nan)) == 0
    np.testing.assert_array_equal(nav.x, x)
    np.testing.assert_array_equal(nav.P, P)
    assert nav.stats.empty_frames == 2


def test_true_bearings_with_a_nan_row_and_a_distractor_converge():
    nav = _nav()
    truth = np.r_[1.3, 0.1, 1.1, 0.0, 0.0, 0.3, np.zeros(6)]
    bear, rate = dm.bearings_and_rates(truth[None], LEDS_EQ_5_10, CAM, np.zeros(3))
    for k in range(60):
        nav.imu(k * 0.03, [0, 0, -9.81], np.zeros(3), G)
        b = np.vstack([bear[0], [[np.nan, 0.1]], [[0.5, -0.4]]])  # a NaN row and a bright non-light
        r = np.vstack([rate[0], [[np.nan, np.nan]], [[np.nan, np.nan]]])
        nav.camera(b, r)
    assert np.linalg.norm(nav.x[:3] - truth[:3]) < 0.05
    assert abs(nav.x[5] - 0.3) < np.radians(3)
    assert nav.stats.blobs_rejected > 0 and nav.stats.lights_used_last == 4


def test_gyro_noise_telescopes_into_the_velocity_and_covariance_holds_it():
    # vehicle and deck at rest: the only velocity error comes from the numerical angular acceleration,
    # sum (n_k - n_k-1) x r = (n_N - n_0) x r, bounded (not a random walk); covariance() carries the
    # newest sample's part, [r]x Sigma_g [r]x^T, on top of P
    x0, P0 = dm.initial_state_static()
    sg = 0.003
    imu_cov = np.diag([0.0] * 3 + [sg**2] * 3)
    nav = DeckNavigator(LEDS_EQ_5_10, CAM, x0, P0, imu_cov, np.zeros((6, 6)), np.radians(2), np.radians(2))
    rng = np.random.default_rng(0)
    n = sg * rng.standard_normal((50, 3))
    for k in range(50):
        nav.imu(0.01 * k, -G, n[k], G)
    r = nav.x[0:3]
    np.testing.assert_allclose(nav.x[6:9] - x0[6:9], -np.cross(n[-1] - n[0], r), atol=2e-4)
    assert np.linalg.norm(np.cross(n[-1] - n[0], r)) > 2e-3  # the effect is ten times the tolerance
    S = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    extra = nav.covariance() - nav.P
    np.testing.assert_allclose(extra[6:9, 6:9], S @ S.T * sg**2, rtol=1e-12)
    extra[6:9, 6:9] = 0.0
    np.testing.assert_array_equal(extra, 0.0)
