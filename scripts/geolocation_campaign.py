"""Seed 002 ch. 7 campaign: the mav-geolocation scenario over the procedural rural map and the two real
maps of ../shared/data (20 seeds each), the one-frame case, and the Hough-alignment comparison with
+-30 deg of extra heading error. Writes one JSON of per-run metrics; ``docs/results-geolocation.md``
is built from it by hand.

    PYTHONPATH=src nice -n 10 python scripts/geolocation_campaign.py --out runs/geoloc-campaign.json \
        [--seeds 20] [--hough-seeds 10] [--single-seeds 5] [--workers 2] [--parts main,hough,single,thesis] \
        [--set KEY=VALUE ...]

``--set`` applies to every flight, e.g. the airframe of rounds 1-4: ``--set vehicle.span_m=1.1 --set
vehicle.airspeed_mps=13 --set mission.half_length_m=80 --set control.mav.l1_m=30``.

Target placement (documented in docs/geolocation.md): the real maps are small (199 x 519 m and
596 x 173 m) against a 70 x 56 m footprint at 70 m, so the figure-eight (half length 160 m) runs along
the map's long side and the truck sits where a frame around it lies on the map: on the gravel road of
the column map, in the forest clearing behind the shore of the strip map, on a road of the rural map.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"  # ../shared/data beside the repository
if not DATA.is_dir() and os.environ.get("VISNAV_SHARED_DATA"):
    DATA = Path(os.environ["VISNAV_SHARED_DATA"])
MAPS = {
    "rural": [],
    "column": [f"world.geo_map.file={DATA / 'satellite_column.png'}", "world.truck.north_m=-45",
               "world.truck.east_m=30", "world.truck.heading_deg=45"],
    "strip": [f"world.geo_map.file={DATA / 'satellite_strip.png'}", "world.truck.north_m=-5",
              "world.truck.east_m=100"],
}
KEYS = ("target_error_m", "map_based_error_m", "samples", "false_match_rate", "samples_to_3m",
        "single_frame_error_median_m", "map_based_sample_error_median_m", "hough_applied_rate",
        "samples_rejected", "rls_restarts", "heading_error_rms_deg", "heading_error_max_deg", "sim_time_s",
        "wall_time_s", "error")


def one(job):
    part, name, seed, overrides, scenario = job
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    r = make_simulation(load_scenario(scenario, overrides, seed=seed)).run()
    return {"part": part, "map": name, "seed": seed, "overrides": overrides,
            **{k: r.metrics.get(k) for k in KEYS}}


def jobs(parts, seeds, hough_seeds, single_seeds, extra=()):
    maps = {k: v + list(extra) for k, v in MAPS.items() if k == "rural" or DATA.is_dir()}
    if len(maps) < len(MAPS):
        print(f"real maps skipped: {DATA} not found", file=sys.stderr)
    out = []
    if "main" in parts:
        out += [("main", name, s, ov, "mav-geolocation") for s in seeds for name, ov in maps.items()]
    if "hough" in parts:  # Algorithm 1 against the telemetry heading alone, +-30 deg of heading error
        out += [(f"hough-{h}", "rural", s, ["mission.telemetry.extra_heading_deg=30", f"mission.registration.hough={h}",
                                            *extra], "mav-geolocation") for s in hough_seeds for h in ("true", "false")]
    if "single" in parts:
        out += [("single", name, s, ov, "mav-geolocation-single") for s in single_seeds for name, ov in maps.items()]
    if "thesis" in parts:  # Fig. 7.3 as printed: no scale / rotation refinement, no gating, no quality gate
        out += [("thesis", name, s, ov + ["mission.registration.scale_search=0",
                                          "mission.registration.rotation_refine_deg=0",
                                          "mission.registration.gate_prob=0", "mission.registration.min_quality=0"],
                 "mav-geolocation") for name, ov in maps.items() for s in single_seeds]
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--hough-seeds", type=int, default=10)
    ap.add_argument("--single-seeds", type=int, default=5)
    ap.add_argument("--parts", default="main,hough,single")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="override for every flight (repeatable)")
    a = ap.parse_args()
    todo = jobs(a.parts.split(","), list(range(1, a.seeds + 1)), list(range(1, a.hough_seeds + 1)),
                list(range(1, a.single_seeds + 1)), a.overrides)
    out = Path(a.out)
    done = json.loads(out.read_text()) if out.exists() else []
    seen = {(d["part"], d["map"], d["seed"]) for d in done}
    todo = [j for j in todo if (j[0], j[1], j[2]) not in seen]
    out.parent.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(a.workers) as ex:
        for i, row in enumerate(ex.map(one, todo)):
            done.append(row)
            out.write_text(json.dumps(done, indent=1, default=str))
            print(f"{i + 1}/{len(todo)} {row['part']} {row['map']} seed {row['seed']}: "
                  f"target {row['target_error_m']}, map-based {row['map_based_error_m']}", flush=True)


if __name__ == "__main__":
    main()
