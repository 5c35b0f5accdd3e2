"""Per-sample kernels of ``estimation`` kept apart from the readable equations they reproduce (issue #31).

``ins.StrapdownINS.propagate`` integrates eq. A.1 with numpy on 3- and 4-vectors, where numpy's per-call
overhead is most of the cost at the IMU rate. :func:`ins_propagate_flat` evaluates the same steps on Python
floats for a flat, non-rotating Earth with constant gravity (the navigators' case). It is not the model: a change
is made in ``ins.py`` and then here; ``tests/estimation/test_kernels.py`` holds it to ``propagate`` at 1e-12.
``StrapdownINS.kernel = False`` propagates on the readable path.
"""

from __future__ import annotations

from math import cos, sin, sqrt

import numpy as np

from visnav.jit import compiled, njit  # noqa: F401 (njit: whether the deck kernels are compiled)


def _quat_exp(x, y, z):
    """``ins._quat_exp`` (the exponential map of the rotation vector (x, y, z)) on floats."""
    a = sqrt(x * x + y * y + z * z)
    k = sin(0.5 * a) / (a + (a == 0.0))
    return cos(0.5 * a), k * x, k * y, k * z


def _hamilton(pw, px, py, pz, qw, qx, qy, qz):
    """``ins._hamilton``: p ⊗ q."""
    return (pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw)


def ins_propagate_flat(q, v, p, f, w, g, dt: float):
    """``StrapdownINS.propagate`` without the Earth's rates and with constant gravity ``g``: the quaternion ``q``
    (w, x, y, z), velocity ``v`` and position ``p`` advanced by ``dt`` under the specific force ``f`` and body rate
    ``w`` (less their biases), all floats; returns (q, v, p) as lists."""
    w0, w1, w2 = w
    h = 0.5 * dt
    qw, qx, qy, qz = _hamilton(*q, *_quat_exp(w0 * h, w1 * h, w2 * h))  # the mid-interval attitude
    q1 = _hamilton(*q, *_quat_exp(w0 * dt, w1 * dt, w2 * dt))
    n = sqrt(q1[0] * q1[0] + q1[1] * q1[1] + q1[2] * q1[2] + q1[3] * q1[3])
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)  # ins._quat_dcm_rows
    C = ((1 - s * (qy * qy + qz * qz), s * (qx * qy - qw * qz), s * (qx * qz + qw * qy)),
         (s * (qx * qy + qw * qz), 1 - s * (qx * qx + qz * qz), s * (qy * qz - qw * qx)),
         (s * (qx * qz - qw * qy), s * (qy * qz + qw * qx), 1 - s * (qx * qx + qy * qy)))
    f0, f1, f2 = f
    v1 = [vi + (c0 * f0 + c1 * f1 + c2 * f2 + gi) * dt for vi, (c0, c1, c2), gi in zip(v, C, g)]  # eq. A.1
    return [x / n for x in q1], v1, [pi + 0.5 * (a + b) * dt for pi, a, b in zip(p, v, v1)]


def quat_step(q, w, dt: float) -> tuple:
    """``ins.quat_mult(q, ins.quat_from_rotvec(w dt))`` on floats: the quaternion ``q`` (w, x, y, z) turned by the body
    rates ``w`` (three floats) held over ``dt``."""
    return _hamilton(*q, *_quat_exp(w[0] * dt, w[1] * dt, w[2] * dt))


# ------------------------------------------------------------------ the deck UKF's prediction (seed 003)
# ``estimation/deck.process_model`` and ``process_noise`` are array expressions over a few 3x3 matrices; at the
# IMU rate numpy's per-call overhead is most of their cost (~50 and ~40 us a step). These loops evaluate the same
# equations element by element and only pay compiled: ``navigation/deck`` uses them where ``visnav.jit.njit``
# exists and the readable functions otherwise. tests/estimation/test_kernels.py holds both to the readable
# functions at 1e-12.

