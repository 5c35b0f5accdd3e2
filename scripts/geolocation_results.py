"""Markdown tables of docs/results-geolocation.md from the campaign JSON files.

    python scripts/geolocation_results.py runs/geoloc-campaign.json runs/geoloc-hough.json
"""

from __future__ import annotations

import json
import sys

import numpy as np


def _med(v):
    v = np.array([x for x in v if x is not None and np.isfinite(x)], float)
    if v.size == 0:
        return "n/a"
    return f"{np.median(v):.2f} ({np.percentile(v, 25):.2f}-{np.percentile(v, 75):.2f})"


def main() -> None:
    rows = json.loads(open(sys.argv[1]).read())
    keys = ("target_error_m", "map_based_error_m", "single_frame_error_median_m", "false_match_rate",
            "samples_to_3m", "samples", "map_based_sample_error_median_m", "hough_applied_rate",
            "heading_error_rms_deg")
    for part in ("main", "single", "thesis"):
        sel = [r for r in rows if r["part"] == part]
        if not sel:
            continue
        print(f"\n### {part}: median (25-75 %) over seeds\n")
        print("| map | seeds | " + " | ".join(keys) + " |")
        print("|---|---:|" + "---:|" * len(keys))
        for m in ("rural", "column", "strip"):
            s = [r for r in sel if r["map"] == m]
            if s:
                errs = sum(1 for r in s if r.get("error"))
                print(f"| {m} | {len(s)}{f' ({errs} errors)' if errs else ''} | "
                      + " | ".join(_med([r[k] for r in s]) for k in keys) + " |")
        for m in ("rural", "column", "strip"):
            s = [r for r in sel if r["map"] == m]
            if s:
                print(f"\n{m} per seed target_error_m: " + ", ".join(f"{r['seed']}: {r['target_error_m']:.2f}"
                                                                   for r in sorted(s, key=lambda r: r['seed'])))
    if len(sys.argv) > 2:
        h = json.loads(open(sys.argv[2]).read())
        print("\n### Hough alignment vs the telemetry heading alone (heading error uniform +-30 deg)\n")
        print("| map | frames | telemetry heading alone | Alg. 1 | ratio | Alg. 1 + rotation search | ratio | "
              "Alg. 1 applied |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        for r in h:
            a, b = r["false_match_rate_hough"], r["false_match_rate_telemetry"]
            c = r.get("false_match_rate_hough_search", float("nan"))
            print(f"| {r['map']} | {r['n']} | {b:.3f} | {a:.3f} | {b / a if a > 0 else float('inf'):.1f}x | "
                  f"{c:.3f} | {b / c if c > 0 else float('inf'):.1f}x | {r.get('hough_applied_hough', float('nan')):.2f} |")


if __name__ == "__main__":
    main()
