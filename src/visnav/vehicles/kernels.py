"""Per-step kernels kept apart from the readable models they reproduce (issue #31 item 2).

The models are written once, in the form of their equations (``vehicles/fixedwing.derivatives``: Beard &
McLain eq. 3.14-3.17 and 4.6-4.19). A simulation steps the fixed wing 100 times a second through four
evaluations of those equations; on 3-vectors numpy's per-call overhead is most of the cost (~27 us per
evaluation against ~6 us on floats), which halved CONDOR's real-time factor. This module evaluates the same
equations on floats: where numba is installed (the ``fast`` extra, which ``make install`` installs) the fixed
wing's RK4 step is compiled (``cache=True``: once per installation, ~1 s; loading it costs ~0.2 s per process,
and a step then ~3 us against ~20 us on Python floats); without numba, or with ``VISNAV_JIT=0``, the very same
functions run on Python floats. It is not the model: a change to the physics is made in
``fixedwing.derivatives`` and then here, and ``tests/vehicles/test_kernels.py`` holds every kernel, compiled and
on floats, to its readable reference at 1e-12 relative (random states, controls and winds, and a whole flight).
``FixedWingModel(kernel=False)`` flies the readable path. The R-MAX's translational RK4 (seed 002 eq. 3.9-3.10,
``rmax.RmaxModel._deriv``) is compiled likewise: on Python floats it made the plant's step 16 % slower than the
hand-unrolled step it replaced; compiled it is ~6 us of a 29 us step (BENCHMARKS.md round 13).
``RmaxModel.kernel = False`` flies its readable path.
"""

from __future__ import annotations

import math
from math import asin, atan2, copysign, cos, exp, sin, sqrt

from visnav.geometry.rotations import _dcm_rows

from visnav.jit import compiled, njit

G = 9.81


def fixedwing_constants(p, gam) -> tuple:
    """What the fixed-wing kernel reads of ``FixedWingParams`` ``p`` and its Gamma terms ``gam``, once per model (a
    parameter's attribute lookup, and ``p.AR``'s division, cost as much as its use)."""
    return _floats((p.M, p.alpha0, p.C_L_0, p.C_L_alpha, p.C_D_p, math.pi * p.e * p.AR, 0.5 * p.rho * p.S,
            p.C_D_q, p.C_L_q, p.C_D_de, p.C_L_de, p.c, p.b, p.mass, 0.5 * p.rho * p.S_prop * p.C_prop, p.k_motor,
            p.C_Y_0, p.C_Y_beta, p.C_Y_p, p.C_Y_r, p.C_Y_da, p.C_Y_dr,
            p.C_l_0, p.C_l_beta, p.C_l_p, p.C_l_r, p.C_l_da, p.C_l_dr,
            p.C_m_0, p.C_m_alpha, p.C_m_q, p.C_m_de,
            p.C_n_0, p.C_n_beta, p.C_n_p, p.C_n_r, p.C_n_da, p.C_n_dr, p.Jy, *gam))


