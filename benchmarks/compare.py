"""Interleaved before/after real-time factors of the closed-loop scenarios.

    python benchmarks/compare.py BEFORE_SRC AFTER_SRC [--rounds 3] [--scenarios a,b] [--seed 1] [--after-set K=V ...]

Each round runs every scenario once per checkout (a fresh process each, ``benchmarks/rtf.py`` with
that checkout's ``src`` on ``PYTHONPATH``), before and after back to back, so both see the same
load. ``--after-set`` overrides keys of the after checkout's scenario only (the same flight on a checkout whose
defaults moved: e.g. deck-moving with the ideal sensors the before checkout flew). Prints one JSON line per run and a markdown table of min / median per checkout (the machine is
shared: the minimum is the least disturbed run) with the load average seen.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENARIOS = ("palace-landing", "witas-homing", "deck-moving", "condor-orbit")


def one(src: str, scenario: str, seed: int, overrides=()) -> dict:
    env = {**os.environ, "PYTHONPATH": str(Path(src).resolve())}
    sets = [x for o in overrides for x in ("--set", o)]
    out = subprocess.run([sys.executable, str(HERE / "rtf.py"), scenario, "--seed", str(seed), *sets], env=env,
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--scenarios", default=",".join(SCENARIOS))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--after-set", action="append", default=[], help="override a key of the after run (KEY=VALUE)")
    a = ap.parse_args()
    rows: dict[tuple[str, str], list[dict]] = {}
    for r in range(a.rounds):
        for sc in a.scenarios.split(","):
            order = (("before", a.before), ("after", a.after)) if r % 2 == 0 else (("after", a.after), ("before", a.before))
            for tag, src in order:
                res = one(src, sc, a.seed, a.after_set if tag == "after" else ())
                res["which"], res["round"] = tag, r
                print(json.dumps(res), flush=True)
                rows.setdefault((sc, tag), []).append(res)
    print("\n| scenario | | wall s min / med (RTF max) | CPU s min / med (RTF max) | main-thread CPU s min | "
          "waited on frames s min | load avg |")
    print("|---|---|---|---|---|---|---|")
    for sc in a.scenarios.split(","):
        for tag in ("before", "after"):
            rs = rows[(sc, tag)]
            w, c = [x["wall_s"] for x in rs], [x["cpu_s"] for x in rs]
            sim = rs[0]["sim_s"]
            print(f"| {sc} | {tag} | {min(w):.2f} / {statistics.median(w):.2f} ({sim / min(w):.1f}x) | "
                  f"{min(c):.2f} / {statistics.median(c):.2f} ({sim / min(c):.1f}x) | "
                  f"{min(x['main_cpu_s'] for x in rs):.2f} | {min(x['render_wait_s'] for x in rs):.2f} | "
                  f"{min(x['load'] for x in rs):.1f}-{max(x['load'] for x in rs):.1f} |")


if __name__ == "__main__":
    main()
