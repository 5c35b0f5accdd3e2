"""CONDOR (issue #7): real-time factor of the vision orbit, and the cost of its pieces."""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from visnav.vehicles.base import Environment

from visnav.scenarios.schema import load_scenario
from visnav.app.missions import make_simulation


def _per_call(fn, n: int) -> float:
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n


def main(seed: int = 1, profile: bool = False) -> dict:
    from visnav.sensors.condor_camera import TargetCamera, condor_camera, target_outline
    from visnav.vehicles.fixedwing import FixedWingModel, FixedWingParams, trim
    from visnav.vision.blob_tracker import BlobTracker

    rows: dict = {}
    sc = load_scenario("condor-orbit", seed=seed)
    t0 = time.perf_counter()
    sim = make_simulation(sc)
    rows["setup_s (trim + distortion table)"] = time.perf_counter() - t0
    if profile:
        from pyinstrument import Profiler

        p = Profiler()
        p.start()
    m = sim.run().metrics
    if profile:
        p.stop()
        print(p.output_text(unicode=False, color=False, show_all=False)[:6000])
    rows["condor-orbit sim_time_s"] = m["sim_time_s"]
    rows["condor-orbit wall_time_s"] = m["wall_time_s"]
    rows["condor-orbit real_time_factor"] = m["real_time_factor"]
    t0 = time.perf_counter()
    make_simulation(load_scenario("condor-ground-test", seed=seed)).run()
    rows["condor-ground-test wall_time_s (12 rows, 3 pipelines)"] = time.perf_counter() - t0
    par = FixedWingParams()
    tr = trim(par, 17.0)
    fw = FixedWingModel.from_trim(par, tr, [0, 0, -100], 0.0)
    rows["fixed-wing RK4 step [us]"] = 1e6 * _per_call(lambda: fw.step(tr.controls, 0.01, Environment(np.zeros(3))), 2000)
    cam = condor_camera(640, 480, 53.0, -0.25, 0.05, 12.0, -7.0)
    tc = TargetCamera(cam, np.random.default_rng(0))
    out = target_outline([110.0, 0.0], 3.0, 2.0, 0.3)
    pose = ([0, 0, -100.0], 0.0, -math.atan2(100, 110), 0.0)
    rows["render 640x480 frame [ms]"] = 1e3 * _per_call(lambda: tc.render(*pose, out), 200)
    img = tc.render(*pose, out)
    bt = BlobTracker()
    bt.start(330, 232)
    rows["blob tracker [ms]"] = 1e3 * _per_call(lambda: bt.track(img), 200)
    print("| case | value |\n|---|---:|")
    for k, v in rows.items():
        print(f"| {k} | {v:.2f} |")
    return rows


if __name__ == "__main__":
    main(profile="--profile" in sys.argv)
