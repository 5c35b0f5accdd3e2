"""Headline metrics of two campaigns (``visnav montecarlo ... --out DIR``) side by side.

    python benchmarks/seed_table.py BEFORE_DIR AFTER_DIR [--metrics a,b,c]

Prints a markdown table, one row per seed (before -> after for each headline metric), and the
largest absolute difference of every numeric column over the seeds both campaigns finished.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path


def rows(d: str) -> dict[str, dict[str, str]]:
    with open(Path(d) / "runs.csv", newline="") as f:
        return {r["seed"]: r for r in csv.DictReader(f)}


def num(x: str) -> float | None:
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--metrics", default="")
    a = ap.parse_args()
    b, c = rows(a.before), rows(a.after)
    seeds = sorted(set(b) & set(c), key=int)
    cols = [k for k in b[seeds[0]] if k not in ("seed", "wall_time_s", "real_time_factor")]
    head = [m for m in a.metrics.split(",") if m] or [k for k in cols if num(b[seeds[0]][k]) is not None][:4]
    print("| seed | " + " | ".join(f"{m} before / after" for m in head) + " |")
    print("|---|" + "---|" * len(head))
    for s in seeds:
        cells = []
        for m in head:
            x, y = b[s].get(m, ""), c[s].get(m, "")
            fx, fy = num(x), num(y)
            cells.append(f"{fx:.6g} / {fy:.6g}" if fx is not None and fy is not None else f"{x} / {y}")
        print(f"| {s} | " + " | ".join(cells) + " |")
    print(f"\nseeds compared: {len(seeds)} ({', '.join(seeds)})")
    for k in cols:
        diffs, same = [], True
        for s in seeds:
            x, y = num(b[s].get(k)), num(c[s].get(k))
            if x is None or y is None:
                same &= b[s].get(k) == c[s].get(k)
            elif not (math.isnan(x) and math.isnan(y)):
                diffs.append(abs(x - y))
        worst = max(diffs) if diffs else 0.0
        print(f"- {k}: max |after - before| = {worst:.3g}" + ("" if same else " (text differs)"))


if __name__ == "__main__":
    main()
