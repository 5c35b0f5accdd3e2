"""Cubic Hermite path segments (seed 002 eq. 4.1-4.5): boundary conditions, curvature, arc length."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from visnav.guidance.hermite import (
    HermitePath,
    HermiteSegment,
    arc_tangent_magnitude,
    helix_waypoints,
)


def _arc(R: float, deg: float) -> HermitePath:
    """One segment from bearing 0 to ``deg`` on a circle of radius R around the origin (turning right)."""
    th = math.radians(deg)
    P = np.array([[R, 0, 0], [R * math.cos(th), R * math.sin(th), 0]])
    T = np.array([[0, 1, 0], [-math.sin(th), math.cos(th), 0]])
    return HermitePath.from_waypoints(P, T, scale="arc")


def test_segment_meets_its_boundary_conditions():
    rng = np.random.default_rng(4)
    for _ in range(10):
        p0, p1, t0, t1 = rng.normal(0, 20, (4, 3))
        sg = HermiteSegment(p0, p1, t0, t1)
        np.testing.assert_allclose(sg.position([0.0, 1.0]), [p0, p1], atol=1e-9)
        np.testing.assert_allclose(sg.tangent([0.0, 1.0]), [t0, t1], atol=1e-9)
        # the coefficients solve the 12 boundary equations p(0), p(1), p'(0), p'(1) (eq. 4.2)
        M = np.array([[0, 0, 0, 1], [1, 1, 1, 1], [0, 0, 1, 0], [3, 2, 1, 0]], float)
        np.testing.assert_allclose(sg.coeffs, np.linalg.solve(M, np.stack([p0, p1, t0, t1])), atol=1e-9)


def test_derivatives_match_finite_differences():
    sg = HermiteSegment([0, 0, -10], [30, 20, -15], [40, 0, 0], [0, 35, -5])
    s, h = np.linspace(0.05, 0.95, 7), 1e-5
    np.testing.assert_allclose(sg.tangent(s), (sg.position(s + h) - sg.position(s - h)) / (2 * h), rtol=1e-6)
    np.testing.assert_allclose(sg.second_derivative(s), (sg.tangent(s + h) - sg.tangent(s - h)) / (2 * h),
                               rtol=1e-6)
    for si in s:  # the scalar fast path agrees with the vector one
        p, t, k = sg.frame_at(si)
        np.testing.assert_allclose(p, sg.position(si), atol=1e-12)
        np.testing.assert_allclose(k, sg.curvature(si), atol=1e-12)


@pytest.mark.parametrize("deg", [30.0, 45.0])
def test_curvature_of_a_circle_approximating_segment_is_one_over_R(deg):
    R = 20.0
    sg = _arc(R, deg).segments[0]
    s = np.linspace(0, 1, 101)
    k = sg.curvature(s)
    np.testing.assert_allclose(np.linalg.norm(k, axis=1), 1 / R, rtol=0.01)
    # the curvature vector points at the centre of the circle (the origin)
    towards = -sg.position(s) / np.linalg.norm(sg.position(s), axis=1, keepdims=True)
    assert np.all(np.sum(k / np.linalg.norm(k, axis=1, keepdims=True) * towards, axis=1) > 0.999)
    assert abs(sg.length / (R * math.radians(deg)) - 1) < 1e-4


def test_curvature_equals_the_turn_rate_of_the_unit_tangent_per_metre():
    sg = HermiteSegment([0, 0, 0], [50, 30, -10], [60, -10, 0], [0, 50, -5])
    s, h = np.linspace(0.1, 0.9, 5), 1e-5
    unit = lambda x: sg.tangent(x) / np.linalg.norm(sg.tangent(x), axis=-1, keepdims=True)  # noqa: E731
    dT_ds = (unit(s + h) - unit(s - h)) / (2 * h)
    dT_dl = dT_ds / np.linalg.norm(sg.tangent(s), axis=1, keepdims=True)  # dT/dl = kappa N
    np.testing.assert_allclose(sg.curvature(s), dT_dl, rtol=1e-5, atol=1e-9)


def test_helix_curvature_and_length():
    R, turns, dh = 25.0, 1.5, 30.0
    P, T = helix_waypoints((0, 0), R, 0.0, 2 * math.pi * turns, -40.0, -10.0, 12)
    path = HermitePath.from_waypoints(P, T)
    c = dh / (2 * math.pi * turns)  # rise per radian
    kappa = R / (R * R + c * c)
    smp = path.sample(50)
    np.testing.assert_allclose(np.linalg.norm(smp["curvature"], axis=1), kappa, rtol=0.01)
    assert path.length == pytest.approx(math.hypot(2 * math.pi * turns * R, dh), rel=1e-3)


def test_arc_length_matches_scipy_quad_and_distance_to_end():
    sg = HermiteSegment([0, 0, 0], [40, 10, -5], [80, 0, 0], [0, 60, 0])
    path = HermitePath([sg, HermiteSegment([40, 10, -5], [40, 60, -5], [0, 50, 0], [0, 50, 0])])
    for s in (0.3, 0.7, 1.0):
        ref, _ = integrate.quad(lambda u: np.linalg.norm(sg.tangent(u)), 0, s, epsabs=1e-10)
        assert sg.arc_length(s) == pytest.approx(ref, rel=1e-6)
    assert path.segments[1].length == pytest.approx(50.0, rel=1e-9)  # straight, chord tangents
    assert path.distance_to_end(0, 0.3) == pytest.approx(path.length - path.arc_position(0, 0.3), abs=1e-9)
    assert path.distance_to_segment_end(1, 0.5) == pytest.approx(25.0, rel=1e-9)


def test_closest_point_distance_to_a_circle():
    R = 30.0
    P, T = helix_waypoints((0, 0), R, 0.0, math.pi, -20.0, -20.0, 4)
    path = HermitePath.from_waypoints(P, T)
    ang = np.radians([20, 70, 130])
    d = np.array([0.5, -1.0, 2.0])  # radial offsets
    pts = np.column_stack([(R + d) * np.cos(ang), (R + d) * np.sin(ang), np.full(3, -20.0)])
    dist, l = path.closest(pts)
    np.testing.assert_allclose(dist, np.abs(d), atol=0.005)
    np.testing.assert_allclose(l, R * ang, rtol=0.005)


def test_arc_tangent_magnitude():
    assert arc_tangent_magnitude(10.0, 0.0) == 10.0
    R, th = 7.0, math.radians(90)
    assert arc_tangent_magnitude(2 * R * math.sin(th / 2), th) == pytest.approx(4 * R * math.tan(th / 4))
    with pytest.raises(ValueError, match="chord"):
        arc_tangent_magnitude(0.0, 0.1)


def test_bad_segments_and_paths_are_named():
    with pytest.raises(ValueError, match="start tangent t0 is zero"):
        HermiteSegment([0, 0, 0], [10, 0, 0], [0, 0, 0], [1, 0, 0])
    with pytest.raises(ValueError, match="cusp"):
        HermiteSegment([0, 0, 0], [0, 0, 0], [10, 0, 0], [10, 0, 0])
    a = HermiteSegment([0, 0, 0], [10, 0, 0], [10, 0, 0], [10, 0, 0])
    b = HermiteSegment([10.5, 0, 0], [20, 0, 0], [10, 0, 0], [10, 0, 0])
    with pytest.raises(ValueError, match=r"path segment 1 starts .* gap 0\.500 m"):
        HermitePath([a, b])
    c = HermiteSegment([10, 0, 0], [20, 10, 0], [0, 10, 0], [10, 0, 0])
    with pytest.raises(ValueError, match="segment 1 starts with a tangent 90.00 deg off"):
        HermitePath([a, c])
    with pytest.raises(ValueError, match="waypoint 1: tangent is zero"):
        HermitePath.from_waypoints([[0, 0, 0], [10, 0, 0]], [[1, 0, 0], [0, 0, 0]])
    with pytest.raises(ValueError, match="waypoints 0 and 1 coincide"):
        HermitePath.from_waypoints([[0, 0, 0], [0, 0, 0]], [[1, 0, 0], [1, 0, 0]])
    with pytest.raises(ValueError, match=r"shape \(N, 12\)"):
        HermitePath.from_segments([[0.0] * 11])
    with pytest.raises(ValueError, match="at least one segment"):
        HermitePath([])


def test_frame_at_equals_eq_4_2_to_4_5_on_random_segments():
    """The per-step ``frame_at`` gives p, t and the curvature (t × q) × t / |t|⁴ of eq. 4.5 written with
    numpy's cross products, on random segments of every scale."""
    rng = np.random.default_rng(19)
    n = 0
    for _ in range(300):
        p0, p1, t0, t1 = rng.normal(0, 1, (4, 3)) * rng.choice([0.01, 1.0, 30.0, 1e4], size=(4, 1))
        try:
            sg = HermiteSegment(p0, p1, t0, t1)
        except ValueError:  # a cusp: not a segment
            continue
        scale = np.abs(sg.coeffs).max()
        for s in [0.0, 1.0, 0.5, *rng.uniform(0, 1, 8).tolist()]:
            p, t, k = sg.frame_at(s)
            q = sg.second_derivative(s)
            k_ref = np.cross(np.cross(t, q), t) / np.dot(t, t) ** 2
            np.testing.assert_allclose(p, sg.position(s), rtol=1e-12, atol=1e-12 * scale)
            np.testing.assert_allclose(t, sg.tangent(s), rtol=1e-12, atol=1e-12 * scale)
            np.testing.assert_allclose(k, k_ref, rtol=1e-8, atol=1e-10 * np.abs(k_ref).max())
            n += 1
    assert n > 1000
