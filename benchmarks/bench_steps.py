"""Per-step cost of the 100 Hz blocks: R-MAX model, fixed wing, ESKF predict, INS (with and without Earth
rate), ESKF baro update, PFCM's Hermite arc length, CONDOR's distortion look-up, position filter, Dryden
gusts; the deck loop's per-step truth (deck motion, relative state, gear point), UKF prediction and LED frame.

    PYTHONPATH=src python benchmarks/bench_steps.py [--blocks 15]

Thread CPU time per call (``time.thread_time``), the minimum over ``--blocks`` blocks of calls (on a
shared machine the least disturbed block); prints one JSON line. Run it once per checkout, alternating
(``--ab BEFORE_SRC AFTER_SRC`` does that in fresh processes and prints a table).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def _min_block(fn, n: int, blocks: int) -> float:
    best = np.inf
    for _ in range(blocks):
        t0 = time.thread_time()
        for i in range(n):
            fn(i)
        best = min(best, (time.thread_time() - t0) / n)
    return best * 1e6


def measure(blocks: int) -> dict:
    from visnav.estimation.eskf import EskfConfig, ErrorStateKF
    from visnav.estimation.ins import NavState, StrapdownINS, euler_to_quat
    from visnav.estimation.position_filter import PositionFilter
    from visnav.measurements import YacsCommand
    from visnav.vehicles.fixedwing import Controls, FixedWingModel, trim, FixedWingParams
    from visnav.vehicles.rmax import RmaxModel

    rng = np.random.default_rng(0)
    out = {}
    cmds = [YacsCommand(0.0, *rng.normal(0, 30, 4)) for _ in range(200)]
    from visnav.vehicles.base import Environment

    winds = [Environment(wind_ned=rng.normal(0, 2, 3)) for _ in range(200)]
    m = RmaxModel(position=(0, 0, -40))
    out["rmax_step_us"] = _min_block(lambda i: m.step(cmds[i % 200], 0.01, winds[i % 200]), 200, blocks)
    p = FixedWingParams()
    tr = trim(p, 17.0, turn_radius=110.0)
    fw = FixedWingModel.from_trim(p, tr, [0.0, 0.0, -100.0], 0.0)
    c = tr.controls
    ctl = [Controls(c.aileron + 0.01 * rng.normal(), c.elevator + 0.01 * rng.normal(), c.rudder, c.throttle)
           for _ in range(200)]

    def fw_step(i):
        fw.step(ctl[i % 200], 0.01, winds[i % 200])
        return fw.state  # the loop reads the truth every step

    out["fixedwing_step_us"] = _min_block(fw_step, 200, blocks)
    s0 = NavState(0.0, np.array([0.0, 0.0, -60.0]), np.array([8.0, 3.0, 0.0]), euler_to_quat([0.05, -0.03, 1.0]))
    kf = ErrorStateKF(s0, np.ones(12), EskfConfig(gravity_mps2=9.81, earth_rotation=False))
    acc, gyr = np.array([0.3, -0.2, -9.7]), np.array([0.01, -0.02, 0.03])
    out["eskf_propagate_us"] = _min_block(lambda i: kf.propagate(acc, gyr, 0.02), 200, blocks)
    ins = StrapdownINS()
    st = [s0]

    def ins_step(i):
        st[0] = ins.propagate(st[0], acc, gyr, 0.02)

    out["ins_propagate_us"] = _min_block(ins_step, 200, blocks)
    flat = StrapdownINS(earth_rotation=False, gravity=9.81)  # witas-homing's INS-only twin
    st2 = [s0]

    def flat_step(i):
        st2[0] = flat.propagate(st2[0], acc, gyr, 0.02)

    out["ins_flat_propagate_us"] = _min_block(flat_step, 200, blocks)
    out["eskf_update_baro_us"] = _min_block(lambda i: kf.update_baro(60.0 + 0.01 * (i % 7), 0.5), 200, blocks)
    from visnav.guidance.hermite import HermiteSegment

    seg = HermiteSegment(np.zeros(3), np.array([80.0, 40.0, -5.0]), np.array([100.0, 0.0, 0.0]),
                         np.array([60.0, 80.0, 0.0]))
    out["hermite_arc_length_us"] = _min_block(lambda i: seg.arc_length(0.001 + 0.004 * (i % 200)), 200, blocks)
    from visnav.geometry.camera import PinholeCamera
    from visnav.vision.distortion_lut import full_lut, synthetic_board
    from visnav.vision.rectification import CameraGeometry

    cam = PinholeCamera(640, 480, 640.0, 640.0, 333.5, 231.5, (-0.28, 0.08, 0, 0, 0, 0, 0, 0))
    lut = full_lut(synthetic_board(cam, 2.0, 0.04), CameraGeometry.from_focal(640, 480, 640.0, 640.0))
    xs = [(np.array([rng.uniform(-300, 300)]), np.array([rng.uniform(-220, 220)])) for _ in range(200)]
    out["distortion_lut_correct_us"] = _min_block(lambda i: lut.correct(*xs[i % 200]), 200, blocks)
    pf = PositionFilter(position=np.zeros(3), velocity=np.zeros(3))
    pf.predict(0.0, acc)
    tt = [0.0]

    def pf_step(i):
        tt[0] += 0.01
        pf.predict(tt[0], acc)

    out["position_filter_predict_us"] = _min_block(pf_step, 400, blocks)
    from visnav.world.wind import DrydenTurbulence

    dr = DrydenTurbulence("moderate", np.random.default_rng(1), 30.0, 8.0)
    out["dryden_step_us"] = _min_block(lambda i: dr.step(0.01, 30.0 + 0.01 * (i % 7), 8.0), 400, blocks)
    out.update(_deck(blocks))
    return out


def _deck(blocks: int) -> dict:
    """The deck loop's blocks on the deck-moving scenario's own objects (built, not flown)."""
    from visnav.estimation import deck as dm
    from visnav.measurements import ImuSample
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation
    from visnav.world.deck import relative_state

    sim = make_simulation(load_scenario("deck-moving", seed=1))
    out = {}
    motion, veh = sim.world.motion, sim.vehicle
    tt = [0.0]

    def truth(i):  # per step: the loop's deck state, the observer's (every 2nd step), the log's relative state
        tt[0] += 0.01
        ds = motion.state(tt[0])
        if i % 2 == 0:
            relative_state(veh.state, motion.state(tt[0]))
        relative_state(veh.state, ds)
        veh.gear_point(), veh.gear_point(), veh.gear_point()

    out["deck_truth_per_step_us"] = _min_block(truth, 200, blocks)
    nav = sim.nav
    inner = getattr(nav, "inner", nav)  # the faults wrapper, if any
    rng = np.random.default_rng(2)
    t0 = [0.0]
    inner._rp = np.zeros(2)

    x0, P0 = inner.ukf.x.copy(), inner.ukf.P.copy()

    def imu(i):
        if i == 0:  # no frame corrects it: start every block from the first state (P stays positive)
            inner.ukf.x, inner.ukf.P = x0.copy(), P0.copy()
        t0[0] += 0.01
        inner._imu(ImuSample(t=t0[0], accel=np.array([0.0, 0.0, -9.81]) + 0.01 * rng.standard_normal(3),
                             gyro=0.01 * rng.standard_normal(3)))

    out["deck_ukf_imu_predict_us"] = _min_block(imu, 100, blocks)
    cam, hist = sim.camera, sim.history
    out["deck_led_frame_us"] = _min_block(lambda i: cam.sample(0.0, hist, sim.world), 20, blocks)
    return out


def main(blocks: int = 10) -> dict:
    """The table for ``run_all.py``: this checkout's per-call times."""
    res = measure(blocks)
    print("| step | us per call (min of blocks) |\n|---|---:|")
    for k, v in res.items():
        print(f"| {k[:-3]} | {v:.1f} |")
    return res


