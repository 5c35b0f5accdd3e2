"""Figures of docs/results-condor.md: the ground test (thesis method vs ours) over seeds, and the
vision orbit in 8 kt wind with the three controllers over seeds. Usage:
``python scripts/condor_results.py [n_seeds]`` (about 10 s per orbit run on the 2-core machine)."""

from __future__ import annotations

import sys

import numpy as np

from visnav.scenarios.schema import load_scenario
from visnav.app.missions import make_simulation


def main(n: int = 5) -> None:
    seeds = list(range(1, n + 1))
    g = [make_simulation(load_scenario("condor-ground-test", seed=s)).run().metrics for s in seeds]
    print(f"## ground test, seeds {seeds[0]}-{seeds[-1]}\n")
    print("| method | mean abs error % | max abs error % |\n|---|---:|---:|")
    for k, label in (("thesis", "thesis (mirrored quadrant table, printed roll, linear pan)"),
                     ("ours", "ours (whole-frame table, 2-D roll rotation, pinhole pan)")):
        mean = [m[f"{k}_mean_abs_error_pct"] for m in g]
        mx = [m[f"{k}_max_abs_error_pct"] for m in g]
        print(f"| {label} | {np.mean(mean):.2f} ({np.min(mean):.2f}-{np.max(mean):.2f}) | "
              f"{np.mean(mx):.2f} ({np.min(mx):.2f}-{np.max(mx):.2f}) |")
    keys = ("orbit_radius_error_rms_m", "orbit_radius_error_max_m", "orbit_centre_offset_m", "orbit_radius_mean_m",
            "radius_est_error_rms_pct", "radius_est_error_max_pct", "tracking_lost_s", "max_bank_deg",
            "real_time_factor")
    print(f"\n## condor-orbit, 8 kt wind, seeds {seeds[0]}-{seeds[-1]}: mean (min-max)\n")
    print("| controller | " + " | ".join(keys) + " |\n|---|" + "---:|" * len(keys))
    for logic in ("original", "modified", "coordinated"):
        ov = [f"control.condor.orbit.logic={logic}"]
        ms = [make_simulation(load_scenario("condor-orbit", ov, seed=s)).run().metrics for s in seeds]
        cells = []
        for k in keys:
            v = np.array([m[k] for m in ms], float)
            cells.append(f"{v.mean():.2f} ({v.min():.2f}-{v.max():.2f})")
        print(f"| {logic} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
