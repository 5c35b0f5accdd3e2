"""Per-step kernels kept apart from the readable models they reproduce (issue #31 item 2).

The models are written once, in the form of their equations (``vehicles/fixedwing.derivatives``: Beard &
McLain eq. 3.14-3.17 and 4.6-4.19). A simulation steps the fixed wing 100 times a second through four
evaluations of those equations; on 3-vectors numpy's per-call overhead is most of the cost (~27 us per
evaluation against ~6 us on floats), which halved CONDOR's real-time factor. This module evaluates the same
equations, term for term and in the same order, on Python floats. It is not the model: a change to the physics
is made in ``fixedwing.derivatives`` and then here, and ``tests/vehicles/test_kernels.py`` holds every kernel to
its readable reference at 1e-12 relative (random states, controls and winds, and a whole flight).
``FixedWingModel(kernel=False)`` flies the readable path.
"""

from __future__ import annotations

import math

from visnav.geometry.rotations import _dcm_rows

G = 9.81


def fixedwing_derivatives(p, gam, lift_drag, x, u, wind) -> list[float]:
    """``fixedwing.derivatives(p, x, u, wind, gam)[0]`` on floats: ``x`` 12 floats, ``u`` (aileron, elevator,
    rudder, throttle), ``wind`` (n, e, d); ``lift_drag`` is ``fixedwing._lift_drag``."""
    _, _, _, uu, vv, ww, phi, th, psi, P, Q, R = x
    da, de, dr, dt = u
    wn, we, wd = wind
    cf, sf, ct, st = math.cos(phi), math.sin(phi), math.cos(th), math.sin(th)
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = _dcm_rows(cf, sf, ct, st, math.cos(psi), math.sin(psi))
    ur = uu - (c00 * wn + c10 * we + c20 * wd)  # eq. 2.7: body velocity minus C^T wind
    vr = vv - (c01 * wn + c11 * we + c21 * wd)
    wr = ww - (c02 * wn + c12 * we + c22 * wd)
    Va = math.sqrt(ur * ur + vr * vr + wr * wr)  # eq. 2.8
    Va_s = max(Va, 1.0)
    alpha = math.atan2(wr, ur)
    beta = math.asin(max(-1.0, min(1.0, vr / Va_s)))
    qbar = 0.5 * p.rho * Va_s * Va_s * p.S
    cl, cd = lift_drag(p, alpha)
    ca, sa = math.cos(alpha), math.sin(alpha)
    cx, cxq, cxde = -cd * ca + cl * sa, -p.C_D_q * ca + p.C_L_q * sa, -p.C_D_de * ca + p.C_L_de * sa  # eq. 4.19
    cz, czq, czde = -cd * sa - cl * ca, -p.C_D_q * sa - p.C_L_q * ca, -p.C_D_de * sa - p.C_L_de * ca
    c2v, b2v = p.c / (2.0 * Va_s), p.b / (2.0 * Va_s)
    m = p.mass
    thrust = 0.5 * p.rho * p.S_prop * p.C_prop * ((p.k_motor * dt) ** 2 - Va * Va)  # eq. 4.18
    fx = -m * G * st + qbar * (cx + cxq * c2v * Q + cxde * de) + thrust
    fy = m * G * ct * sf + qbar * (p.C_Y_0 + p.C_Y_beta * beta + p.C_Y_p * b2v * P + p.C_Y_r * b2v * R
                                   + p.C_Y_da * da + p.C_Y_dr * dr)
    fz = m * G * ct * cf + qbar * (cz + czq * c2v * Q + czde * de)
    l_m = qbar * p.b * (p.C_l_0 + p.C_l_beta * beta + p.C_l_p * b2v * P + p.C_l_r * b2v * R
                        + p.C_l_da * da + p.C_l_dr * dr)
    m_m = qbar * p.c * (p.C_m_0 + p.C_m_alpha * alpha + p.C_m_q * c2v * Q + p.C_m_de * de)
    n_m = qbar * p.b * (p.C_n_0 + p.C_n_beta * beta + p.C_n_p * b2v * P + p.C_n_r * b2v * R
                        + p.C_n_da * da + p.C_n_dr * dr)
    g1, g2, g3, g4, g5, g6, g7, g8 = gam
    tt = st / ct
    return [c00 * uu + c01 * vv + c02 * ww, c10 * uu + c11 * vv + c12 * ww, c20 * uu + c21 * vv + c22 * ww,  # 3.14
            R * vv - Q * ww + fx / m, P * ww - R * uu + fy / m, Q * uu - P * vv + fz / m,  # eq. 3.15
            P + sf * tt * Q + cf * tt * R, cf * Q - sf * R, (sf * Q + cf * R) / ct,  # eq. 3.16
            g1 * P * Q - g2 * Q * R + g3 * l_m + g4 * n_m,  # eq. 3.17
            g5 * P * R - g6 * (P * P - R * R) + m_m / p.Jy,
            g7 * P * Q - g1 * Q * R + g4 * l_m + g8 * n_m]