def _euler_dcm_rate(phi, theta, psi):
    """C = euler_to_dcm (seed 002 eq. 3.2, rotations._dcm_rows) and E = euler_rate_matrix (eq. 3.7) as 9 + 9
    floats, row by row."""
    cf, sf, ct, st, cp, sp = cos(phi), sin(phi), cos(theta), sin(theta), cos(psi), sin(psi)
    tt = st / ct
    return ((ct * cp, -cf * sp + sf * st * cp, sf * sp + cf * st * cp,
             ct * sp, cf * cp + sf * st * sp, -sf * cp + cf * st * sp,
             -st, sf * ct, cf * ct),
            (1.0, sf * tt, cf * tt, 0.0, cf, -sf, 0.0, sf / ct, cf / ct))


def _deck_process_model(sig, dt, accel, gyro, gyro_dot, g_body, aug):
    """``deck.process_model`` (eq. 3.1-3.5, 2.14) of the rows of ``sig`` (N, n >= 12); states 12-14 the
    accelerometer bias when ``aug``, later states copied."""
    out = sig.copy()
    w0, w1, w2 = gyro[0], gyro[1], gyro[2]
    # M = dw/dt x + w x (w x .) = [wdot]x + w w^T - (w.w) I: r @ M.T of eq. 3.5
    ww = w0 * w0 + w1 * w1 + w2 * w2
    m00, m01, m02 = w0 * w0 - ww, -gyro_dot[2] + w0 * w1, gyro_dot[1] + w0 * w2
    m10, m11, m12 = gyro_dot[2] + w1 * w0, w1 * w1 - ww, -gyro_dot[0] + w1 * w2
    m20, m21, m22 = -gyro_dot[1] + w2 * w0, gyro_dot[0] + w2 * w1, w2 * w2 - ww
    h = 0.5 * dt * dt
    for i in range(sig.shape[0]):
        r0, r1, r2 = sig[i, 0], sig[i, 1], sig[i, 2]
        v0, v1, v2 = sig[i, 6], sig[i, 7], sig[i, 8]
        f0, f1, f2 = accel[0], accel[1], accel[2]
        if aug:  # the bias estimate taken off the reading
            f0, f1, f2 = f0 - sig[i, 12], f1 - sig[i, 13], f2 - sig[i, 14]
        a0, a1, a2 = f0 + g_body[0], f1 + g_body[1], f2 + g_body[2]  # eq. 3.4
        vd0 = -a0 - (m00 * r0 + m01 * r1 + m02 * r2) - 2.0 * (w1 * v2 - w2 * v1)  # eq. 3.5
        vd1 = -a1 - (m10 * r0 + m11 * r1 + m12 * r2) - 2.0 * (w2 * v0 - w0 * v2)
        vd2 = -a2 - (m20 * r0 + m21 * r1 + m22 * r2) - 2.0 * (w0 * v1 - w1 * v0)
        C, E = _euler_dcm_rate(sig[i, 3], sig[i, 4], sig[i, 5])
        p, q, s = sig[i, 9], sig[i, 10], sig[i, 11]
        u0 = w0 - (C[0] * p + C[3] * q + C[6] * s)  # w_h - C^T w_d (eq. 2.14)
        u1 = w1 - (C[1] * p + C[4] * q + C[7] * s)
        u2 = w2 - (C[2] * p + C[5] * q + C[8] * s)
        out[i, 0], out[i, 1], out[i, 2] = r0 + v0 * dt + h * vd0, r1 + v1 * dt + h * vd1, r2 + v2 * dt + h * vd2
        out[i, 3] += (E[0] * u0 + E[1] * u1 + E[2] * u2) * dt  # eq. 3.2
        out[i, 4] += (E[3] * u0 + E[4] * u1 + E[5] * u2) * dt
        out[i, 5] += (E[6] * u0 + E[7] * u1 + E[8] * u2) * dt
        out[i, 6], out[i, 7], out[i, 8] = v0 + vd0 * dt, v1 + vd1 * dt, v2 + vd2 * dt
    return out


