"""Integration error of the fixed-wing model (vehicles/fixedwing.py) at the loop step, against a 10x finer
reference: RK4 (what FixedWingModel.step does), RK3 and Heun at dt = 0.01 s vs RK4 at dt = 0.001 s, from
trim at 17 m/s in a steady wind, with slow aileron / elevator sines held over the autopilot's 0.02 s period.

    PYTHONPATH=src python benchmarks/fixedwing_integration_error.py

Prints the largest state differences over 30 s (sampled at 10 Hz). Used to decide whether a cheaper scheme
than RK4 would be "exact enough" (BENCHMARKS.md, speed round 3).
"""

import math

import numpy as np

from visnav.measurements import Controls
from visnav.vehicles.fixedwing import FixedWingModel, default_trim, derivatives


def main(T: float = 30.0) -> None:
    p, tr = default_trim(17.0)
    m = FixedWingModel.from_trim(p, tr, np.zeros(3), 0.3)
    u0 = m._clip(tr.controls)
    u0 = (u0.aileron, u0.elevator, u0.rudder, u0.throttle)
    w = np.array([2.0, -1.5, 0.2])

    def f(_k, x, uc, wind):  # the model's one derivative function (eq. 3.14-3.17), as a list
        return derivatives(p, np.asarray(x, float), Controls(*uc), wind)[0].tolist()

    k = None

    def ctrl(t):  # held over each 0.02 s control period, as the autopilot does
        tc = math.floor(t / 0.02 + 1e-9) * 0.02
        return (u0[0] + 0.05 * math.sin(1.3 * tc), u0[1] + 0.03 * math.sin(0.7 * tc), u0[2], u0[3])

    def run(scheme: str, dt: float) -> np.ndarray:
        x, out = m.x.tolist(), []
        n = int(round(T / dt))
        for i in range(n):
            uc = ctrl(i * dt)
            k1 = f(k, x, uc, w)
            if scheme == "rk4":
                k2 = f(k, [a + 0.5 * dt * b for a, b in zip(x, k1)], uc, w)
                k3 = f(k, [a + 0.5 * dt * b for a, b in zip(x, k2)], uc, w)
                k4 = f(k, [a + dt * b for a, b in zip(x, k3)], uc, w)
                x = [a + dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
            elif scheme == "rk3":
                k2 = f(k, [a + 0.5 * dt * b for a, b in zip(x, k1)], uc, w)
                k3 = f(k, [a - dt * b1 + 2 * dt * b2 for a, b1, b2 in zip(x, k1, k2)], uc, w)
                x = [a + dt / 6 * (b1 + 4 * b2 + b3) for a, b1, b2, b3 in zip(x, k1, k2, k3)]
            else:  # Heun
                k2 = f(k, [a + dt * b for a, b in zip(x, k1)], uc, w)
                x = [a + 0.5 * dt * (b1 + b2) for a, b1, b2 in zip(x, k1, k2)]
            q = (i + 1) * dt / 0.1
            if abs(round(q) - q) < 1e-9:
                out.append(x[:])
        return np.array(out)

    ref = run("rk4", 0.001)
    for sc in ("rk4", "rk3", "heun"):
        d = np.abs(run(sc, 0.01) - ref)
        print(f"{sc:5s} dt=0.01 vs RK4 dt=0.001 over {T:.0f} s: max |pos| {d[:, :3].max():.2e} m, "
              f"|uvw| {d[:, 3:6].max():.2e} m/s, |euler| {d[:, 6:9].max():.2e} rad, |pqr| {d[:, 9:].max():.2e} rad/s")


if __name__ == "__main__":
    main()
