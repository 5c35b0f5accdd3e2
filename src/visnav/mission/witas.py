"""WITAS GPS-denied homing (seed 002 §5.9.1): the R-MAX flies a closed loop at 60 m AGL with PFCM, GPS
is lost at the start, the vision-based navigator is the only navigation source in the control loop,
and the helicopter comes back home.

The loop's geometry lives here (``loop_waypoints``; fitted to a map by ``world/witas_map.fit_loop``); the simulation's builder of the
mission (world, reference map, sensors, navigator, PFCM mission) is ``app/witas_parts.py``.
"""

from __future__ import annotations

import math

import numpy as np




def loop_waypoints(size_north: float, size_east: float, radius: float, altitude: float,
                   centre=(0.0, 0.0), direction: str = "cw") -> tuple[np.ndarray, np.ndarray]:
    """Rounded rectangle from home (middle of the west leg) back to home; each corner is a quarter
    circle of ``radius`` made of two 45-degree Hermite segments. Returns waypoints and tangents."""
    n2, e2 = size_north / 2.0, size_east / 2.0
    r = min(radius, 0.45 * min(size_north, size_east))
    c0 = np.asarray(centre, float)
    corners = [(n2, -e2), (n2, e2), (-n2, e2), (-n2, -e2)]  # NW, NE, SE, SW: clockwise seen from above
    dirs = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]  # leg ending at each corner
    if direction == "ccw":
        corners = [(n2, e2), (-n2, e2), (-n2, -e2), (n2, -e2)]
        dirs = [(0.0, 1.0), (-1.0, 0.0), (0.0, -1.0), (1.0, 0.0)]
        home = np.array([n2, 0.0])
        first = np.array([0.0, 1.0])
    else:
        home = np.array([0.0, -e2])
        first = np.array([1.0, 0.0])
    P, T = [home], [first]
    for k, (c, din) in enumerate(zip(corners, dirs)):
        c, din = np.array(c), np.array(din)
        dout = np.array(dirs[(k + 1) % 4])
        a = c - r * din
        o = a + r * dout
        mid = o + r * (din - dout) / math.sqrt(2.0)
        P += [a, mid, c + r * dout]
        T += [din, (din + dout) / math.sqrt(2.0), dout]
    P.append(home)
    T.append(first)
    P = np.array(P) + c0
    out = np.column_stack([P, np.full(len(P), -altitude)])
    return out, np.column_stack([np.array(T), np.zeros(len(T))])