def ab(before: str, after: str, rounds: int, blocks: int) -> None:
    res: dict[str, dict[str, list[float]]] = {"before": {}, "after": {}}
    for r in range(rounds):
        for tag, src in ((("before", before), ("after", after)) if r % 2 == 0 else (("after", after), ("before", before))):
            env = {**os.environ, "PYTHONPATH": str(Path(src).resolve())}
            line = subprocess.run([sys.executable, __file__, "--blocks", str(blocks)], env=env, check=True,
                                  capture_output=True, text=True).stdout.strip().splitlines()[-1]
            for k, v in json.loads(line).items():
                res[tag].setdefault(k, []).append(v)
    print(f"load average {os.getloadavg()[0]:.1f}; min over {rounds} processes x {blocks} blocks each\n")
    print("| step | before us | after us | ratio |\n|---|---:|---:|---:|")
    for k in res["before"]:
        b, a = min(res["before"][k]), min(res["after"][k])
        print(f"| {k[:-3]} | {b:.1f} | {a:.1f} | {b / a:.2f}x |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--blocks", type=int, default=15)
    ap.add_argument("--ab", nargs=2, metavar=("BEFORE_SRC", "AFTER_SRC"))
    ap.add_argument("--rounds", type=int, default=4)
    a = ap.parse_args()
    if a.ab:
        ab(*a.ab, a.rounds, a.blocks)
    else:
        print(json.dumps(measure(a.blocks)))
