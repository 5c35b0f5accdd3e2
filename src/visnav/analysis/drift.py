"""Tracker drift exactly as seed 000 §4.2.1 measures it.

At 10 Hz the vector from the reference position (GPS there, truth here) to the MPE estimate is
taken; a straight line in time is fitted to these vectors by least squares, the 10 points farthest
from the line are discarded one at a time with a refit after each, and the drift is the distance
between the fitted line's first and last points. The equivalent pixels are drift * f / range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DriftResult:
    drift_m: float
    drift_px: float
    duration_s: float
    noise_sigma_m: float  # RMS distance of the kept points from the fitted line (Table 4.1's sigma)
    rate_m_per_s: np.ndarray  # fitted drift velocity (per component)
    kept: np.ndarray  # boolean mask of the points the final fit used


def _fit(t: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    A = np.column_stack([np.ones_like(t), t - t[0]])
    coef, *_ = np.linalg.lstsq(A, d, rcond=None)
    return coef, A @ coef


def measure_drift(t, error_vectors, range_m, focal_px: float, discard: int = 10) -> DriftResult:
    """``error_vectors`` (N, k): MPE - reference at times ``t``; ``range_m`` scalar or (N,)."""
    t = np.asarray(t, dtype=float)
    d = np.asarray(error_vectors, dtype=float)
    if d.ndim == 1:
        d = d[:, None]
    good = np.all(np.isfinite(d), axis=1) & np.isfinite(t)
    if good.sum() < discard + 3:
        raise ValueError(f"drift needs at least {discard + 3} finite samples, got {int(good.sum())}")
    keep = good.copy()
    for _ in range(discard):
        idx = np.nonzero(keep)[0]
        _, pred = _fit(t[idx], d[idx])
        worst = idx[np.argmax(np.linalg.norm(d[idx] - pred, axis=1))]
        keep[worst] = False
    idx = np.nonzero(keep)[0]
    coef, pred = _fit(t[idx], d[idx])
    duration = float(t[idx[-1]] - t[idx[0]])
    drift = float(np.linalg.norm(coef[1] * duration))
    rng = float(np.nanmean(np.asarray(range_m, dtype=float)))
    sigma = float(np.sqrt(np.mean(np.sum((d[idx] - pred) ** 2, axis=1))))
    return DriftResult(drift_m=drift, drift_px=drift * focal_px / rng, duration_s=duration,
                       noise_sigma_m=sigma, rate_m_per_s=coef[1], kept=keep)
