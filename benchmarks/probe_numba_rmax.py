"""Probe: what a numba kernel of the R-MAX step buys a whole run (issue #19's "where it clearly pays").

    pip install numba   # not a dependency of visnav: this probe only
    PYTHONPATH=src python benchmarks/probe_numba_rmax.py [--scenario palace-landing] [--seeds 5]

The airborne step of ``vehicles/rmax.RmaxModel`` (ZOH channels, attitudes, RK4 of eq. 3.9, the specific force)
as one ``@njit`` function whose matrix products go through ``np.dot`` (the same BLAS calls, in the same shapes,
as the numpy path: that is what keeps it bit-identical; hand-written loops drift by ~1e-14 a step). The probe
patches ``RmaxModel.step`` while a run flies (the ground path and everything else stay numpy) and prints:

* the per-process fixed cost: ``import numba`` and the first call of the cached kernel (a fresh process each);
* the kernel against ``RmaxModel.step`` per call, and their largest difference over 2000 open-loop steps;
* per seed, the run's wall with and without the kernel (interleaved) and the metrics that differ (exactly).

It is a measurement, not a code path of the project.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import subprocess
import sys
import time

import numpy as np

try:
    from numba import njit
except ImportError:  # pragma: no cover - the probe's own dependency
    sys.exit("probe_numba_rmax: numba is not installed (pip install numba); visnav itself does not use it")


@njit(cache=True)
def _attitude(y, d2r):
    phi, theta, r, az = y[0] * d2r, y[1] * d2r, y[2] * d2r, y[3]
    phid, thetad = y[4] * d2r, y[5] * d2r
    cf, sf = math.cos(phi), math.sin(phi)
    q = (thetad + r * sf) / cf
    p = phid - (q * sf + r * cf) * math.tan(theta)
    return phi, theta, p, q, r, az


@njit(cache=True)
def _deriv(y, a, wind, P, out):
    Xu, Yv, Zw, g, yacs = P[0], P[1], P[2], P[3], P[4]
    phi, theta, p, q, r, az = a
    cf, sf, ct, st = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
    u, v, w, psi = y[0], y[1], y[2], y[6]
    cp, sp = math.cos(psi), math.sin(psi)
    R00, R01, R02 = ct * cp, -cf * sp + sf * st * cp, sf * sp + cf * st * cp
    R10, R11, R12 = ct * sp, cf * cp + sf * st * sp, -sf * cp + cf * st * sp
    R20, R21, R22 = -st, sf * ct, cf * ct
    wx, wy, wz = wind[0], wind[1], wind[2]
    ub = R00 * wx + R10 * wy + R20 * wz
    vb = R01 * wx + R11 * wy + R21 * wz
    wb = R02 * wx + R12 * wy + R22 * wz
    fx, fy = Xu * (u - ub), Yv * (v - vb)
    w_hold = y[7] if yacs != 0.0 else 0.0
    fz = Zw * (w - w_hold - wb) - g * (1.0 + az)
    out[0] = fx - q * w + r * v - g * st
    out[1] = fy - r * u + p * w + g * ct * sf
    out[2] = fz - p * v + q * u + g * ct * cf
    out[3] = R00 * u + R01 * v + R02 * w
    out[4] = R10 * u + R11 * v + R12 * w
    out[5] = R20 * u + R21 * v + R22 * w
    out[6] = (q * sf + r * cf) / ct
    out[7] = -g * az
    return fx, fy, fz


@njit(cache=True)
def step_air(Ad, Bd, Ah, Bh, CCA, x0, y, u, wind, dt, P):
    """(x1, y1, attitude at t + dt, specific force) of one airborne step."""
    n = x0.shape[0]
    xh = np.dot(Ah, x0) + np.dot(Bh, u)
    x1 = np.dot(Ad, x0) + np.dot(Bd, u)
    X = np.empty((n, 3))
    X[:, 0], X[:, 1], X[:, 2] = x0, xh, x1
    Y = np.dot(CCA, X)
    d2r = math.pi / 180.0
    a0, ah, a1 = _attitude(Y[:, 0], d2r), _attitude(Y[:, 1], d2r), _attitude(Y[:, 2], d2r)
    k1, k2, k3, k4, tmp = np.empty(8), np.empty(8), np.empty(8), np.empty(8), np.empty(8)
    h2 = 0.5 * dt
    _deriv(y, a0, wind, P, k1)
    for i in range(8):
        tmp[i] = y[i] + h2 * k1[i]
    _deriv(tmp, ah, wind, P, k2)
    for i in range(8):
        tmp[i] = y[i] + h2 * k2[i]
    _deriv(tmp, ah, wind, P, k3)
    for i in range(8):
        tmp[i] = y[i] + dt * k3[i]
    _deriv(tmp, a1, wind, P, k4)
    y1 = np.empty(8)
    for i in range(8):
        y1[i] = y[i] + dt * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) / 6.0
    f = _deriv(y1, a1, wind, P, tmp)
    return x1, y1, a1, f


def _compiled_step(self, command, dt=None, environment=None):
    """``RmaxModel.step`` with the airborne path in ``step_air`` (the ground path unchanged)."""
    from visnav.vehicles import rmax

    dt = self.dt if dt is None else float(dt)
    if self.on_ground:
        return _NUMPY_STEP(self, command, dt, environment)
    wind = np.zeros(3) if environment is None or environment.wind_ned is None else \
        np.asarray(environment.wind_ned, float)
    Ad, Bd, C, CA, Ah, Bh = self._matrices(dt)
    p = self.params
    P = np.array([p.Xu, p.Yv, p.Zw, p.g, 1.0 if p.heave_damping == "yacs" else 0.0])
    u = self._saturate(command)
    x1, y1, a1, _ = step_air(Ad, Bd, Ah, Bh, self._CCA, self._x, np.asarray(self._y, float), u, wind, dt, P)
    y1 = y1.tolist()
    row = rmax._dcm_bn(a1[0], a1[1], y1[6])[2]
    vd = row[0] * y1[0] + row[1] * y1[1] + row[2] * y1[2]
    if y1[5] >= 0.0 and vd > 0.0:  # touchdown, as the numpy path
        self.touchdown_speed = float(vd)
        self.on_ground = True
        y1[0] = y1[1] = y1[2] = y1[5] = y1[7] = 0.0
    self._x, self._y, self.last_input = x1, y1, u
    self.t = round(self.t + dt, 12)
    self.state = self._make_state(tuple(wind.tolist()), a1)
    return self.state


_NUMPY_STEP = None


@contextlib.contextmanager
def compiled():
    global _NUMPY_STEP
    from visnav.vehicles.rmax import RmaxModel

    _NUMPY_STEP = RmaxModel.step
    RmaxModel.step = _compiled_step
    try:
        yield
    finally:
        RmaxModel.step = _NUMPY_STEP


def _fixed_cost() -> str:
    code = ("import time,sys; t=time.perf_counter(); import numba; t1=time.perf_counter();"
            f"sys.path.insert(0, {str(__file__.rsplit('/', 1)[0])!r}); import probe_numba_rmax as p, numpy as np;"
            "z=np.zeros((14,14)); b=np.zeros((14,4)); t2=time.perf_counter();"
            "p.step_air(z,b,z,b,np.zeros((8,14)),np.zeros(14),np.zeros(8),np.zeros(4),np.zeros(3),0.01,"
            "np.array([-0.025,-0.1,-0.6,9.81,1.0])); t3=time.perf_counter();"
            "print(f'import numba {t1-t:.3f} s, first call of the cached kernel {t3-t2:.3f} s')")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenario", default="palace-landing")
    ap.add_argument("--seeds", type=int, default=5)
    a = ap.parse_args()
    from visnav.measurements import YacsCommand
    from visnav.scenarios.schema import load_scenario
    from visnav.sim.missions import make_simulation
    from visnav.vehicles.base import Environment
    from visnav.vehicles.rmax import RmaxModel

    t = time.perf_counter()
    ref, fast = RmaxModel(position=(0, 0, -20.0)), RmaxModel(position=(0, 0, -20.0))
    cmd, env = YacsCommand(t=0, ail=30, ele=-20, rud=10, thr=40), Environment(np.array([1.0, 2.0, 0.3]))
    with compiled():
        fast.step(cmd, 0.01, env)
    print(f"compile or cache load in this process: {time.perf_counter() - t:.2f} s; {_fixed_cost()} (fresh process)")
    ref.step(cmd, 0.01, env)
    worst = 0.0
    for _ in range(2000):
        ref.step(cmd, 0.01, env)
        with compiled():
            fast.step(cmd, 0.01, env)
        worst = max(worst, float(np.max(np.abs(np.subtract(ref._y, fast._y)))), float(np.max(np.abs(ref._x - fast._x))))
    n = 5000
    t = time.perf_counter()
    for _ in range(n):
        ref.step(cmd, 0.01, env)
    t_ref = (time.perf_counter() - t) / n
    with compiled():
        t = time.perf_counter()
        for _ in range(n):
            fast.step(cmd, 0.01, env)
        t_fast = (time.perf_counter() - t) / n
    print(f"RmaxModel.step {t_ref * 1e6:.1f} us, with the kernel {t_fast * 1e6:.1f} us a call; "
          f"largest difference over 2000 open-loop steps {worst:.3g}")
    print("| seed | wall numpy s | wall kernel s | metrics that differ |\n|---|---|---|---|")
    for seed in range(1, a.seeds + 1):
        walls, metrics = {}, {}
        for which in (("numpy", "kernel") if seed % 2 else ("kernel", "numpy")):
            sim = make_simulation(load_scenario(a.scenario, seed=seed))
            with compiled() if which == "kernel" else contextlib.nullcontext():
                t = time.perf_counter()
                res = sim.run()
                walls[which] = time.perf_counter() - t
            metrics[which] = {k: v for k, v in res.metrics.items() if k not in ("wall_time_s", "real_time_factor")}
        m0, m1 = metrics["numpy"], metrics["kernel"]
        diff = [k for k in m0 if not (m0[k] == m1[k] or (isinstance(m0[k], float) and math.isnan(m0[k])
                                                        and math.isnan(m1[k])))]
        print(f"| {seed} | {walls['numpy']:.2f} | {walls['kernel']:.2f} | {', '.join(diff) or 'none'} |")


if __name__ == "__main__":
    main()
