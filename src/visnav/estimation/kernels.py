"""Per-sample kernels of ``estimation`` kept apart from the readable equations they reproduce (issue #31).

``ins.StrapdownINS.propagate`` integrates eq. A.1 with numpy on 3- and 4-vectors, where numpy's per-call
overhead is most of the cost at the IMU rate. :func:`ins_propagate_flat` evaluates the same steps on Python
floats for a flat, non-rotating Earth with constant gravity (the navigators' case). It is not the model: a change
is made in ``ins.py`` and then here; ``tests/estimation/test_kernels.py`` holds it to ``propagate`` at 1e-12.
``StrapdownINS.kernel = False`` propagates on the readable path.
"""

from __future__ import annotations

from math import cos, sin, sqrt


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
