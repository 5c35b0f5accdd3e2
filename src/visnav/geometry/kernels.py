"""One-vector kernels of ``geometry/rotations`` kept apart from the readable equations they reproduce (issue #31).

``rotations.dcm_to_euler`` reads the angles off eq. 3.2 with numpy, for a batch; on one matrix (the navigators'
and the vehicles' state at every step) numpy's per-call overhead is nearly all of its cost. This evaluates the
same formulas on Python floats; ``tests/geometry/test_kernels.py`` holds it to the readable (batch) path at 1e-12,
gimbal lock included. ``rotations.KERNELS = False`` sends one matrix down the readable path.
"""

from __future__ import annotations

import math


def dcm_to_euler3(rows) -> list[float]:
    """``rotations.dcm_to_euler`` of one ``C_b^n`` given as three rows of floats: [roll, pitch, yaw]."""
    (c00, c01, _), (c10, c11, _), (c20, c21, c22) = rows
    pitch = -math.asin(min(max(c20, -1.0), 1.0))
    if math.hypot(c21, c22) < 1e-9:  # gimbal lock: yaw -+ roll from the second row / column, roll 0
        roll, yaw = 0.0, math.atan2(-c01, c11)
    else:
        roll, yaw = math.atan2(c21, c22), math.atan2(c10, c00)
    return [roll, pitch, math.pi if yaw <= -math.pi else yaw]
