"""Registrability map on the real maps of ../shared/data: median score by land cover (hand-drawn
classes below), and the failure rate of full-pipeline registrations per score quantile.

    VISNAV_SHARED_DATA=/path/to/shared/data PYTHONPATH=src nice -n 10 python scripts/geolocation_registrability.py \
        --out runs/geoloc-registrability.json [--n 200] [--models same,day] [--maps rural,column,strip]
    PYTHONPATH=src python scripts/geolocation_registrability.py --stats runs/geoloc-registrability.json [...]

``--chunked N``: registrations only (no land-cover table), another day, ``N`` per map taken in rounds of
``--chunk`` frames that go round the maps (each round a fresh seed: new places, headings and draw of the
change), the output rewritten after each round, so a run cut short leaves equal counts on every map.

``--stats``: from the frames of earlier outputs, the failure rate of the registrations started in the
lowest-scoring quarter against the rest, the odds ratio (conditional maximum likelihood) with its exact
95 % interval and the two-sided Fisher exact test (scipy.stats).

Land cover: polygons drawn by eye on the maps (x = column, y = row, in pixels of the map reduced by
``scale``: 0.5 for satellite_column, 0.4 for satellite_strip); the road class is the cells within 8 m
of the gravel roads. Registrations: the mission's pipeline (Algorithm 1, rotation search, scale and
rotation refinement), heading off by up to +-15 deg, GPS by 4 m. ``--models``: the appearance change between
the reference and the flight (``world/appearance.py``) the score is computed under and the frames are
rendered with: ``same`` (frames drawn from the reference orthophoto itself), ``day`` (``ANOTHER_DAY``: the
relief's fine texture changes and moves, the default of the mission and of ``visnav map-quality``),
``dayL5`` / ``dayL20`` (the same with the relief level at 5 / 20 grey levels instead of 10: sensitivity),
``uniform`` (round 2's model: the fine texture of every place keeps 0.5, nothing moves).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import cv2
import numpy as np

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
if not DATA.is_dir() and os.environ.get("VISNAV_SHARED_DATA"):
    DATA = Path(os.environ["VISNAV_SHARED_DATA"])

POLYGONS = {
    "column": (0.5, {
        "lake": [(0, 0), (398, 0), (398, 95), (0, 100)],
        "forest": [(0, 150), (100, 160), (260, 290), (225, 380), (200, 430), (210, 580), (150, 720), (110, 800),
                   (40, 1000), (0, 1000)],
        "fields": [(300, 320), (398, 300), (398, 1038), (70, 1038), (125, 820), (170, 720), (225, 590), (230, 420)],
        "shore/reed": [(0, 110), (398, 100), (398, 290), (290, 300), (100, 150)],
    }, [((398, 492), (140, 742)), ((325, 558), (398, 660))]),
    "strip": (0.4, {
        "lake": [(0, 0), (954, 0), (954, 70), (800, 70), (700, 78), (560, 58), (430, 90), (330, 150), (160, 230),
                 (60, 277), (0, 277)],
        "forest": [(230, 277), (340, 200), (440, 120), (560, 80), (680, 100), (760, 160), (840, 240), (860, 277)],
        "shore/reed": [(80, 277), (160, 240), (330, 160), (430, 100), (560, 68), (700, 88), (954, 80), (954, 230),
                       (870, 240), (860, 277)],
    }, []),
}


MODELS = {
    "same": {"unstable_m": 0.0},
    "day": {},
    "dayL5": {"relief_level": 5.0},
    "dayL20": {"relief_level": 20.0},
    "uniform": {"texture_keep": 0.5, "relief_level": None, "shift_m": 0.0},
}


def classes(name: str, shape) -> dict:
    scale, polys, roads = POLYGONS[name]
    out = {}
    for k, pts in polys.items():
        m = np.zeros(shape, np.uint8)
        cv2.fillPoly(m, [np.round(np.array(pts, float) / scale).astype(np.int32)], 1)
        out[k] = m.astype(bool)
    if roads:
        m = np.zeros(shape, np.uint8)
        for a, b in roads:
            cv2.line(m, tuple(int(v / scale) for v in a), tuple(int(v / scale) for v in b), 1, int(16 / 0.25))
        out["road"] = m.astype(bool)
        out["fields"] &= ~out["road"]
    if "shore/reed" in out:
        out["shore/reed"] &= ~out["forest"]
    return out


def by_class(reg, geo, cl) -> dict:
    h, w = reg.score.shape
    ii, jj = np.mgrid[0:h, 0:w]
    ne = np.column_stack([reg.north0 - ii.ravel() * reg.cell_m, reg.east0 + jj.ravel() * reg.cell_m])
    px = geo.ned_to_pixel(ne)
    c = np.clip(np.round(px[:, 0]).astype(int), 0, geo.shape[1] - 1)
    r = np.clip(np.round(px[:, 1]).astype(int), 0, geo.shape[0] - 1)
    out = {}
    for k, m in cl.items():
        sel = m[r, c]
        if sel.any():
            out[k] = {"cells": int(sel.sum()), "score": float(np.median(reg.score.ravel()[sel])),
                      "peak": float(np.median(reg.peak.ravel()[sel])),
                      "ambiguity": float(np.median(reg.ambiguity.ravel()[sel]))}
    return out


def low_quarter_stats(scores, failed) -> dict:
    """Failures of the lowest-scoring quarter against the other three quarters: counts, rates, the odds ratio
    (conditional MLE) with its exact 95 % confidence interval and the two-sided Fisher exact p."""
    from scipy.stats import fisher_exact
    from scipy.stats.contingency import odds_ratio

    s, f = np.asarray(scores, float), np.asarray(failed, bool)
    low = s <= np.nanquantile(s, 0.25)
    a, b = int(f[low].sum()), int((~f[low]).sum())  # low quarter: failed, registered
    c, d = int(f[~low].sum()), int((~f[~low]).sum())  # the rest
    res = odds_ratio([[a, b], [c, d]])
    ci = res.confidence_interval(0.95)
    return {"n_low": a + b, "fail_low": a, "n_rest": c + d, "fail_rest": c, "rate_low": a / max(a + b, 1),
            "rate_rest": c / max(c + d, 1), "odds_ratio": float(res.statistic), "ci95": [float(ci.low), float(ci.high)],
            "p_fisher": float(fisher_exact([[a, b], [c, d]], alternative="two-sided").pvalue)}


def print_stats(paths) -> None:
    for p in paths:
        for row in json.loads(Path(p).read_text()):
            if "frames" not in row:
                continue
            st = low_quarter_stats(row["frames"]["score"], row["frames"]["failed"])
            print(f"{row['map']:7s} {row['model']:5s} n={row['n']:5d}  low quarter {st['fail_low']:4d}/{st['n_low']:<4d} "
                  f"({st['rate_low']:.3f})  rest {st['fail_rest']:4d}/{st['n_rest']:<4d} ({st['rate_rest']:.3f})  "
                  f"OR {st['odds_ratio']:.2f} [{st['ci95'][0]:.2f}, {st['ci95'][1]:.2f}]  p = {st['p_fisher']:.2g}")


def load_map(name: str):
    from visnav.world.maps import GeoImage
    from visnav.world.rural import rural_map

    if name == "rural":
        return rural_map(400.0, 0.25, np.random.default_rng(11))
    if (DATA / f"satellite_{name}.png").exists():
        return GeoImage.load(DATA / f"satellite_{name}.png")
    print(f"{name}: {DATA} not found, skipped")
    return None


def chunked(out: str, maps, n: int, chunk: int, heading_error_deg: float, first_seed: int = 1000) -> None:
    """``n`` full-pipeline registrations per map (another day), in rounds of ``chunk`` going round the maps."""
    from visnav.analysis.registrability import registrability_map, validate

    regs = {}
    for name in maps:
        geo = load_map(name)
        if geo is not None:
            regs[name] = (geo, registrability_map(geo, 70.0))
            print(f"{name}: registrability map done", flush=True)
    rows = {k: {"map": k, "model": "day", "n": 0, "seeds": [], "frames": {"north": [], "east": [], "score": [],
                                                                       "failed": [], "error_m": []}} for k in regs}
    for r in range(-(-n // chunk)):
        for name, (geo, reg) in regs.items():
            v = validate(reg, geo, n=chunk, heading_error_deg=heading_error_deg, seed=first_seed + r,
                         rotation_search_deg=45.0, rotation_search_step_deg=7.5)
            row, fr = rows[name], rows[name]["frames"]
            fr["north"] += v["positions"][:, 0].tolist()
            fr["east"] += v["positions"][:, 1].tolist()
            fr["score"] += v["scores"].tolist()
            fr["failed"] += v["failed"].tolist()
            fr["error_m"] += [float(e) if np.isfinite(e) else None for e in v["error_m"]]
            row["n"] += chunk
            row["seeds"].append(first_seed + r)
            row["low_quarter"] = low_quarter_stats(fr["score"], fr["failed"])
            Path(out).write_text(json.dumps(list(rows.values()), indent=1))
            st = row["low_quarter"]
            print(f"round {r + 1} {name}: n {row['n']}, low quarter {st['fail_low']}/{st['n_low']}, "
                  f"rest {st['fail_rest']}/{st['n_rest']}, p {st['p_fisher']:.2g}", flush=True)


def main() -> None:
    from visnav.analysis.registrability import registrability_map, validate

    if "--stats" in sys.argv:
        print_stats(sys.argv[sys.argv.index("--stats") + 1:])
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--models", default="same,day")
    ap.add_argument("--maps", default="rural,column,strip")
    ap.add_argument("--heading-error-deg", type=float, default=15.0)
    ap.add_argument("--chunked", type=int, default=0)
    ap.add_argument("--chunk", type=int, default=50)
    a = ap.parse_args()
    if a.chunked:
        chunked(a.out, a.maps.split(","), a.chunked, a.chunk, a.heading_error_deg)
        return
    rows = []
    for name in a.maps.split(","):
        geo = load_map(name)
        if geo is None:
            continue
        for model in a.models.split(","):
            kw = MODELS[model]
            reg = registrability_map(geo, 70.0, **kw)
            row = {"map": name, "model": model, "classes": by_class(reg, geo, classes(name, geo.shape))
                   if name in POLYGONS else {}}
            if a.n > 0:
                v = validate(reg, geo, n=a.n, heading_error_deg=a.heading_error_deg, seed=11,
                             rotation_search_deg=45.0, rotation_search_step_deg=7.5, **kw)
                row.update(n=a.n, fail_rate=float(v["failed"].mean()), fail_rate_quantile=v["fail_rate_quantile"],
                           score_quantile_edges=v["score_quantile_edges"], fail_rate_low=v["fail_rate_low"],
                           fail_rate_high=v["fail_rate_high"], frames={
                               "north": v["positions"][:, 0].tolist(), "east": v["positions"][:, 1].tolist(),
                               "score": v["scores"].tolist(), "failed": v["failed"].tolist(),
                               "error_m": [float(e) if np.isfinite(e) else None for e in v["error_m"]]},
                           low_quarter=low_quarter_stats(v["scores"], v["failed"]))
            rows.append(row)
            print(json.dumps(row), flush=True)
            Path(a.out).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
