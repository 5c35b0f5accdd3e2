"""Arithmetic on single numbers for the 100 Hz paths, without numpy's per-call overhead (a leaf module)."""

from __future__ import annotations


def clip(x: float, lo: float, hi: float) -> float:
    """``float(np.clip(x, lo, hi))`` for one number: the same result, NaN included (NaN stays NaN)."""
    return float(min(max(x, lo), hi))
