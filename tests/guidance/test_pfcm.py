"""PFCM trajectory generator (seed 002 §4.3): control point, velocity profile limits, feed-forward."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize

from visnav.guidance.hermite import HermitePath, helix_waypoints
from visnav.guidance.pfcm import (
    PathReference,
    PfcmGuidance,
    PfcmLimits,
    PointHold,
    brake_speed,
    descent_speed_limit,
    hover_induced_velocity,
    kinematic_speed_limits,
    max_path_speed,
    nz_max_for_mass,
)
from visnav.measurements import NavEstimate

G = 9.81
PHI, R_MAX, THETA = math.radians(15), math.radians(40), math.radians(15)


def _nav(t, p, v=(0, 0, 0), yaw=0.0):
    return NavEstimate(t=t, position=np.asarray(p, float), velocity=np.asarray(v, float),
                       attitude=np.array([0.0, 0.0, yaw]))


def _fly(g: PfcmGuidance, duration: float, dt: float = 0.02, lag: float = 0.0):
    """A kinematic follower: the helicopter sits on the control point (minus ``lag`` m along the
    path) and moves at v_target along the tangent; heading along the path. Returns the outputs."""
    p = g.path.start.copy()
    v = np.zeros(3)
    out = []
    yaw = math.atan2(*g.path.segments[0].tangent(0.0)[[1, 0]])
    for k in range(int(duration / dt)):
        r = g.step(k * dt, _nav(k * dt, p, v, yaw))
        out.append(r)
        v = r.velocity
        p = r.position - lag * r.tangent + v * dt
        yaw = r.yaw
        if r.finished:
            break
    return out


def test_fig_4_6_speed_limits_closed_forms_and_u3_tightest():
    R = np.array([10.0, 20.0, 50.0, 100.0, 200.0])
    u = kinematic_speed_limits(R, R_MAX, PHI, THETA, 1.1)
    np.testing.assert_allclose(u["u1"], R * R_MAX)
    np.testing.assert_allclose(u["u3"], np.sqrt(PHI * G * R))
    np.testing.assert_allclose(u["u4"], (0.1 * G * G * R * R) ** 0.25)
    np.testing.assert_allclose(u["u2"], G * THETA / 0.025)  # 103 m/s: never the limit (§4.3.3)
    # Fig. 4.6: for the 80 kg R-MAX the roll limit u3 is the tightest (u3 < u4 since phi_max < sqrt(0.1))
    assert np.all(u["u3"] < u["u4"]) and np.all(u["u3"] < u["u1"])
    np.testing.assert_allclose(max_path_speed(R, R_MAX, PHI, THETA, 1.1), u["u3"])
    # the yaw-rate limit takes over below R* = phi_max g / r_max^2 = 5.27 m
    r_star = PHI * G / R_MAX**2
    u_lo = kinematic_speed_limits(0.9 * r_star, R_MAX, PHI, THETA, 1.1)
    assert u_lo["u1"] < u_lo["u3"]
    assert max_path_speed(np.inf, R_MAX, PHI, THETA, 1.1) == np.inf


def test_heavier_rmax_makes_the_load_factor_the_limit():
    nz = nz_max_for_mass(90.0)  # 94 kg max take-off weight: Nz_max = 1.044 < 1 + phi_max^2
    assert nz == pytest.approx(94 / 90)
    u = kinematic_speed_limits(30.0, R_MAX, PHI, THETA, nz)
    assert u["u4"] < u["u3"]
    assert max_path_speed(30.0, R_MAX, PHI, THETA, nz) == pytest.approx(u["u4"])
    with pytest.raises(ValueError, match="nz_max must be > 1"):
        kinematic_speed_limits(30.0, R_MAX, PHI, THETA, 1.0)


def test_hover_induced_velocity_and_vrs_descent_limits():
    vi = hover_induced_velocity(80.0, 3.115)
    assert vi == pytest.approx(6.37, rel=0.02)  # §4.3.3 quotes 6.37 m/s
    # the imperial form of eq. 4.22: 60 sqrt(DL / 2 rho) ft/min, DL in lb/ft², rho in slug/ft³
    dl = 80 / 0.45359237 / (math.pi * (3.115 / 0.3048) ** 2 / 4)
    assert vi == pytest.approx(60 * math.sqrt(dl / (2 * 0.002377)) * 0.3048 / 60, rel=1e-3)
    tau = lambda gam: np.array([math.cos(math.radians(gam)), 0.0, math.sin(math.radians(gam))])  # noqa: E731
    assert descent_speed_limit(tau(45)) == pytest.approx(1.5 / math.sin(math.radians(45)))
    assert descent_speed_limit(tau(30)) == pytest.approx(1.5 / 0.5)
    assert descent_speed_limit(tau(20)) == pytest.approx(3.0 / math.sin(math.radians(20)))
    assert descent_speed_limit(tau(90)) == pytest.approx(1.5)
    assert descent_speed_limit(tau(0)) == np.inf and descent_speed_limit(tau(-20)) == np.inf


def test_brake_speed_formula():
    assert brake_speed(10.0, 1.2, 2.0) == pytest.approx(math.sqrt(2 * 10 * 1.2 + 4))
    np.testing.assert_allclose(brake_speed(np.array([0.0, 41.6667]), 1.2), [0.0, 10.0], rtol=1e-5)


def test_control_point_converges_to_the_orthogonal_projection():
    P, T = helix_waypoints((0, 30), 30.0, -math.pi / 2, math.pi, -20.0, -25.0, 2)
    path = HermitePath.from_waypoints(P, T)
    sg = path.segments[0]
    x = np.array([18.0, 9.0, -23.5])  # off the path, inside the turn
    ref = optimize.minimize_scalar(lambda s: np.sum((sg.position(s) - x) ** 2), bounds=(0, 1), method="bounded",
                                   options={"xatol": 1e-10}).x
    g = PfcmGuidance(path, PfcmLimits(v_cruise=5.0), iterations=30)
    g.s = 0.2
    _, s = g.update_control_point(x)
    assert s == pytest.approx(ref, abs=1e-7)
    e = sg.position(s) - x
    assert abs(e @ sg.tangent(s)) < 1e-6 * np.linalg.norm(sg.tangent(s))  # eq. 4.6
    # one iteration per cycle (the thesis' setting) converges over a few cycles
    g1 = PfcmGuidance(path, PfcmLimits(v_cruise=5.0), iterations=1)
    g1.s = 0.2
    for _ in range(10):
        g1.update_control_point(x)
    assert g1.s == pytest.approx(ref, abs=1e-4)


def test_braking_starts_at_the_distance_the_formula_gives():
    path = HermitePath.from_waypoints([[0, 0, -20], [200, 0, -20]], [[1, 0, 0], [1, 0, 0]])
    for lead in (0.0, 0.5):
        g = PfcmGuidance(path, PfcmLimits(v_cruise=8.0, accel=1.2), brake_lead_s=lead)
        out = _fly(g, 60.0)
        first = next(r for r in out if r.phase == "brake")
        prev = out[out.index(first) - 1]
        d_formula = 8.0**2 / (2 * 1.2)  # eq. 4.19-4.20 with v_end = 0: 26.7 m
        assert prev.distance_to_end > d_formula + 8.0 * lead >= first.distance_to_end - 8.0 * 0.02
        assert first.distance_to_end == pytest.approx(d_formula + 8.0 * lead, abs=0.2)
        assert [r.phase for r in out[:5]] == ["accelerate"] * 5
        assert out[-1].finished and out[-1].v_target == 0.0


def test_acceleration_phase_rises_at_1_2_mps2():
    path = HermitePath.from_waypoints([[0, 0, -20], [300, 0, -20]], [[1, 0, 0], [1, 0, 0]])
    out = _fly(PfcmGuidance(path, PfcmLimits(v_cruise=10.0)), 12.0)
    v = np.array([r.v_target for r in out])
    t = np.array([r.t for r in out])
    acc = (t > 1) & (t < 7)
    np.testing.assert_allclose(np.diff(v[acc]) / 0.02, 1.2, rtol=1e-6)
    assert v.max() == pytest.approx(10.0) and out[-1].phase == "cruise"


def test_turn_limit_on_a_circle_and_feed_forward():
    R = 30.0
    P, T = helix_waypoints((0, R), R, -math.pi / 2, 3 * math.pi, -20.0, -20.0, 12)  # right turns, level
    g = PfcmGuidance(HermitePath.from_waypoints(P, T), PfcmLimits(v_cruise=10.0))
    out = _fly(g, 40.0)
    mid = out[len(out) // 2]
    kappa = np.linalg.norm(mid.curvature)
    u3 = math.sqrt(PHI * G / kappa)  # 8.8 m/s < v_cruise
    assert mid.v_targ2 == pytest.approx(u3, rel=0.01) and mid.v_target == pytest.approx(u3, rel=0.01)
    assert mid.v_targ1 == 10.0 and mid.v_targ3 == np.inf
    u = mid.v_target
    assert mid.phi_ff > 0 and mid.r_ff > 0  # right turn: roll right, yaw right (NED)
    # eq. 4.14 in its exact trimmed-turn form: tan phi = u² k / g, r = cos(phi) u k
    assert mid.phi_ff == pytest.approx(math.atan(u * u * kappa / G), rel=0.01)
    assert mid.phi_ff == pytest.approx(math.atan(PHI), rel=0.01)  # at the u3 limit: tan(phi) = phi_max
    assert mid.r_ff == pytest.approx(u * kappa * math.cos(mid.phi_ff), rel=0.01)


@pytest.mark.parametrize("anticipate", [True, False])
def test_turn_limit_is_anticipated_by_braking_at_acc(anticipate):
    R = 30.0
    P, T = helix_waypoints((100, R), R, -math.pi / 2, math.pi, -20.0, -20.0, 4)
    path = HermitePath.from_waypoints(np.vstack([[0, 0, -20], P]), np.vstack([[1, 0, 0], T]))
    g = PfcmGuidance(path, PfcmLimits(v_cruise=10.0, anticipate=anticipate), brake_lead_s=0.0)
    out = _fly(g, 30.0)
    last_straight = [r for r in out if r.segment == 0][-1]
    kappa = np.linalg.norm(next(r for r in out if r.segment == 1 and r.s > 0.5).curvature)
    u3 = math.sqrt(PHI * G / kappa)
    if anticipate:  # slowed down at Acc before the turn: v² = u3² + 2 Acc d over the last metres
        assert last_straight.v_target <= u3 + 0.05
        before = next(r for r in out if r.distance_to_end <= path.lengths[1:].sum() + 10.0)
        assert before.v_target == pytest.approx(math.sqrt(u3**2 + 2 * 1.2 * 10.0), rel=0.02)
    else:  # the thesis' v_targ2 at the control point only: still at cruise speed up to the turn
        assert last_straight.v_target == pytest.approx(10.0)


@pytest.mark.parametrize("gamma_deg, w", [(45.0, 1.5), (20.0, 3.0)])
def test_descent_limit_on_a_straight_descent(gamma_deg, w):
    g_ = math.radians(gamma_deg)
    d = np.array([math.cos(g_), 0.0, math.sin(g_)])
    path = HermitePath.from_waypoints([[0, 0, -60], (np.array([0, 0, -60]) + 100 * d)], [d, d])
    out = _fly(PfcmGuidance(path, PfcmLimits(v_cruise=10.0)), 40.0)
    mid = out[len(out) // 3]
    assert mid.v_targ3 == pytest.approx(w / math.sin(g_), rel=1e-6)
    assert mid.v_target == pytest.approx(min(10.0, w / math.sin(g_)), rel=1e-6)
    assert mid.velocity[2] == pytest.approx(min(10.0 * math.sin(g_), w), rel=1e-6)  # descent rate


def test_heading_error_and_hold():
    path = HermitePath.from_waypoints([[0, 0, -20], [0, 50, -20]], [[0, 1, 0], [0, 1, 0]])  # east
    g = PfcmGuidance(path, PfcmLimits(v_cruise=5.0))
    r = g.step(0.0, _nav(0.0, [0, 0, -20], yaw=math.radians(80)))
    assert r.heading_error == pytest.approx(math.radians(10))
    assert g.step(0.0, _nav(0.0, [5, 5, -20])) is r  # same t: cached
    h = PointHold([1, 2, -10], math.radians(-170)).step(1.0, _nav(1.0, [0, 0, -10], yaw=math.radians(170)))
    assert h.heading_error == pytest.approx(math.radians(20)) and np.all(h.velocity == 0)


def test_bad_limits():
    for v in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="v_cruise must be > 0"):
            PfcmLimits(v_cruise=v)
    with pytest.raises(ValueError, match="accel"):
        PfcmLimits(v_cruise=5.0, accel=0.0)
    path = HermitePath.from_waypoints([[0, 0, -20], [0, 50, -20]], [[0, 1, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match="iterations"):
        PfcmGuidance(path, PfcmLimits(v_cruise=5.0), iterations=0)


def test_profile_row_interpolates_the_table_and_clamps_at_its_ends():
    """``_row`` is the linear interpolation of the look-ahead table (np.interp per column), held at the ends."""
    P, T = helix_waypoints((0, 30), 30.0, -math.pi / 2, 1.5 * math.pi, -20.0, -32.0, 3)
    g = PfcmGuidance(HermitePath.from_waypoints(P, T), PfcmLimits(v_cruise=8.0))
    tab = g.profile_table
    cols = [tab["envelope2"], tab["envelope3"], tab["lateral_curvature"]]
    rng = np.random.default_rng(7)
    for l in [*rng.uniform(-5, g.path.length + 5, 200).tolist(), 0.0, g.path.length]:
        want = [np.interp(l, tab["l"], c) for c in cols]
        np.testing.assert_allclose(g._row(l), want, rtol=1e-12, atol=1e-12)
