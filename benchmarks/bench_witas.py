"""Benchmark: the WITAS navigator's pieces and the whole witas-homing run (issue #5).

Run: ``PYTHONPATH=src python benchmarks/bench_witas.py [--no-run]``. Prints a markdown table;
``main()`` returns the numbers (milliseconds, medians over repeats).

* PMF update (eq. 5.26-5.30: translate + separable convolution + likelihood product + MV/covariance)
  on 80 x 80 and 200 x 200 grids;
* registration per frame (template build eq. 5.14 + NCC over a +-15 m window on the 1 m reference);
* odometry per frame (KLT 50 features + RANSAC + eq. 5.9) on rendered 384 x 288 frames at 60 m;
* our normalized DLT + RANSAC vs ``cv2.findHomography(RANSAC)`` on 50 correspondences, 30 % outliers;
* the whole default run: simulated time / wall time and / CPU time (``process_time``).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from visnav.estimation.pmf import PointMassFilter  # noqa: E402
from visnav.geometry.camera import PinholeCamera  # noqa: E402
from visnav.geometry.mounts import FixedMount  # noqa: E402
from visnav.geometry.rotations import euler_to_dcm  # noqa: E402
from visnav.sensors.camera import CameraRenderer  # noqa: E402
from visnav.vision.homography import ransac_homography  # noqa: E402
from visnav.vision.odometry import VisualOdometry  # noqa: E402
from visnav.vision.registration import MapRegistration  # noqa: E402
from visnav.world.maps import degrade_reference  # noqa: E402
from visnav.world.rural import rural_map  # noqa: E402
from visnav.world.scene import World  # noqa: E402


def _median_ms(fn, repeats: int) -> float:
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return 1e3 * float(np.median(ts))


def bench_pmf(n: int, repeats: int = 200) -> float:
    pmf = PointMassFilter([0.0, 0.0], size_m=float(n), resolution_m=1.0, sigma0_m=10.0)
    rng = np.random.default_rng(0)
    L = 0.02 + rng.random((n, n))

    def step():
        pmf.predict(rng.normal(0, 1.0, 2), 0.5)
        pmf.update(L)
        pmf.estimate()

    return _median_ms(step, repeats)


def _frames(n=40):
    g = rural_map(500.0, 0.25, np.random.default_rng(1), pond_ne=None)
    cam = PinholeCamera.ideal(384, 288, 463.0)
    mount = FixedMount.depressed(90)
    r = CameraRenderer(cam, 2.0, np.random.default_rng(0))
    w = World(ground=g, surface="grass", wind=None)
    out = []
    for k in range(n):
        p = np.array([-100 + 1.6 * k, 20.0, -60.0])
        e = np.array([0.02 * np.sin(k / 5), 0.03, 0.1])
        pos, C = mount.camera_pose(p, euler_to_dcm(e))
        out.append((r.render(pos, C, w), C, p, e))
    return g, cam, mount, out


def main(run: bool = True) -> dict:
    res = {"pmf_80_ms": bench_pmf(80), "pmf_200_ms": bench_pmf(200)}
    g, cam, mount, frames = _frames()
    ref = degrade_reference(g)
    reg = MapRegistration(ref, cam.K, mount)
    i = [0]

    def one_reg():
        img, C, p, e = frames[i[0] % len(frames)]
        i[0] += 1
        reg.register(img, e, 60.0, p[:2] + 3.0, 15.0)

    res["registration_ms"] = _median_ms(one_reg, 60)
    vo = VisualOdometry(cam.K, rng=np.random.default_rng(0))
    ts = []
    for img, C, p, e in frames:
        t = time.perf_counter()
        vo.step(0.0, img, C, 60.0)
        ts.append(time.perf_counter() - t)
    res["odometry_ms"] = 1e3 * float(np.median(ts[1:]))
    rng = np.random.default_rng(3)
    H = np.array([[1.01, 0.02, 4.0], [-0.02, 0.99, -3.0], [1e-5, -2e-5, 1.0]])
    x1 = rng.uniform(0, 384, (50, 2))
    q = np.c_[x1, np.ones(50)] @ H.T
    x2 = q[:, :2] / q[:, 2:] + rng.normal(0, 0.5, (50, 2))
    out = rng.random(50) < 0.3
    x2[out] += rng.uniform(10, 40, (out.sum(), 2))
    res["ransac_ours_ms"] = _median_ms(lambda: ransac_homography(x1, x2, 0.5, rng=np.random.default_rng(1)), 200)
    thr = float(np.sqrt(5.99) * 0.5)
    res["ransac_cv2_ms"] = _median_ms(lambda: cv2.findHomography(x1, x2, cv2.RANSAC, thr), 200)
    if run:
        from visnav.scenarios.schema import load_scenario
        from visnav.app.missions import make_simulation

        sim = make_simulation(load_scenario("witas-homing"))
        c0, m0 = time.process_time(), time.thread_time()
        r = sim.run()
        cpu, main_cpu = time.process_time() - c0, time.thread_time() - m0
        res["run_sim_s"] = r.metrics["sim_time_s"]
        res["run_wall_s"] = r.metrics["wall_time_s"]
        res["run_cpu_s"] = cpu  # both threads (loop + frame rendering)
        res["run_main_thread_cpu_s"] = main_cpu  # the loop alone: the wall floor on 2 free cores
        res["real_time_factor"] = r.metrics["real_time_factor"]
        res["real_time_factor_cpu"] = r.metrics["sim_time_s"] / cpu
    print("| what | ms |\n|---|---:|")
    for k, v in res.items():
        print(f"| {k} | {v:.3f} |")
    return res


if __name__ == "__main__":
    main(run="--no-run" not in sys.argv)