def _fixedwing_eval(k, x, u, wind):
    """Beard & McLain eq. 3.14-3.17 with eq. 4.6-4.19 (``fixedwing.derivatives`` with ``_lift_drag``) on floats: the
    state derivative (12) and the air data (Va, alpha, beta, specific force) at ``x``."""
    (M, a0, CL0, CLa, CDp, piEAR, hrhoS, CDq, CLq, CDde, CLde, c, b, m, kprop, kmot,
     y0, yb, yp, yr, yda, ydr, l0, lb, lp, lr, lda, ldr, m0, ma, mq, mde, n0, nb, np_, nr, nda, ndr, Jy,
     g1, g2, g3, g4, g5, g6, g7, g8) = k
    uu, vv, ww, phi, th, psi, P, Q, R = x[3], x[4], x[5], x[6], x[7], x[8], x[9], x[10], x[11]
    da, de, dr, thr = u
    wn, we, wd = wind
    cf, sf, ct, st, cp, sp = cos(phi), sin(phi), cos(th), sin(th), cos(psi), sin(psi)
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = _dcm_rows_c(cf, sf, ct, st, cp, sp)  # eq. 3.2
    ur = uu - (c00 * wn + c10 * we + c20 * wd)  # eq. 2.7: body velocity minus C^T wind
    vr = vv - (c01 * wn + c11 * we + c21 * wd)
    wr = ww - (c02 * wn + c12 * we + c22 * wd)
    Va = sqrt(ur * ur + vr * vr + wr * wr)  # eq. 2.8
    Va_s = Va if Va > 1.0 else 1.0
    alpha = atan2(wr, ur)
    sb = vr / Va_s
    beta = asin(-1.0 if sb < -1.0 else (1.0 if sb > 1.0 else sb))
    qbar = hrhoS * Va_s * Va_s
    ca, sa = cos(alpha), sin(alpha)
    ea, eb = exp(-M * (alpha - a0)), exp(M * (alpha + a0))  # eq. 4.9-4.11 (_lift_drag)
    sigma = (1.0 + ea + eb) / ((1.0 + ea) * (1.0 + eb))
    cl_lin = CL0 + CLa * alpha
    cl = (1.0 - sigma) * cl_lin + sigma * 2.0 * copysign(1.0, alpha) * sa * sa * ca
    cd = CDp + cl_lin * cl_lin / piEAR
    cx, cxq, cxde = -cd * ca + cl * sa, -CDq * ca + CLq * sa, -CDde * ca + CLde * sa  # eq. 4.19
    cz, czq, czde = -cd * sa - cl * ca, -CDq * sa - CLq * ca, -CDde * sa - CLde * ca
    c2v, b2v = c / (2.0 * Va_s), b / (2.0 * Va_s)
    thrust = kprop * ((kmot * thr) ** 2 - Va * Va)  # eq. 4.18
    fx = -m * G * st + qbar * (cx + cxq * c2v * Q + cxde * de) + thrust
    fy = m * G * ct * sf + qbar * (y0 + yb * beta + (yp * P + yr * R) * b2v + yda * da + ydr * dr)
    fz = m * G * ct * cf + qbar * (cz + czq * c2v * Q + czde * de)
    l_m = qbar * b * (l0 + lb * beta + (lp * P + lr * R) * b2v + lda * da + ldr * dr)
    m_m = qbar * c * (m0 + ma * alpha + mq * c2v * Q + mde * de)
    n_m = qbar * b * (n0 + nb * beta + (np_ * P + nr * R) * b2v + nda * da + ndr * dr)
    tt = st / ct
    d = (c00 * uu + c01 * vv + c02 * ww, c10 * uu + c11 * vv + c12 * ww, c20 * uu + c21 * vv + c22 * ww,  # 3.14
         R * vv - Q * ww + fx / m, P * ww - R * uu + fy / m, Q * uu - P * vv + fz / m,  # eq. 3.15
         P + sf * tt * Q + cf * tt * R, cf * Q - sf * R, (sf * Q + cf * R) / ct,  # eq. 3.16
         g1 * P * Q - g2 * Q * R + g3 * l_m + g4 * n_m,  # eq. 3.17
         g5 * P * R - g6 * (P * P - R * R) + m_m / Jy,
         g7 * P * Q - g1 * Q * R + g4 * l_m + g8 * n_m)
    return d, (Va, alpha, beta, (fx / m - c20 * G, fy / m - c21 * G, fz / m - c22 * G))


def _axpy(x, h, d):
    """x + h d on 12-tuples (the RK4's stage state)."""
    return (x[0] + h * d[0], x[1] + h * d[1], x[2] + h * d[2], x[3] + h * d[3], x[4] + h * d[4], x[5] + h * d[5],
            x[6] + h * d[6], x[7] + h * d[7], x[8] + h * d[8], x[9] + h * d[9], x[10] + h * d[10], x[11] + h * d[11])


def _fixedwing(k, x, u, wind, dt):
    """One classic RK4 step of :func:`_fixedwing_eval` over ``dt`` (none for ``dt`` 0), controls and wind held
    (``FixedWingModel.step``'s), and the state derivative and air data at the new state: (x, dx, air)."""
    if dt != 0.0:
        k1 = _fixedwing_eval(k, x, u, wind)[0]
        k2 = _fixedwing_eval(k, _axpy(x, 0.5 * dt, k1), u, wind)[0]
        k3 = _fixedwing_eval(k, _axpy(x, 0.5 * dt, k2), u, wind)[0]
        k4 = _fixedwing_eval(k, _axpy(x, dt, k3), u, wind)[0]
        x = _axpy(x, dt / 6.0, _axpy(_axpy(_axpy(k1, 2.0, k2), 2.0, k3), 1.0, k4))  # x + dt/6 (k1 + 2k2 + 2k3 + k4)
    d, air = _fixedwing_eval(k, x, u, wind)
    return x, d, air


# compiled once per installation (numba's cache, visnav.jit); the same functions on floats otherwise
_fixedwing_eval, _axpy, _fixedwing = compiled(_fixedwing_eval), compiled(_axpy), compiled(_fixedwing)


def _floats(v) -> tuple:
    return tuple(map(float, v))


def fixedwing_derivatives(k, x, u, wind, air: bool = False):
    """``fixedwing.derivatives(p, x, u, wind, gam)[0]`` on floats: ``k`` from :func:`fixedwing_constants`, ``x`` 12
    floats, ``u`` (aileron, elevator, rudder, throttle), ``wind`` (n, e, d). ``air``: also (Va, alpha, beta, specific
    force), ``derivatives(...)[1]``'s values."""
    _, dx, air_data = _fixedwing(k, _floats(x), _floats(u), _floats(wind), 0.0)
    return (list(dx), air_data) if air else list(dx)


def fixedwing_rk4(k, x, u, wind, dt: float, air: bool = False):
    """One classic RK4 step of :func:`fixedwing_derivatives` (``FixedWingModel.step``'s, without the yaw wrap): the new
    state (12 floats); ``air``: also the air data at it (what ``fixedwing_derivatives(..., air=True)[1]`` gives)."""
    x1, _, air_data = _fixedwing(k, _floats(x), _floats(u), _floats(wind), float(dt))
    return (list(x1), air_data) if air else list(x1)