def _add_abat(A, B, out):
    """out += A B A^T (A: (n, k), B: (k, k))."""
    n, k = A.shape
    for i in range(n):
        for a in range(k):
            ab = 0.0
            for b in range(k):
                ab += A[i, b] * B[b, a]
            if ab != 0.0:
                for j in range(n):
                    out[i, j] += ab * A[j, a]


def _deck_process_noise(x, dt, gyro, imu_cov, ship_cov, n):
    """``deck.process_noise`` (eq. 3.8) at the mean ``x`` as an (n, n) matrix with the thesis' Q in its 12 x 12
    top-left block (the rest zero)."""
    r0, r1, r2, v0, v1, v2 = x[0], x[1], x[2], x[6], x[7], x[8]
    w0, w1, w2 = gyro[0], gyro[1], gyro[2]
    C, E = _euler_dcm_rate(x[3], x[4], x[5])
    wr = w0 * r0 + w1 * r1 + w2 * r2
    # d vdot / d w: 2 [v]x + 2 r w^T - (w.r) I - w r^T
    D = np.empty((3, 3))
    rr, ww_ = (r0, r1, r2), (w0, w1, w2)
    for i in range(3):
        for j in range(3):
            D[i, j] = 2.0 * rr[i] * ww_[j] - ww_[i] * rr[j] - (wr if i == j else 0.0)
    D[0, 1] -= 2.0 * v2
    D[0, 2] += 2.0 * v1
    D[1, 0] += 2.0 * v2
    D[1, 2] -= 2.0 * v0
    D[2, 0] -= 2.0 * v1
    D[2, 1] += 2.0 * v0
    h = 0.5 * dt * dt
    Fz = np.zeros((12, 6))
    Fs = np.zeros((12, 6))
    for i in range(3):
        Fz[i, i], Fz[6 + i, i] = -h, -dt
        Fs[9 + i, 3 + i] = dt
        for j in range(3):
            Fz[i, 3 + j], Fz[6 + i, 3 + j] = h * D[i, j], dt * D[i, j]
            Fz[3 + i, 3 + j] = dt * E[3 * i + j]
            Fs[i, j], Fs[6 + i, j] = h * C[3 * j + i], dt * C[3 * j + i]  # C^T
            ec = 0.0  # (E C^T)_ij
            for k in range(3):
                ec += E[3 * i + k] * C[3 * j + k]
            Fs[3 + i, 3 + j] = -h * ec
    Q = np.zeros((n, n))
    _add_abat(Fz, imu_cov, Q)
    _add_abat(Fs, ship_cov, Q)
    return Q


_euler_dcm_rate, _add_abat = compiled(_euler_dcm_rate), compiled(_add_abat)
_deck_process_model, _deck_process_noise = compiled(_deck_process_model), compiled(_deck_process_noise)


def deck_process_model(sig, dt, u, bias=None):
    """``deck.process_model(sig, dt, u, bias)`` through the kernel (same signature)."""
    aug = sig.shape[1] == 15 if bias is None else bool(bias)  # (as deck.process_model: N_AUGMENTED)
    return _deck_process_model(np.ascontiguousarray(sig, dtype=np.float64), float(dt), u.accel, u.gyro,
                               u.gyro_dot, u.gravity_body, aug)


def deck_process_noise(x, dt, u, imu_cov, ship_cov, n: int = 12):
    """``deck.process_noise(x, dt, u, imu_cov, ship_cov)`` through the kernel, in an (n, n) matrix (zero beyond
    the thesis' 12 states)."""
    return _deck_process_noise(np.ascontiguousarray(x, dtype=np.float64), float(dt), u.gyro,
                               np.ascontiguousarray(imu_cov, dtype=np.float64),
                               np.ascontiguousarray(ship_cov, dtype=np.float64), int(n))
