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


def one(src: str, scenario: str, seed: int, overrides=(), warm: bool = False) -> dict:
    env = {**os.environ, "PYTHONPATH": str(Path(src).resolve())}
    sets = [x for o in overrides for x in ("--set", o)] + (["--warm"] if warm else [])
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
    ap.add_argument("--warm", action="store_true", help="time each process's second run (rtf.py --warm): what a "
                    "campaign worker's runs cost; the first run's wall time (imports done, kernels loaded in it) "
                    "is shown apart")
    a = ap.parse_args()
    rows: dict[tuple[str, str], list[dict]] = {}
    for r in range(a.rounds):
        for sc in a.scenarios.split(","):
            order = (("before", a.before), ("after", a.after)) if r % 2 == 0 else (("after", a.after), ("before", a.before))
            for tag, src in order:
                res = one(src, sc, a.seed, a.after_set if tag == "after" else (), a.warm)
                res["which"], res["round"] = tag, r
                print(json.dumps(res), flush=True)
                rows.setdefault((sc, tag), []).append(res)
    print(f"\n{'Warm: each process flew seed + 1 first (untimed); ' if a.warm else ''}RTF after / before is the "
          "ratio of the two minimum wall times' RTF")
    print("\n| scenario | | wall s min / med (RTF max) | CPU s min / med (RTF max) | main-thread CPU s min | "
          "waited on frames s min | load avg | first run wall s min | RTF after / before |")
    print("|---|---|---|---|---|---|---|---|---|")
    for sc in a.scenarios.split(","):
        for tag in ("before", "after"):
            rs = rows[(sc, tag)]
            w, c = [x["wall_s"] for x in rs], [x["cpu_s"] for x in rs]
            sim = rs[0]["sim_s"]
            print(f"| {sc} | {tag} | {min(w):.2f} / {statistics.median(w):.2f} ({sim / min(w):.1f}x) | "
                  f"{min(c):.2f} / {statistics.median(c):.2f} ({sim / min(c):.1f}x) | "
                  f"{min(x['main_cpu_s'] for x in rs):.2f} | {min(x['render_wait_s'] for x in rs):.2f} | "
                  f"{min(x['load'] for x in rs):.1f}-{max(x['load'] for x in rs):.1f} | {_first(rs)} | "
                  f"{_ratio(rows, sc) if tag == 'after' else ''} |")


def _first(rs: list[dict]) -> str:
    f = [x["first_run_wall_s"] for x in rs if x.get("first_run_wall_s") is not None]
    return f"{min(f):.2f}" if f else "-"


def _ratio(rows: dict, sc: str) -> str:
    """RTF after / before - 1 on the minimum wall times (same simulated time: the inverse wall-time ratio)."""
    b, a = (rows[(sc, t)] for t in ("before", "after"))
    rb, ra = b[0]["sim_s"] / min(x["wall_s"] for x in b), a[0]["sim_s"] / min(x["wall_s"] for x in a)
    return f"{100.0 * (ra / rb - 1.0):+.0f} %"


if __name__ == "__main__":
    main()
