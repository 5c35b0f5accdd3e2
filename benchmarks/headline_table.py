"""Headline metrics of every scenario, two sets of campaigns side by side (issue 13's before / after table).

    python benchmarks/headline_table.py BEFORE_ROOT AFTER_ROOT [--seeds 1-10]

Each root holds one campaign directory per scenario (``visnav montecarlo SCEN -n 10 --out ROOT/SCEN``).
Prints a markdown table: per scenario, runs finished, and the median over the common seeds of its
headline metrics before -> after, plus the largest per-seed change of each (so a median that hides a
changed seed is still visible).
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
from pathlib import Path

HEADLINE = {
    "palace-landing": ["touchdown_error_m", "touchdown_speed_mps", "mpe_error_rms_m", "ate_rmse_m"],
    "palace-hover-drift": ["drift_m", "mpe_noise_sigma_m", "hover_pos_rms_m", "ate_rmse_m"],
    "palace-sweep": ["drift_m", "mpe_noise_sigma_m", "hover_pos_rms_m", "ate_rmse_m"],
    "pfcm-segment": ["cross_track_rms_m", "cross_track_max_m", "ate_rmse_m"],
    "pfcm-spiral": ["cross_track_rms_m", "cross_track_max_m", "ate_rmse_m"],
    "witas-homing": ["home_error_m", "pmf_error_rms_m", "odometry_drift_pct", "kf_error_max_m", "ate_rmse_m"],
    "pad-landing": ["touchdown_error_m", "touchdown_speed_mps", "attitude_error_rms_deg", "ate_rmse_m"],
    "deck-static": ["touchdown_position_error_m", "touchdown_rel_speed_mps", "touchdown_attitude_mismatch_deg",
                    "ate_rmse_m"],
    "deck-moving": ["touchdown_position_error_m", "touchdown_rel_speed_mps", "touchdown_attitude_mismatch_deg",
                    "ate_rmse_m"],
    "condor-orbit": ["orbit_radius_error_rms_m", "radius_est_error_rms_pct", "position_est_error_rms_m",
                     "ate_rmse_m"],
    "mav-geolocation": ["target_error_m", "map_based_error_m", "single_frame_error_median_m"],
    "mav-geolocation-single": ["target_error_m", "map_based_error_m", "single_frame_error_median_m"],
}


def _rows(d: Path) -> dict[str, dict[str, str]]:
    with open(d / "runs.csv", newline="") as f:
        return {r["seed"]: r for r in csv.DictReader(f)}


def _num(x) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(v) else v


def _metrics(name: str, row: dict[str, str]) -> list[str]:
    want = [m for m in HEADLINE.get(name, []) if m in row]
    if want:
        return want
    skip = {"seed", "wall_time_s", "real_time_factor", "sim_time_s"}
    return [k for k, v in row.items() if k not in skip and _num(v) is not None][:4]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    a = ap.parse_args()
    before, after = Path(a.before), Path(a.after)
    print("| scenario | runs ok before / after | metric | median before | median after | max per-seed change |")
    print("|---|---|---|---|---|---|")
    for d in sorted(p for p in before.iterdir() if (p / "runs.csv").exists()):
        if not (after / d.name / "runs.csv").exists():
            print(f"| {d.name} | (no after campaign) | | | | |")
            continue
        b, c = _rows(d), _rows(after / d.name)
        seeds = sorted(set(b) & set(c), key=int)
        if not seeds:
            continue
        ok_b = sum(b[s].get("status") == "ok" for s in seeds)
        ok_c = sum(c[s].get("status") == "ok" for s in seeds)
        for i, m in enumerate(_metrics(d.name, b[seeds[0]])):
            xb = [_num(b[s].get(m)) for s in seeds]
            xc = [_num(c[s].get(m)) for s in seeds]
            mb = statistics.median([x for x in xb if x is not None]) if any(x is not None for x in xb) else float("nan")
            mc = statistics.median([x for x in xc if x is not None]) if any(x is not None for x in xc) else float("nan")
            ch = [abs(y - x) for x, y in zip(xb, xc) if x is not None and y is not None]
            head = f"| {d.name} | {ok_b}/{len(seeds)} / {ok_c}/{len(seeds)} " if i == 0 else "| | "
            print(f"{head}| {m} | {mb:.4g} | {mc:.4g} | {max(ch) if ch else float('nan'):.3g} |")


if __name__ == "__main__":
    main()
