"""Touchdown acceleration, deck attitude prediction and tau-gap trajectories (seed 003 eq. 4.1-4.24)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.geometry.rotations import euler_to_dcm
from visnav.guidance.deck_approach import (StraightApproach, TauGapApproach, predict_deck_attitude,
                                           touchdown_acceleration)

G = np.array([0.0, 0.0, 9.81])


def test_level_deck_lands_vertically_at_a_td():
    a, lam, gam = touchdown_acceleration(np.array([0, 0, -1.0]), 2.5)
    np.testing.assert_allclose(a, [0, 0, -2.5], atol=1e-12)
    assert gam == pytest.approx(0.0)


@pytest.mark.parametrize("euler_deg", [(5, 0, 0), (0, -8, 0), (6, 7, 30), (-10, 9, 0)])
def test_specific_force_is_along_the_deck_normal(euler_deg):
    C = euler_to_dcm(np.radians(euler_deg))
    n_up = -C[:, 2]
    a, lam, gam = touchdown_acceleration(n_up, 2.5)
    f = a - G  # specific force: thrust along the vehicle's -z
    np.testing.assert_allclose(f / np.linalg.norm(f), n_up, atol=1e-12)  # attitudes match (eq. 4.2)
    assert np.linalg.norm(a) == pytest.approx(2.5)  # eq. 4.3
    assert a[2] < 0  # decelerating the descent
    # small-angle check of eq. 4.10: lateral acceleration / thrust = tilt
    tilt = np.arccos(-n_up[2])
    assert np.hypot(a[0], a[1]) / np.linalg.norm(f) == pytest.approx(np.sin(tilt), rel=1e-9)


def test_too_steep_deck_is_refused():
    n_up = -euler_to_dcm(np.radians([16.0, 0, 0]))[:, 2]
    with pytest.raises(ValueError, match="tilt"):
        touchdown_acceleration(n_up, 2.5)
    touchdown_acceleration(-euler_to_dcm(np.radians([14.5, 0, 0]))[:, 2], 2.5)  # 14.8 deg is the limit


def test_euler_rodrigues_prediction_matches_scipy():
    C0 = euler_to_dcm([0.1, -0.05, 0.3])
    w = np.array([0.2, -0.1, 0.05])
    got = predict_deck_attitude(C0, w, 1.7)
    np.testing.assert_allclose(got, C0 @ Rotation.from_rotvec(w * 1.7).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(predict_deck_attitude(C0, np.zeros(3), 2.0), C0)


def test_tau_gap_trajectory_boundary_conditions_and_derivatives():
    start = np.array([-1.0, 0.3, -1.0])
    a_td, _, _ = touchdown_acceleration(-euler_to_dcm(np.radians([4, -6, 0]))[:, 2], 2.5)
    tr = TauGapApproach(start, a_td, k_rho=0.5, k_ab=0.45)
    p0, v0, acc0 = tr.desired(0.0)
    np.testing.assert_allclose(p0, start, atol=1e-12)
    np.testing.assert_allclose(v0, 0, atol=1e-12)
    np.testing.assert_allclose(acc0, 0, atol=1e-12)
    pT, vT, aT = tr.desired(tr.T)
    np.testing.assert_allclose(pT, 0, atol=1e-12)
    np.testing.assert_allclose(vT, 0, atol=1e-12)
    np.testing.assert_allclose(aT, a_td, atol=1e-9)  # touchdown acceleration along the terminal path (eq. 2.46)
    h = 1e-5
    for t in np.linspace(0.1, tr.T - 0.1, 7):
        pm, vm, _ = tr.desired(t - h)
        pp, vp, _ = tr.desired(t + h)
        _, v, a = tr.desired(t)
        np.testing.assert_allclose(v, (pp - pm) / (2 * h), atol=1e-6)
        np.testing.assert_allclose(a, (vp - vm) / (2 * h), atol=1e-5)


def test_straight_approach_is_a_line():
    s = StraightApproach(np.array([-1.2, 0.4, -1.5]), 15.0, 0.3)
    for t in (0.0, 3.0, 9.0, 14.0):
        p, v, _ = s.desired(t)
        assert np.linalg.norm(np.cross(p, [-1.2, 0.4, -1.5])) < 1e-12
    np.testing.assert_allclose(s.desired(15.0)[0], 0.0)


def test_rot_z_with_math_trig_equals_numpys_bit_for_bit():
    """rot_z takes math's cos / sin of the yaw where it took numpy's (of a Python float): the same matrix."""
    from visnav.guidance.deck_approach import rot_z

    def reference(a):  # rot_z before speed round 5
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    rng = np.random.default_rng(13)
    yaws = [0.0, -0.0, np.pi, -np.pi, 1e-300] + rng.uniform(-4, 4, 20000).tolist() + rng.normal(0, 1e3, 2000).tolist()
    for a in yaws:
        assert np.array_equal(rot_z(a).view(np.int64), reference(a).view(np.int64))


@pytest.mark.parametrize("euler_deg,along", [((0, 0, 0), (-1.0, 0.0, -1.0)), ((4, -6, 20), (-0.5, 0.3, -1.0)),
                                             ((-7, 3, 0), (0.2, -0.9, -0.6))])
def test_the_final_path_meets_the_deck_plane_at_the_landing_point(euler_deg, along):
    """With the overshoot along the final path, the line through the target along that path crosses the plane the
    gear must meet (``gear_offset`` above the deck along its normal) exactly above the landing point; with the
    overshoot along the normal (the thesis' static approach) it crosses it ``overshoot tan(gamma)`` short."""
    from visnav.guidance.deck_approach import touchdown_target

    C = euler_to_dcm(np.radians(euler_deg))
    lp, gear, over = np.array([-0.2, 0.05, 0.0]), 0.17, 0.04
    contact = C @ lp + gear * (-C[:, 2])  # psi_d = 0: the level-deck frame is the deck's heading-free frame
    u = np.asarray(along) / np.linalg.norm(along)
    c, n_up = touchdown_target(C, np.zeros(3), 0.0, 0.0, lp, gear, over, False, along=u)
    np.testing.assert_allclose(n_up, -C[:, 2], atol=1e-12)
    assert n_up @ (c - contact) == pytest.approx(-over, abs=1e-12)  # overshoot below the plane
    s = (n_up @ (contact - c)) / (n_up @ u)  # where the line c + s u meets the plane
    np.testing.assert_allclose(c + s * u, contact, atol=1e-12)
    c_n, _ = touchdown_target(C, np.zeros(3), 0.0, 0.0, lp, gear, over, False)  # along the normal
    s_n = (n_up @ (contact - c_n)) / (n_up @ u)
    gamma = np.arccos(n_up @ u)
    assert np.linalg.norm(c_n + s_n * u - contact) == pytest.approx(over * np.tan(gamma), rel=1e-9)


def test_a_nearly_level_final_path_moves_the_target_at_most_overshoot_over_cos_60():
    from visnav.guidance.deck_approach import MAX_ALONG_DEG, touchdown_target

    C = np.eye(3)
    c, n_up = touchdown_target(C, np.zeros(3), 0.0, 0.0, np.zeros(3), 0.17, 0.04, False,
                               along=np.array([-1.0, 0.0, -0.01]))
    contact = np.array([0.0, 0.0, -0.17])
    assert np.linalg.norm(c - contact) == pytest.approx(0.04 / np.cos(np.radians(MAX_ALONG_DEG)), rel=1e-12)
