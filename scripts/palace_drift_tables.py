"""Markdown tables (per condition and per surface) and the drift figure of ``palace-hover-drift`` campaigns,
as docs/results-palace.md shows them.

    python scripts/palace_drift_tables.py runs/drift-concrete-grass [--png docs/figures/x.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

from visnav.analysis.palace_report import drift_figure, drift_summary, drift_table, read_csv


def main(argv: list[str]) -> None:
    png = argv[argv.index("--png") + 1] if "--png" in argv else None
    dirs = [a for i, a in enumerate(argv) if not a.startswith("--") and (i == 0 or argv[i - 1] != "--png")]
    rows = [r for d in dirs for r in read_csv(Path(d) / "runs.csv")]
    failed = sum(r.get("status") != "ok" for r in rows)
    no_drift = sum(r.get("status") == "ok" and r.get("drift_px") in ("", "nan", None) for r in rows)
    lost = sum(str(r.get("tracker_lost")) == "True" for r in rows)
    t = drift_table(rows)
    print(f"{len(rows)} runs, {failed} failed, {lost} tracks lost, {no_drift} without a drift measure\n")
    print("| surface | AGL m | wind | n | mean px | max px | mean m | σ m | range m |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in t:
        print(f"| {r['surface']} | {r['altitude_m']:g} | {r['wind_from_deg']:g} | {r['n']} | {r['mean_px']:.2f} | "
              f"{r['max_px']:.2f} | {r['mean_m']:.3f} | {r['sigma_m']:.3f} | {r['range_m']:.1f} |")
    print("\n| surface | AGL m | n | mean px | max px |\n|---|---|---|---|---|")
    for surf in sorted({r["surface"] for r in t}):
        for alt in sorted({r["altitude_m"] for r in t}):
            c = [r for r in t if r["surface"] == surf and r["altitude_m"] == alt]
            n = sum(r["n"] for r in c)
            print(f"| {surf} | {alt:g} | {n} | {sum(r['mean_px'] * r['n'] for r in c) / n:.2f} | "
                  f"{max(r['max_px'] for r in c):.2f} |")
    print("\n| surface | runs with drift | mean px | mean of per-condition max px | max px |\n|---|---|---|---|---|")
    for s, v in drift_summary(t).items():
        print(f"| {s} | {v['n']} | {v['mean_px']:.2f} | {v['mean_of_max_px']:.2f} | {v['max_px']:.2f} |")
    if png:
        fig = drift_figure(t)
        fig.savefig(png, dpi=80, bbox_inches="tight")
        print(f"\nwritten: {png}")


if __name__ == "__main__":
    main(sys.argv[1:])
