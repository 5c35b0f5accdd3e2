"""Real-time factor of the default PALACE landing (target >= 30x on the 2-core machine), with a profile."""

from __future__ import annotations

import sys
import time

from visnav.scenarios.schema import load_scenario
from visnav.app.loop import Simulation


def main(seed: int = 1, profile: bool = False) -> dict:
    sc = load_scenario("palace-landing", seed=seed)
    t0 = time.perf_counter()
    sim = Simulation(sc)
    setup = time.perf_counter() - t0
    if profile:
        from pyinstrument import Profiler

        p = Profiler()
        p.start()
    res = sim.run()
    if profile:
        p.stop()
        print(p.output_text(unicode=False, color=False, show_all=False)[:6000])
    m = res.metrics
    rows = {"sim_time_s": m["sim_time_s"], "wall_time_s": m["wall_time_s"], "setup_s": setup,
            "real_time_factor": m["real_time_factor"], "landed": m["landed"]}
    print("| case | value |\n|---|---|")
    for k, v in rows.items():
        print(f"| {k} | {v:.2f} |" if isinstance(v, float) else f"| {k} | {v} |")
    return rows


if __name__ == "__main__":
    main(profile="--profile" in sys.argv)
