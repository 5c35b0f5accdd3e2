"""Per-call cost of condor-orbit's per-step blocks, on the scenario's own objects flown to the vision orbit.

    PYTHONPATH=src python benchmarks/bench_condor_steps.py [--blocks 10] [--at 90]
    python benchmarks/bench_condor_steps.py --ab BEFORE_SRC AFTER_SRC [--rounds 3]

Flies condor-orbit (seed 1) to ``--at`` seconds, then times each block on the live objects: thread CPU time
per call (``time.thread_time``), the minimum over ``--blocks`` blocks of calls (on a shared machine the least
disturbed block); prints one JSON line. The calls change the objects' state (random draws, filters): the
times are what a call costs, not a replay of the run. ``--ab`` alternates fresh processes of two checkouts
(``src`` directories) and prints a markdown table of the minimum per block over the rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_steps import _min_block  # noqa: E402  (thread CPU per call, minimum over blocks)


def measure(blocks: int, at_s: float) -> dict:
    import numpy as np

    from visnav.measurements import Frame
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation
    from visnav.vehicles.base import Environment

    sim = make_simulation(load_scenario("condor-orbit", [f"run.duration_s={at_s}"], seed=1))
    sim.run()
    v, nav, truth, world, s = sim.vehicle, sim.nav, sim.history, sim.world, sim.sensors
    ap, mission = sim.controller, sim.mission
    t = truth.now
    u = sim.step_state.command
    env = Environment(np.array([-4.1, 0.3, 0.2]))
    est = nav.estimate(t)
    health = nav.health(t)
    ref, _ = mission.step(t, est, health)
    out = {"at_s": at_s}
    x0, t0 = v.x, v.t

    def fw_step(i):
        v.x, v.t = x0, t0  # the same state each call
        v.step(u, 0.01, env)

    out["fixedwing step (RK4)"] = _min_block(fw_step, 400, blocks)

    def truth_build(i):  # the first truth read after a step: the state and its air data
        v._air_at = (x0.tolist(), v._clipped(u), (-4.1, 0.3, 0.2))
        v.x = x0.copy()
        return v.state

    out["truth state + air data, first read"] = _min_block(truth_build, 400, blocks)
    v.x, v.t = x0, t0
    st = v.state
    truth.now = v.t
    tt = v.t
    for name in ("ahrs", "imu", "pitot", "baro", "camera_ahrs"):
        sen = s[name]
        if name == "camera_ahrs":  # stepped over 0.02 s each call, as at 50 Hz
            def cam(i, sen=sen):
                sen._t = tt - 0.02
                return sen.sample(tt, truth, world)
            out[f"sensor {name}"] = _min_block(cam, 400, blocks)
        else:
            out[f"sensor {name}"] = _min_block(lambda i, sen=sen: sen.sample(tt, truth, world), 400, blocks)
    est_fn = getattr(nav, "_estimate", nav.estimate)  # (the after side keeps the last estimate: time a new one)
    out["navigator estimate (vision mode)"] = _min_block(lambda i: est_fn(t + 1e-6 * i), 400, blocks)
    out["navigator health"] = _min_block(lambda i: nav.health(t + 1e-6 * i), 400, blocks)
    out["autopilot command"] = _min_block(lambda i: ap.command(t + 0.02 * (i + 1), est, ref), 400, blocks)
    w = world.wind
    out["wind (Dryden + steady, 20 Hz)"] = _min_block(lambda i: w.velocity_ned(t, 0.05, 100.0, 17.0), 400, blocks)
    out["gimbal step"] = _min_block(lambda i: world.gimbal.step(0.01), 400, blocks)
    cam = s["camera"]
    out["camera frame (render)"] = _min_block(lambda i: cam.sample(tt, truth, world), 100, blocks)
    f1 = cam.sample(tt, truth, world)
    v.x = x0 + np.r_[0.3, 0.2, 0.0, np.zeros(9)]  # the next frame a little further on
    v.t = t0 + 1e-9
    truth.now = v.t
    f2 = cam.sample(v.t, truth, world)
    v.x, v.t = x0, t0
    truth.now = v.t
    from visnav.navigation.base import same_image

    out["frozen-frame check (two frames)"] = _min_block(lambda i: same_image(f2.image, f1.image), 100, blocks)
    tr = nav.tracker
    last = tr.last

    def track(i):
        tr.last = last
        return tr.track(f1.image)

    out["blob tracker (window)"] = _min_block(track, 100, blocks)
    a = nav.altimeter
    out["vision range (one pixel)"] = _min_block(
        lambda i: nav.vision.estimate(12.0, -30.0, 100.0, -0.7, 0.05, a[0], a[1], a[2]), 400, blocks)

    def frame(i):
        tr.last = last
        nav._frozen._last = f2.image
        nav.update(Frame(tt, f1.image, i))
        nav.uplink.clear()

    out["ground station frame (update)"] = _min_block(frame, 100, blocks)
    return out


def ab(before: str, after: str, rounds: int, blocks: int, at_s: float) -> None:
    rows: dict[str, dict[str, list[float]]] = {}
    for r in range(rounds):
        for which, src in ((("before", before), ("after", after)) if r % 2 == 0 else (("after", after), ("before", before))):
            env = {**os.environ, "PYTHONPATH": str(Path(src).resolve())}
            res = subprocess.run([sys.executable, __file__, "--blocks", str(blocks), "--at", str(at_s)], env=env,
                                 capture_output=True, text=True, check=True).stdout
            for k, val in json.loads(res.strip().splitlines()[-1]).items():
                rows.setdefault(k, {}).setdefault(which, []).append(val)
    print(f"load average {os.getloadavg()[0]:.1f}")
    print("| block | before us | after us | ratio |\n|---|---:|---:|---:|")
    for k, d in rows.items():
        if k == "at_s":
            continue
        b, a = min(d["before"]), min(d["after"])
        print(f"| {k} | {b:.1f} | {a:.1f} | {b / a:.2f}x |")


if __name__ == "__main__":
    ap_ = argparse.ArgumentParser()
    ap_.add_argument("--blocks", type=int, default=10)
    ap_.add_argument("--at", type=float, default=90.0)
    ap_.add_argument("--ab", nargs=2, metavar=("BEFORE_SRC", "AFTER_SRC"))
    ap_.add_argument("--rounds", type=int, default=3)
    a_ = ap_.parse_args()
    if a_.ab:
        ab(a_.ab[0], a_.ab[1], a_.rounds, a_.blocks, a_.at)
    else:
        print(json.dumps(measure(a_.blocks, a_.at)))
