"""Pad landing (issue #15): detection + pose time per 640x480 frame at several heights (CPU time, the
machine is shared), and the real-time factor of a short pad landing.

    PYTHONPATH=src python benchmarks/bench_pad.py
"""

from __future__ import annotations

import time

import cv2
import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.pad import PadLayout
from visnav.sensors.pad_camera import PadSceneRenderer
from visnav.vision.ellipses import detect_rings
from visnav.vision.pad import PadDetector
from visnav.world.pad import pad_board
from visnav.world.scene import World
from visnav.world.textures import landing_field
from visnav.world.wind import SteadyWind, Wind


def _look(pos):
    z = -pos / np.linalg.norm(pos)
    x = np.array([0.0, 1.0, 0.0]) - z * z[1]
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def frames(heights=(20.0, 10.0, 3.0, 1.2)):
    rng = np.random.default_rng(0)
    layout = PadLayout()
    cam = PinholeCamera.ideal(640, 480, 640.0)
    world = World(ground=landing_field("asphalt", 60.0, 0.02, rng=rng), surface="asphalt",
                  wind=Wind(SteadyWind(0.0, 0.0), None))
    sc = PadSceneRenderer(cam, pad_board(layout, 0.002, rng), rng)
    out = {}
    for h in heights:
        pos = np.array([0.1 * h, -0.08 * h, -h])
        img = sc.render(pos, _look(pos), world)
        out[h] = cv2.add(img, rng.normal(0, 2, img.shape).round().astype(np.int16), dtype=cv2.CV_8U)
    return layout, cam, out


def _blocks(fn, blocks: int, n: int) -> tuple[float, float]:
    """(min, median) over ``blocks`` blocks of ``n`` calls of the per-call CPU time [ms]: the minimum is the
    figure least disturbed by other load on a shared machine, the median shows the scatter."""
    per = []
    for _ in range(blocks):
        t0 = time.process_time()
        for _ in range(n):
            out = fn()
        per.append((time.process_time() - t0) / n)
    return 1e3 * min(per), 1e3 * float(np.median(per)), out


def bench_detection(blocks: int = 10, n: int = 5) -> dict:
    layout, cam, imgs = frames()
    det = PadDetector(layout, cam.K)
    res = {}
    cv2.setNumThreads(1)  # one core's work per frame (the loop renders on the other)
    try:
        for h, img in imgs.items():
            det.detect(img)
            tot_min, tot_med, d = _blocks(lambda: det.detect(img), blocks, n)
            ring_min, ring_med, _ = _blocks(lambda: detect_rings(img), blocks, n)
            res[h] = (tot_min, tot_med, ring_min, ring_med, d.pose.config if d.pose else None, len(d.rings))
    finally:
        cv2.setNumThreads(-1)
    return res


def bench_landing() -> tuple[float, float, float]:
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    sc = load_scenario("pad-landing", ["mission.start_height_m=5.0", "mission.start_ne_m=[1.0, -0.8]",
                                       "mission.settle_s=1.0", "mission.slow_height_m=3.0", "world.field_size_m=30.0"])
    sim = make_simulation(sc)
    c0 = time.process_time()
    res = sim.run()
    cpu = time.process_time() - c0
    m = res.metrics
    return m["sim_time_s"], m["real_time_factor"], m["sim_time_s"] / cpu


def main() -> None:
    print("| height | detection + pose, ms / frame (CPU, min / median of 10 blocks) | of which ring detection "
          "| configuration | rings |")
    print("|---|---:|---:|---:|---:|")
    for h, (tmin, tmed, rmin, rmed, cfg, n) in bench_detection().items():
        print(f"| {h:g} m | {tmin:.1f} / {tmed:.1f} | {rmin:.1f} / {rmed:.1f} | {cfg} | {n} |")
    sim_t, rtf, rtf_cpu = bench_landing()
    print(f"\npad landing from 5 m ({sim_t:.1f} s simulated): real-time factor {rtf:.2f} wall, {rtf_cpu:.2f} CPU")


if __name__ == "__main__":
    main()
