"""Real-time factor of one closed-loop scenario; optionally dump its metrics and log for diffing.

    PYTHONPATH=src python benchmarks/rtf.py SCENARIO [--seed N] [--set KEY=VALUE ...] [--warm] [--dump FILE.npz] [--profile] [--cv2-threads N]

Prints one JSON line: simulated time, wall and CPU time of ``run()`` (process CPU, so the render
thread counts), main-thread CPU and the real-time factors. ``--warm`` first flies seed N + 1 of the same scenario
in the same process, untimed, so that the timed run is what every further run of a campaign worker costs: the
one-off costs of a process (importing, loading numba's cached kernels, first-call allocations) are then reported
apart, as ``first_run_wall_s`` (issue #31: a compiled kernel's load is measured against a campaign). Run it with
another checkout's ``PYTHONPATH`` to compare commits (``benchmarks/compare.py`` interleaves two).
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def run(name: str, seed: int = 1, dump: str | None = None, profile: bool = False, overrides=(),
        warm: bool = False) -> dict:
    from visnav.scenarios.schema import load_scenario

    try:
        from visnav.app.missions import make_simulation
    except ImportError:  # a checkout from before the run assembly moved to visnav.app (issue #31)
        from visnav.sim.missions import make_simulation

    from visnav.sensors import camera

    first = None
    if warm:  # a campaign worker's later runs: another seed flown first, in this process
        w0 = time.perf_counter()
        make_simulation(load_scenario(name, list(overrides), seed=seed + 1)).run()
        first = time.perf_counter() - w0
    sc = load_scenario(name, list(overrides), seed=seed)
    sim = make_simulation(sc)
    waited = [0.0, 0]
    result = camera.PendingFrame.result

    def timed_result(self):  # what the loop still waits on the render thread
        if self.future.done():
            return result(self)
        w = time.perf_counter()
        out = result(self)
        waited[0] += time.perf_counter() - w
        waited[1] += 1  # frames not rendered yet when the loop took them
        return out

    camera.PendingFrame.result = timed_result
    prof = None
    if profile:
        from pyinstrument import Profiler

        prof = Profiler(interval=0.0005)
        prof.start()
    w0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
    res = sim.run()
    wall, cpu, main = time.perf_counter() - w0, time.process_time() - c0, time.thread_time() - m0
    camera.PendingFrame.result = result
    if prof is not None:
        prof.stop()
        print(prof.output_text(unicode=False, color=False, show_all=False))
    m = res.metrics
    sim_t = float(m.get("sim_time_s", np.nan))
    out = {"scenario": name, "seed": seed, "sim_s": sim_t, "wall_s": wall, "cpu_s": cpu, "main_cpu_s": main,
           "rtf_wall": sim_t / wall, "rtf_cpu": sim_t / cpu, "render_wait_s": waited[0], "frames_waited_on": waited[1],
           "load": os.getloadavg()[0], "error": res.error, "warm": warm, "first_run_wall_s": first}
    if dump:
        arrays = {}
        for s in res.log.streams():
            for k, v in res.log.get(s).items():
                if v.dtype != object:
                    arrays[f"{s}/{k}"] = v
        metrics = {k: v for k, v in m.items() if k not in ("wall_time_s", "real_time_factor")}
        arrays["__metrics__"] = np.array(json.dumps(metrics, default=str, sort_keys=True))
        np.savez(dump, **arrays)
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dump")
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--warm", action="store_true", help="fly seed + 1 first, untimed (a campaign worker's later runs)")
    ap.add_argument("--cv2-threads", type=int, help="cv2.setNumThreads before the run (default: OpenCV's own)")
    ap.add_argument("--set", action="append", default=[], help="override a scenario key (KEY=VALUE), repeatable")
    a = ap.parse_args()
    if a.cv2_threads is not None:
        import cv2

        cv2.setNumThreads(a.cv2_threads)
    print(json.dumps(run(a.scenario, a.seed, a.dump, a.profile, a.set, a.warm)))
