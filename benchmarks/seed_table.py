"""Headline metrics of two campaigns (``visnav montecarlo ... --out DIR``) side by side.

    python benchmarks/seed_table.py BEFORE_DIR AFTER_DIR [--metrics a,b,c]
    python benchmarks/seed_table.py BEFORE_ROOT AFTER_ROOT --all

Prints a markdown table, one row per seed (before -> after for each headline metric), and the
largest absolute difference of every numeric column over the seeds both campaigns finished.
With ``--all`` the roots hold one campaign per scenario (``ROOT/<scenario>/runs.csv``): one row per
scenario with each headline metric (the thesis' figures, ``analysis/published``, and ``outcome``)
checked against tests/test_golden.py's tolerance (2 % or the unit's floor), and every change larger
than 1 % listed by seed.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
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


def _golden():
    spec = importlib.util.spec_from_file_location("golden_test", Path(__file__).parents[1] / "tests" / "test_golden.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def every_scenario(before: Path, after: Path) -> None:
    """One row per scenario found in both roots: seeds, headline metrics within tolerance, changes over 1 %."""
    from visnav.analysis.published import published
    from visnav.scenarios.schema import load_scenario

    gold = _golden()
    print("| scenario | seeds | headline metrics | values within tolerance | outcome changed | largest change |")
    print("|---|---|---|---|---|---|")
    notes = []
    for d in sorted(p for p in Path(before).iterdir() if (p / "runs.csv").is_file() and (after / p.name / "runs.csv").is_file()):
        b, c = rows(d), rows(after / d.name)
        seeds = sorted(set(b) & set(c), key=int)
        names = [m.metric for m in published(load_scenario(d.name))[0]]
        n_in = n_all = flips = 0
        worst = (0.0, "")
        for sd in seeds:
            if b[sd].get("outcome") != c[sd].get("outcome"):
                flips += 1
                notes.append(f"- {d.name} seed {sd}: outcome {b[sd].get('outcome')} -> {c[sd].get('outcome')}")
            for m in names:
                x, y = num(b[sd].get(m)), num(c[sd].get(m))
                if x is None or y is None or (math.isnan(x) and math.isnan(y)):
                    continue
                n_all += 1
                ok = math.isfinite(y) and abs(y - x) <= gold.tolerance(m, x)
                n_in += ok
                rel = abs(y - x) / max(abs(x), 1e-12)
                if rel > 0.01 and abs(y - x) > 1e-9:
                    notes.append(f"- {d.name} seed {sd}: {m} {x:.6g} -> {y:.6g} ({100 * rel:+.1f} %)"
                                 + ("" if ok else " **beyond tolerance**"))
                    if rel > worst[0]:
                        worst = (rel, f"{m} seed {sd}: {100 * rel:.1f} %")
        print(f"| {d.name} | {len(seeds)} | {len(names)} | {n_in} / {n_all} | {flips} | {worst[1] or 'none over 1 %'} |")
    print("\nChanges larger than 1 %:\n" + ("\n".join(notes) if notes else "none"))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--metrics", default="")
    ap.add_argument("--all", action="store_true", help="roots of one campaign per scenario")
    a = ap.parse_args()
    if a.all:
        return every_scenario(Path(a.before), Path(a.after))
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
