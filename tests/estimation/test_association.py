"""Data association (seed 003 eq. 3.11-3.12) against brute force over all assignments."""

import itertools

import numpy as np

from visnav.estimation.association import associate, cost_matrix, mahalanobis_costs


def _brute(costs, gate):
    m, L = costs.shape
    best, best_assign = np.inf, None
    for assign in itertools.product(range(-1, L), repeat=m):
        used = [a for a in assign if a >= 0]
        if len(used) != len(set(used)):
            continue
        c = sum(costs[i, a] if a >= 0 else gate for i, a in enumerate(assign))
        if c < best - 1e-12:
            best, best_assign = c, assign
    return np.array(best_assign)


def test_cost_matrix_layout_eq_3_12():
    C = cost_matrix(np.ones((3, 3)), 5.0)
    assert C.shape == (3, 6)
    np.testing.assert_array_equal(C[:, 3:], [[5, 10, 10], [10, 5, 10], [10, 10, 5]])


def test_mahalanobis_cost_uses_inverse_covariance():
    S = np.array([np.diag([4.0, 1.0])])
    c = mahalanobis_costs(np.array([[2.0, 0.0], [0.0, 2.0]]), np.zeros((1, 2)), S)
    np.testing.assert_allclose(c[:, 0], [1.0, 4.0])


def test_matches_brute_force_on_random_rectangular_problems():
    rng = np.random.default_rng(5)
    for _ in range(40):
        m, L = rng.integers(1, 5), rng.integers(1, 5)
        zp = rng.normal(0, 1, (L, 2))
        zm = rng.normal(0, 1, (m, 2))
        S = np.repeat(np.eye(2)[None] * 0.3, L, axis=0)
        got = associate(zm, zp, S, gate=6.0)
        want = _brute(mahalanobis_costs(zm, zp, S), 6.0)
        c = mahalanobis_costs(zm, zp, S)
        cost = lambda a: sum(c[i, j] if j >= 0 else 6.0 for i, j in enumerate(a))  # noqa: E731
        assert abs(cost(got) - cost(want)) < 1e-9


def test_extra_blob_is_rejected_and_lights_kept():
    zp = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.1], [-0.1, 0.0]])
    S = np.repeat(np.eye(2)[None] * 1e-4, 4, axis=0)
    zm = np.vstack([zp[[2, 0, 3, 1]] + 0.002, [[0.3, 0.3]]])
    np.testing.assert_array_equal(associate(zm, zp, S, gate=13.8), [2, 0, 3, 1, -1])


def test_nan_row_and_empty_inputs():
    zp = np.zeros((2, 2))
    S = np.repeat(np.eye(2)[None], 2, axis=0)
    np.testing.assert_array_equal(associate(np.array([[np.nan, 0.0], [0.0, 0.01]]), zp, S, 9.0), [-1, 0])
    assert associate(np.zeros((0, 2)), zp, S, 9.0).size == 0


def test_cost_matrix_equals_fill_diagonal_and_hstack():
    """cost_matrix fills [C | dummy] in place: the values np.fill_diagonal + np.hstack gave (speed round 4)."""
    from visnav.estimation.association import cost_matrix

    rng = np.random.default_rng(0)
    for m in range(1, 9):
        for L in range(0, 7):
            c = rng.normal(size=(m, L))
            dummy = np.full((m, m), 2.0 * 13.8)
            np.fill_diagonal(dummy, 13.8)
            assert np.array_equal(cost_matrix(c, 13.8), np.hstack([c, dummy]))
