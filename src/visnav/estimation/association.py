"""Data association of measured blobs to known deck lights (seed 003 §3.3, eq. 3.11-3.12).

Cost of giving measured feature i to expected light j: the Mahalanobis distance

    C_ij = (z_i - z_j)^T S_j^-1 (z_i - z_j)                                 (eq. 3.11)

with S_j the predicted covariance of light j's bearings (the printed eq. 3.11 writes the
covariance itself; the Mahalanobis distance it names uses its inverse). One dummy column per
measurement, at the gate cost on its own row and twice the gate cost elsewhere (eq. 3.12), lets a
measurement stay unassigned; the rectangular problem is solved with
``scipy.optimize.linear_sum_assignment`` (Munkres). Measurements matched to a dummy are discarded.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment


def mahalanobis_costs(z_meas: np.ndarray, z_pred: np.ndarray, S: np.ndarray) -> np.ndarray:
    """C (M, L) of eq. 3.11: measured (M, d) against predicted (L, d) with covariances S (L, d, d)."""
    z_meas = np.atleast_2d(np.asarray(z_meas, float))
    z_pred = np.atleast_2d(np.asarray(z_pred, float))
    d = z_meas[:, None, :] - z_pred[None, :, :]
    Si = np.linalg.inv(S)
    return np.einsum("mli,lij,mlj->ml", d, Si, d)


def cost_matrix(costs: np.ndarray, gate: float) -> np.ndarray:
    """The full matrix of eq. 3.12: [C | gate on the diagonal, 2 gate off it]."""
    m = costs.shape[0]
    out = np.empty((m, costs.shape[1] + m))
    out[:, :costs.shape[1]] = costs
    out[:, costs.shape[1]:] = 2.0 * gate
    out[:, costs.shape[1]:].flat[::m + 1] = gate  # (np.fill_diagonal's own step)
    return out


def associate(z_meas: np.ndarray, z_pred: np.ndarray, S: np.ndarray, gate: float) -> np.ndarray:
    """Light index for every measurement (-1: unassigned, discarded).

    ``z_meas`` (M, d), ``z_pred`` (L, d), ``S`` (L, d, d); ``gate`` the largest accepted Mahalanobis
    cost. Rows with NaN are never assigned.
    """
    z_meas = np.asarray(z_meas, float).reshape(-1, np.shape(z_pred)[-1])
    m, L = z_meas.shape[0], np.shape(z_pred)[0]
    out = np.full(m, -1, dtype=int)
    if m == 0 or L == 0:
        return out
    costs = mahalanobis_costs(z_meas, z_pred, S)
    costs = np.where(np.isfinite(costs), costs, 1e12)
    rows, cols = linear_sum_assignment(cost_matrix(costs, gate))
    for r, c in zip(rows, cols):
        if c < L and costs[r, c] <= gate:
            out[r] = c
    return out
