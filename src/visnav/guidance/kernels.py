"""Per-step kernels of the guidance (issue #31): a readable model's own equation on floats, for the calls made
once per control step, kept apart from the model. Each is held to its readable reference at 1e-12 relative in
tests/guidance/test_kernels.py; ``ENABLED = False`` flies the readable path everywhere.
"""

from __future__ import annotations

import math

ENABLED = True


def arc_length_1(rows, s: float, s0: float, nodes_weights) -> float:
    """Eq. 4.3's arc length of one Hermite segment from s0 to s: h sum_i w_i |t(s0 + h x_i)| with the
    Gauss-Legendre nodes and weights on [0, 1] (``HermiteSegment.arc_length``), t(u) = (3A u + 2B) u + C from
    ``rows`` = (3A, 2B, C) as tuples of floats."""
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = rows
    h = s - s0
    total = 0.0
    for x, w in nodes_weights:
        u = s0 + h * x
        t0, t1, t2 = (a0 * u + b0) * u + c0, (a1 * u + b1) * u + c1, (a2 * u + b2) * u + c2
        total += w * math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    return h * total
