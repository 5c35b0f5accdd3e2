"""Values as JSON holds them: what metrics.json, check.json and the command line's --json write."""

from __future__ import annotations

import math

import numpy as np


def jsonable(x):
    """``x`` with numpy scalars and arrays as Python numbers and lists, and NaN / inf as null (JSON has neither)."""
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, np.integer):
        return int(x)
    return x
