"""Trajectories to a (moving) deck from tau gaps (seed 003 ch. 4, eq. 4.1-4.24).

Frames: the *level-deck* frame ld has the deck's heading and is level (z down); positions are of
the vehicle's body origin relative to the touchdown target, a point ``gear_offset`` above the
landing point along the predicted deck normal (so that the gear, not the body, meets the deck).

* :func:`touchdown_acceleration` - eq. 4.1-4.3 and 4.10-4.13: the acceleration a_td (nominal
  2.5 m/s^2) at touchdown whose specific force a - g points along the predicted deck normal, so
  the vehicle's attitude matches the deck's; its direction gives the terminal approach path
  (azimuth lambda, angle from vertical gamma). Solved exactly rather than with small angles:
  |g_vec + s n| = a_td gives s = g cos(tilt) + sqrt(a_td^2 - g^2 sin^2(tilt)), which exists while
  tilt <= asin(a_td / g) (14.8 deg for 2.5 m/s^2, the thesis' "15 deg").
* :func:`predict_deck_attitude` - eq. 4.4-4.9: constant deck rates over the time to go, one
  Euler-Rodrigues quaternion.
* :class:`TauGapApproach` - eq. 4.14-4.21: gaps alpha = atan2(y, -z), beta = atan2(x, -z) and
  rho = |x| closed with higher-order tau (k_alpha = k_beta = 0.45, k_rho = 1/2, the duration set by
  eq. 2.46 so that the rho gap ends with a_td); the desired position u(alpha, beta) rho and its
  first two derivatives by the chain rule (the exact form of eq. 4.18-4.20's omega x terms).
* :class:`StraightApproach` - §5.3.3: one gap per axis, all with the same k and duration: a
  straight line to the target.
* :func:`level_deck_geometry` - the vehicle relative to the deck in the heading-free level frame and
  the level-deck frame, from the 12 relative states, the gyro and the autopilot's roll and pitch;
  :func:`touchdown_target` - the body origin at contact and the predicted upward deck normal there.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.estimation.deck import deck_in_level
from visnav.geometry.rotations import cross3, dcm_to_euler, euler_to_dcm3
from visnav.guidance.tau import duration_for_touchdown_acceleration, higher_order_tau

G = 9.81


def touchdown_acceleration(n_up: np.ndarray, accel: float = 2.5, g: float = G):
    """Vehicle acceleration at touchdown (level frame, z down) for a deck whose upward normal is ``n_up``.

    Returns (a (3,), lambda [rad], gamma [rad]); raises ValueError when the deck is too steep.
    """
    n = np.asarray(n_up, float) / np.linalg.norm(n_up)
    cos_tilt = -n[2]
    sin2 = max(0.0, 1.0 - cos_tilt**2)
    disc = accel**2 - g * g * sin2
    if disc < 0:
        raise ValueError(f"deck tilt {np.degrees(np.arcsin(np.sqrt(sin2))):.1f} deg needs more than "
                         f"{accel} m/s^2 at touchdown")
    s = g * cos_tilt + np.sqrt(disc)  # specific force magnitude (eq. 4.1: T / m)
    a = np.array([0.0, 0.0, g]) + s * n
    lam = float(np.arctan2(a[1], a[0]))  # eq. 4.11-4.12
    gam = float(np.arccos(np.clip(-a[2] / np.linalg.norm(a), -1, 1)))  # eq. 4.13 (angle from vertical)
    return a, lam, gam


def predict_deck_attitude(C_deck: np.ndarray, body_rates: np.ndarray, t_go: float) -> np.ndarray:
    """Deck attitude after ``t_go`` at constant body rates (eq. 4.4-4.9): C(t) = C0 R(q)."""
    w = np.asarray(body_rates, float)
    wn = float(np.linalg.norm(w))
    if wn < 1e-12 or t_go <= 0:
        return np.array(C_deck, float)
    phi = t_go * wn  # eq. 4.8
    k = w / wn  # eq. 4.9
    a, (b, c, d) = np.cos(phi / 2), k * np.sin(phi / 2)  # eq. 4.4-4.7
    R = np.array([[a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
                  [2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)],
                  [2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - b * b - c * c]])
    return np.asarray(C_deck, float) @ R


def _unit_and_derivatives(al, ald, aldd, be, bed, bedd):
    """u = q / |q|, q = (tan beta, tan alpha, -1), and du/dt, d2u/dt2 by the chain rule."""
    ta, tb = np.tan(al), np.tan(be)
    sa, sb = 1 + ta * ta, 1 + tb * tb  # sec^2
    q = np.array([tb, ta, -1.0])
    qd = np.array([sb * bed, sa * ald, 0.0])
    qdd = np.array([2 * sb * tb * bed * bed + sb * bedd, 2 * sa * ta * ald * ald + sa * aldd, 0.0])
    n = np.linalg.norm(q)
    qq, qqd = q @ qd, qd @ qd + q @ qdd
    u = q / n
    ud = qd / n - q * qq / n**3
    udd = qdd / n - 2 * qd * qq / n**3 - q * qqd / n**3 + 3 * q * qq * qq / n**5
    return u, ud, udd


class TauGapApproach:
    """Higher-order tau on alpha, beta (eq. 4.14-4.15) and rho from the start to the terminal path."""

    def __init__(self, start_ld: np.ndarray, a_td: np.ndarray, k_rho: float = 0.5, k_ab: float = 0.45,
                 duration: float | None = None):
        x = np.asarray(start_ld, float)
        if x[2] >= 0:
            raise ValueError("the approach must start above the deck (z < 0 in the level-deck frame)")
        self.rho0 = float(np.linalg.norm(x))
        self.al0, self.be0 = np.arctan2(x[1], -x[2]), np.arctan2(x[0], -x[2])
        u_f = np.asarray(a_td, float) / np.linalg.norm(a_td)  # terminal direction: deck -> vehicle
        self.alf, self.bef = np.arctan2(u_f[1], -u_f[2]), np.arctan2(u_f[0], -u_f[2])
        a_mag = float(np.linalg.norm(a_td))
        self.T = duration if duration is not None else duration_for_touchdown_acceleration(self.rho0, a_mag)
        self.k_rho, self.k_ab = k_rho, k_ab

    def retarget(self, a_td: np.ndarray) -> None:
        """Aim the alpha, beta gaps at a new terminal path (a fresher touchdown prediction)."""
        u_f = np.asarray(a_td, float) / np.linalg.norm(a_td)
        self.alf, self.bef = np.arctan2(u_f[1], -u_f[2]), np.arctan2(u_f[0], -u_f[2])

    def desired(self, t: float):
        """(position, velocity, acceleration) in the level-deck frame at ``t`` since the start (eq. 4.16-4.21)."""
        rho, rhod, rhodd = higher_order_tau(t, self.rho0, self.T, self.k_rho)
        ga, gad, gadd = higher_order_tau(t, 1.0, self.T, self.k_ab)
        al = self.alf + (self.al0 - self.alf) * ga
        be = self.bef + (self.be0 - self.bef) * ga
        u, ud, udd = _unit_and_derivatives(al, (self.al0 - self.alf) * gad, (self.al0 - self.alf) * gadd,
                                           be, (self.be0 - self.bef) * gad, (self.be0 - self.bef) * gadd)
        p = rho * u  # eq. 4.17
        v = rhod * u + rho * ud  # eq. 4.18
        a = rhodd * u + 2 * rhod * ud + rho * udd  # eq. 4.20
        return p, v, a


class StraightApproach:
    """One higher-order tau gap per level-deck axis, same k and duration (§5.3.3): a straight line."""

    def __init__(self, start_ld: np.ndarray, duration: float = 15.0, k: float = 0.3):
        self.x0 = np.asarray(start_ld, float)
        self.T, self.k = duration, k

    def desired(self, t: float):
        g, gd, gdd = higher_order_tau(t, 1.0, self.T, self.k)
        return self.x0 * g, self.x0 * gd, self.x0 * gdd


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)  # (numpy's float64 cos / sin are libm's, as math's: the same values, faster)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def level_deck_geometry(x: np.ndarray, gyro: np.ndarray, roll: float, pitch: float):
    """The vehicle relative to the deck from the relative state ``x`` (``estimation/deck.py``).

    Returns (p, v) of the vehicle relative to the deck in the heading-free level frame, the deck's attitude
    there ``Cd0``, the level-deck yaw ``psi_d`` (so ``rot_z(psi_d).T @ p`` is the level-deck position), and
    the deck's body rates. The last call's result is kept and returned again for the same ``x`` and ``gyro``
    arrays (identity) and the same roll and pitch: the results' arrays must not be changed in place.
    """
    last = _LEVEL_LAST[0]  # the mission and the controller ask for the same estimate's in one step
    if last is not None and last[0] is x and last[1] is gyro and last[2] == roll and last[3] == pitch:
        return last[4]
    Ch0 = euler_to_dcm3(float(roll), float(pitch), 0.0)  # (euler_to_dcm's one-vector path)
    r, e, v, wd = x[0:3], x[3:6], x[6:9], x[9:12]
    p = -Ch0 @ r
    vel = -Ch0 @ (v + cross3(gyro, r))
    Cd0 = deck_in_level(e, roll, pitch)
    psi_d = float(dcm_to_euler(Cd0)[2])
    out = p, vel, Cd0, psi_d, wd
    _LEVEL_LAST[0] = (x, gyro, roll, pitch, out)
    return out


#: the last ``level_deck_geometry`` call: (x, gyro, roll, pitch, result); its arrays are read, never changed in
#: place, by its callers (the deck mission and controller)
_LEVEL_LAST: list = [None]


def touchdown_target(Cd0: np.ndarray, wd: np.ndarray, psi_d: float, t_go: float, landing_point: np.ndarray,
                     gear_offset: float, overshoot: float, moving: bool, along: np.ndarray | None = None):
    """Touchdown target (body origin, level-deck frame) and the predicted upward deck normal there.

    The deck attitude is predicted ``t_go`` ahead (eq. 4.4-4.9) when ``moving``; the body at contact lies
    ``gear_offset`` above the landing point along the normal, and the target ``overshoot`` below the deck plane
    beyond it (so that contact comes before the trajectory's end). Below it along the normal (``along`` None: the
    thesis' static deck, whose straight path then meets the plane ``overshoot tan(gamma)`` short, §5.3.3 "the
    vehicle never reaches (0,0)"), or along the final path, ``along`` the direction from the deck to the vehicle
    on it (the tau approach's a_td), so that the path meets the deck plane above the landing point. The path's
    angle from the normal is taken at most ``MAX_ALONG_DEG`` (a nearly level path would move the target far).
    """
    Cp = predict_deck_attitude(Cd0, wd, t_go) if moving else Cd0
    Rz = rot_z(psi_d)
    n_up = Rz.T @ (-Cp[:, 2])
    land = Rz.T @ (Cp @ landing_point)  # the desired landing location (§2.3), level-deck frame
    contact = land + gear_offset * n_up
    if along is None:
        return contact - overshoot * n_up, n_up
    u = np.asarray(along, float) / np.linalg.norm(along)
    cos_a = max(float(n_up @ u), math.cos(math.radians(MAX_ALONG_DEG)))
    return contact - overshoot / cos_a * u, n_up


#: the largest angle between the final path and the deck normal :func:`touchdown_target` moves the target along
MAX_ALONG_DEG = 60.0