def fixedwing_rk4(p, gam, lift_drag, x, u, wind, dt: float) -> list[float]:
    """One classic RK4 step of :func:`fixedwing_derivatives` (``FixedWingModel.step``'s, without the yaw wrap)."""
    def f(s):
        return fixedwing_derivatives(p, gam, lift_drag, s, u, wind)

    h = 0.5 * dt
    k1 = f(x)
    k2 = f([a + h * b for a, b in zip(x, k1)])
    k3 = f([a + h * b for a, b in zip(x, k2)])
    k4 = f([a + dt * b for a, b in zip(x, k3)])
    w = dt / 6.0
    return [a + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]


def rmax_derivatives(P, y, att, wind) -> list[float]:
    """``rmax.RmaxModel._deriv(y, att, wind)[0]`` on floats (seed 002 eq. 3.9 with the thrust of eq. 3.10):
    d/dt of (u v w N E D ψ w_yacs); ``P`` the model's ``RmaxParams``, ``att`` (φ, θ, p, q, r, ΔaZ)."""
    u, v, w, _, _, _, psi, w_yacs = y
    phi, theta, p, q, r, az = att
    wn, we, wd = wind
    cf, sf, ct, st = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = _dcm_rows(cf, sf, ct, st, math.cos(psi), math.sin(psi))
    ua = u - (c00 * wn + c10 * we + c20 * wd)  # body velocity relative to the air
    va = v - (c01 * wn + c11 * we + c21 * wd)
    wa = w - (c02 * wn + c12 * we + c22 * wd)
    w_hold = w_yacs if P.heave_damping == "yacs" else 0.0
    fx, fy, fz = P.Xu * ua, P.Yv * va, P.Zw * (wa - w_hold) - P.g * (1.0 + az)
    return [fx - (q * w - r * v) + P.g * c20,  # eq. 3.9: f − ω × v + C_nb (0, 0, g)
            fy - (r * u - p * w) + P.g * c21,
            fz - (p * v - q * u) + P.g * c22,
            c00 * u + c01 * v + c02 * w, c10 * u + c11 * v + c12 * w, c20 * u + c21 * v + c22 * w,
            (q * sf + r * cf) / ct,  # ψ̇, eq. 3.7
            -P.g * az]


def rmax_rk4(P, y, a0, ah, a1, wind, dt: float) -> list[float]:
    """``RmaxModel.step``'s RK4 of :func:`rmax_derivatives` with the attitude at t, t + dt/2 and t + dt."""
    h = 0.5 * dt
    k1 = rmax_derivatives(P, y, a0, wind)
    k2 = rmax_derivatives(P, [a + h * b for a, b in zip(y, k1)], ah, wind)
    k3 = rmax_derivatives(P, [a + h * b for a, b in zip(y, k2)], ah, wind)
    k4 = rmax_derivatives(P, [a + dt * b for a, b in zip(y, k3)], a1, wind)
    return [a + dt * (b1 + 2.0 * b2 + 2.0 * b3 + b4) / 6.0 for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4)]
