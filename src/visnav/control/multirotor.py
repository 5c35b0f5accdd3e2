"""Trajectory following, attitude commander and throttle control of the deck lander (seed 003 §4.2-4.3).

All vectors live in a heading-free level frame (the vehicle's yaw is 0 in it), so the attitude
commander's roll and pitch come straight from the commanded acceleration.

* :func:`follow` - eq. 4.25-4.27: a virtual spring (K) and damper (B) between the vehicle and the
  desired point, plus the trajectory's acceleration as feed-forward.
* :func:`attitude_command` - eq. 4.28 solved exactly for (T, phi, theta) (eq. 4.29-4.31 are its
  small-angle form): T/m = |g - a|, theta = atan2(-a_x, g - a_z), phi = asin(a_y m / T).
* :class:`ThrottleController` - eq. 4.32-4.33: throttle = T0(h) (1 + a_up / g) / cos(tilt) (the
  inverse of eq. 4.32 with A = g / T0) + PI on the vertical acceleration error; the hover
  throttle T0 is interpolated between its value at the deck and at 1 m (ground effect) and held
  above 1 m.
"""

from __future__ import annotations

import numpy as np
from visnav.scalar import clip as _clip

G = 9.81


def follow(p_des, v_des, a_ff, p, v, K: float, B: float) -> np.ndarray:
    """Commanded acceleration of eq. 4.25-4.27."""
    return K * (np.asarray(p_des) - p) + B * (np.asarray(v_des) - v) + np.asarray(a_ff)


def attitude_command(a_cmd: np.ndarray, max_tilt: float, g: float = G):
    """(specific thrust T/m, roll, pitch) realising ``a_cmd`` (level frame, z down), eq. 4.28."""
    a = np.asarray(a_cmd, float)
    fz = g - a[2]
    fz = max(fz, 0.3 * g)  # never command free fall
    f = np.array([-a[0], a[1], fz])
    # limit the tilt: scale the horizontal part
    h = np.hypot(f[0], f[1])
    if h > fz * np.tan(max_tilt):
        f[:2] *= fz * np.tan(max_tilt) / h
    T = float(np.linalg.norm(f))
    theta = float(np.arctan2(f[0], f[2]))
    phi = float(np.arcsin(np.clip(f[1] / T, -1, 1)))
    return T, phi, theta


class ThrottleController:
    def __init__(self, hover_throttle_1m: float, hover_throttle_ground: float, kp: float = 0.02, ki: float = 0.05,
                 integral_limit: float = 0.1):
        self.t1, self.t0 = hover_throttle_1m, hover_throttle_ground
        self.kp, self.ki, self.lim = kp, ki, integral_limit
        self.integral = 0.0

    def hover_throttle(self, height_m: float) -> float:
        """T0(h): linear between the deck (h = 0) and 1 m, constant above (§4.3.1)."""
        h = _clip(height_m, 0.0, 1.0)
        return self.t0 + (self.t1 - self.t0) * h

    def command(self, a_up_cmd: float, a_up_meas: float, height_m: float, tilt_cos: float, dt: float) -> float:
        err = a_up_cmd - a_up_meas
        self.integral = _clip(self.integral + err * dt, -self.lim / self.ki, self.lim / self.ki)
        T0 = self.hover_throttle(height_m)
        ff = T0 * (1.0 + a_up_cmd / G) / max(tilt_cos, 0.5)
        return _clip(ff + self.kp * err + self.ki * self.integral, 0.0, 1.0)
