"""Is the lateral phase margin's non-monotonic trend with altitude (MPE, "0 ms") scatter or model?

Flies the lateral margins sweep of ``palace-sweep`` (the ``visnav margins`` chirp, camera 10 ms late)
per seed, on GPS and on MPE uncompensated, at each altitude, and keeps every seed's own result
(``visnav margins`` keeps only the merged one). Resumable: rows go to ``<out>/sweeps.csv`` as they
finish, each seed's broken-loop response to ``<out>/frf/``.

    python scripts/palace_pm_trend.py fly  [--seeds 1-6] [--out runs/pm-trend] [--set k=v] [--altitudes 6,54]
                                           [--sources gps]
    python scripts/palace_pm_trend.py table [--out runs/pm-trend]
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np

ALTITUDES = (6.0, 12.0, 18.0, 30.0, 54.0)
SOURCES = ("gps", "mpe")
COLS = ["seed", "altitude_m", "source", "pm_deg", "w_gc", "gm_db", "w_pc", "notes"]


def _arg(argv, name, default):
    return argv[argv.index(name) + 1] if name in argv else default


def _done(path: Path) -> set:
    if not path.is_file():
        return set()
    with path.open(newline="") as f:
        return {(int(r["seed"]), float(r["altitude_m"]), r["source"]) for r in csv.DictReader(f)}


def fly(out: Path, seeds, sets=(), altitudes=ALTITUDES, sources=SOURCES) -> None:
    from visnav.app.margins_campaign import SweepSettings, sweep_run

    out.mkdir(parents=True, exist_ok=True)
    (out / "frf").mkdir(exist_ok=True)
    path = out / "sweeps.csv"
    done = _done(path)
    new = not path.is_file()
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLS)
        if new:
            w.writeheader()
        for seed in seeds:  # seed outermost: an interrupted run leaves whole seeds
            for alt in altitudes:
                for src in sources:
                    if (seed, alt, src) in done:
                        continue
                    r = sweep_run(alt, "lateral", source=src, seed=seed, sweep=SweepSettings(),
                                  overrides=tuple(sets))
                    if r.get("frf") is not None:
                        np.savez(out / "frf" / f"{src}_{alt:g}_{seed}.npz", **r["frf"])
                    w.writerow(dict(seed=seed, altitude_m=alt, source=src, pm_deg=r["pm_deg"], w_gc=r["w_gc"],
                                    gm_db=r["gm_db"], w_pc=r["w_pc"], notes="; ".join(r["notes"])))
                    f.flush()
                    print(f"seed {seed} {alt:g} m {src}: PM {r['pm_deg']:.1f}", flush=True)


def _slope(x, y):
    """Least-squares slope of y on x and its standard error."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(y)
    x, y = x[ok], y[ok]
    A = np.vstack([x, np.ones_like(x)]).T
    coef, res, *_ = np.linalg.lstsq(A, y, rcond=None)
    dof = max(1, x.size - 2)
    s2 = float(np.sum((y - A @ coef) ** 2)) / dof
    se = math.sqrt(s2 / np.sum((x - x.mean()) ** 2))
    return float(coef[0]), se


def table(out: Path) -> str:
    from visnav.analysis.loop_model import model_margins
    from visnav.app.margins_campaign import SweepSettings, merge_sweeps

    with (out / "sweeps.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    seeds = sorted({int(r["seed"]) for r in rows})
    pm = {(int(r["seed"]), float(r["altitude_m"]), r["source"]): float(r["pm_deg"]) for r in rows}
    lines = [f"seeds {seeds[0]}-{seeds[-1]} ({len(rows)} lateral sweeps); PM in deg",
             "| AGL m | GPS per seed | GPS mean ± sd | MPE per seed | MPE mean ± sd | MPE − GPS (paired) mean ± sd "
             "| merged GPS / MPE | model GPS / MPE |", "|---|---|---|---|---|---|---|---|"]
    g_model = model_margins(6.0, None, image_delay_s=0.01).pm_deg
    xs, ys = {"gps": [], "mpe": [], "diff": []}, {"gps": [], "mpe": [], "diff": []}
    for alt in ALTITUDES:
        per = {s: np.array([pm.get((sd, alt, s), math.nan) for sd in seeds]) for s in SOURCES}
        diff = per["mpe"] - per["gps"]
        merged = {}
        for s in SOURCES:
            res = []
            for sd in seeds:
                p = out / "frf" / f"{s}_{alt:g}_{sd}.npz"
                if p.is_file():
                    z = np.load(p)
                    res.append(dict(frf=dict(w=z["w"], H=z["H"], coherence=z["coherence"]), notes=[]))
            merged[s] = merge_sweeps(res, SweepSettings())["pm_deg"] if len(res) > 1 else math.nan
        m_mpe = model_margins(alt, 0.0, image_delay_s=0.01).pm_deg
        for k, v in (("gps", per["gps"]), ("mpe", per["mpe"]), ("diff", diff)):
            xs[k] += [alt] * len(v)
            ys[k] += list(v)

        def ms(v):
            v = v[np.isfinite(v)]
            return f"{v.mean():.1f} ± {v.std(ddof=1):.1f} (n={v.size})" if v.size > 1 else "-"

        lines.append(f"| {alt:g} | {' '.join(f'{v:.1f}' for v in per['gps'])} | {ms(per['gps'])} | "
                     f"{' '.join(f'{v:.1f}' for v in per['mpe'])} | {ms(per['mpe'])} | {ms(diff)} | "
                     f"{merged['gps']:.1f} / {merged['mpe']:.1f} | {g_model:.1f} / {m_mpe:.1f} |")
    lines.append("")
    slope_model = (model_margins(54.0, 0.0, image_delay_s=0.01).pm_deg
                   - model_margins(6.0, 0.0, image_delay_s=0.01).pm_deg) / 48.0
    for k, name in (("gps", "GPS"), ("mpe", "MPE 0 ms"), ("diff", "MPE − GPS paired")):
        b, se = _slope(xs[k], ys[k])
        lines.append(f"slope of {name} PM against altitude: {b * 48:+.2f} ± {se * 48:.2f} deg per 48 m "
                     f"(6 -> 54 m; ± one standard error)")
    lines.append(f"model (image 10 ms late): {slope_model * 48:+.2f} deg per 48 m for MPE, 0 for GPS")
    txt = "\n".join(lines)
    (out / "summary.md").write_text(txt + "\n")
    return txt


def main(argv: list[str]) -> None:
    out = Path(_arg(argv, "--out", "runs/pm-trend"))
    if argv and argv[0] == "fly":
        a, b = _arg(argv, "--seeds", "1-6").split("-")
        sets = [argv[i + 1] for i, x in enumerate(argv) if x == "--set"]
        alts = [float(x) for x in _arg(argv, "--altitudes", ",".join(f"{a:g}" for a in ALTITUDES)).split(",")]
        srcs = _arg(argv, "--sources", ",".join(SOURCES)).split(",")
        fly(out, range(int(a), int(b) + 1), sets, alts, srcs)
    elif argv and argv[0] == "table":
        print(table(out))
    else:
        print(__doc__)
        sys.exit(2)


if __name__ == "__main__":
    main(sys.argv[1:])