def rmax_constants(P) -> tuple:
    """What the R-MAX kernel reads of ``RmaxParams`` ``P``: (Xu, Yv, Zw, g, 1.0 where the YACS holds the climb rate
    (``heave_damping = "yacs"``) else 0.0). Taken at each call (the parameters are a mutable dataclass)."""
    return (float(P.Xu), float(P.Yv), float(P.Zw), float(P.g), 1.0 if P.heave_damping == "yacs" else 0.0)


def _rmax_eval(k, y, att, wind):
    """Seed 002 eq. 3.9 with the thrust of eq. 3.10 (``rmax.RmaxModel._deriv``) on floats: d/dt of
    (u v w N E D ψ w_yacs) and the specific force, ``att`` = (φ, θ, p, q, r, ΔaZ)."""
    Xu, Yv, Zw, g, yacs = k
    u, v, w, psi, w_yacs = y[0], y[1], y[2], y[6], y[7]
    phi, theta, p, q, r, az = att
    wn, we, wd = wind
    cf, sf, ct, st = cos(phi), sin(phi), cos(theta), sin(theta)
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = _dcm_rows_c(cf, sf, ct, st, cos(psi), sin(psi))  # eq. 3.2
    ua = u - (c00 * wn + c10 * we + c20 * wd)  # body velocity relative to the air
    va = v - (c01 * wn + c11 * we + c21 * wd)
    wa = w - (c02 * wn + c12 * we + c22 * wd)
    fx, fy, fz = Xu * ua, Yv * va, Zw * (wa - yacs * w_yacs) - g * (1.0 + az)
    dy = (fx - (q * w - r * v) + g * c20,  # eq. 3.9: f − ω × v + C_nb (0, 0, g)
          fy - (r * u - p * w) + g * c21,
          fz - (p * v - q * u) + g * c22,
          c00 * u + c01 * v + c02 * w, c10 * u + c11 * v + c12 * w, c20 * u + c21 * v + c22 * w,
          (q * sf + r * cf) / ct,  # ψ̇, eq. 3.7
          -g * az)
    return dy, (fx, fy, fz)


def _axpy8(x, h, d):
    """x + h d on 8-tuples (the R-MAX RK4's stage state)."""
    return (x[0] + h * d[0], x[1] + h * d[1], x[2] + h * d[2], x[3] + h * d[3], x[4] + h * d[4], x[5] + h * d[5],
            x[6] + h * d[6], x[7] + h * d[7])


def _rmax(k, y, a0, ah, a1, wind, dt):
    """``RmaxModel.step``'s classic RK4 of :func:`_rmax_eval` over ``dt``, the attitude at t, t + dt/2 and t + dt; and
    the specific force at the new state (what the step reports: one call instead of a second one for it)."""
    k1 = _rmax_eval(k, y, a0, wind)[0]
    k2 = _rmax_eval(k, _axpy8(y, 0.5 * dt, k1), ah, wind)[0]
    k3 = _rmax_eval(k, _axpy8(y, 0.5 * dt, k2), ah, wind)[0]
    k4 = _rmax_eval(k, _axpy8(y, dt, k3), a1, wind)[0]
    y1 = _axpy8(y, dt / 6.0, _axpy8(_axpy8(_axpy8(k1, 2.0, k2), 2.0, k3), 1.0, k4))  # y + dt/6 (k1 + 2k2 + 2k3 + k4)
    return y1, _rmax_eval(k, y1, a1, wind)[1]


# compiled once per installation (numba's cache, visnav.jit); the same functions on floats otherwise
_dcm_rows_c = compiled(_dcm_rows)
_rmax_eval, _axpy8, _rmax = compiled(_rmax_eval), compiled(_axpy8), compiled(_rmax)


def rmax_derivatives(P, y, att, wind, force: bool = False):
    """``rmax.RmaxModel._deriv(y, att, wind)[0]`` on floats: d/dt of (u v w N E D ψ w_yacs); ``P`` the model's
    ``RmaxParams``, ``att`` (φ, θ, p, q, r, ΔaZ). ``force``: also the specific force (``_deriv(...)[1]``)."""
    dy, f = _rmax_eval(rmax_constants(P), _floats(y), _floats(att), _floats(wind))
    return (list(dy), f) if force else list(dy)


def rmax_rk4(P, y, a0, ah, a1, wind, dt: float) -> tuple[list[float], tuple]:
    """``RmaxModel.step``'s RK4 of eq. 3.9 (:func:`_rmax`) with the attitude at t, t + dt/2 and t + dt: the new
    state (8 floats) and the specific force at it (``rmax_derivatives(P, y1, a1, wind, True)[1]``)."""
    y1, f = _rmax(rmax_constants(P), _floats(y), _floats(a0), _floats(ah), _floats(a1), _floats(wind), float(dt))
    return list(y1), f
