"""Fly N seeds of a scenario (a plain loop over a process pool) and print the acceptance figures.

    python scripts/palace_seeds.py [N] [--set key=value ...]
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from visnav.scenarios.schema import load_scenario
from visnav.app.loop import Simulation


def one(args):
    seed, sets = args
    m = Simulation(load_scenario("palace-landing", sets, seed=seed)).run().metrics
    return seed, m


def main(argv: list[str]) -> dict:
    n = int(argv[0]) if argv and not argv[0].startswith("--") else 20
    sets = [argv[i + 1] for i, a in enumerate(argv) if a == "--set"]
    import multiprocessing

    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as ex:
        rows = list(ex.map(one, [(s, sets) for s in range(1, n + 1)]))
    keys = ["landed", "aborted", "touchdown_error_m", "touchdown_speed_mps", "mpe_drift_m",
            "time_under_vision_s", "reinitializations", "mpe_fallbacks", "real_time_factor"]
    print("seed " + " ".join(f"{k[:14]:>14}" for k in keys))
    for seed, m in rows:
        print(f"{seed:4d} " + " ".join(f"{m.get(k, float('nan')):14.3f}" if not isinstance(m.get(k), bool)
                                       else f"{str(m[k]):>14}" for k in keys))
    ok = [m["landed"] and not m["aborted"] and m["touchdown_error_m"] <= 1.0 for _, m in rows]
    drift = np.array([m["mpe_drift_m"] for _, m in rows])
    summary = {
        "runs": n,
        "landed_within_1m_no_abort": int(sum(ok)),
        "median_mpe_drift_m": float(np.nanmedian(drift)),
        "max_mpe_drift_m": float(np.nanmax(drift)),
        "median_touchdown_error_m": float(np.nanmedian([m["touchdown_error_m"] for _, m in rows])),
        "max_touchdown_error_m": float(np.nanmax([m["touchdown_error_m"] for _, m in rows])),
        "median_touchdown_speed_mps": float(np.nanmedian([m["touchdown_speed_mps"] for _, m in rows])),
    }
    print(json.dumps(summary, indent=2))
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
