"""Arithmetic on single numbers for the 100 Hz paths, without numpy's per-call overhead (a leaf module)."""

from __future__ import annotations

from math import isfinite


def clip(x: float, lo: float, hi: float) -> float:
    """``float(np.clip(x, lo, hi))`` for one number: the same result, NaN included (NaN stays NaN)."""
    return float(min(max(x, lo), hi))


def finite(*vectors) -> bool:
    """``np.isfinite(v).all()`` of each of a few short vectors (arrays or sequences of numbers), on floats."""
    return all(isfinite(x) for v in vectors for x in (v.tolist() if hasattr(v, "tolist") else v))
