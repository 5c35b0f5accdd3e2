"""The golden figures of every built-in scenario: the headline metrics of seeds 1-N, stored for tests/test_golden.py.

    PYTHONPATH=src python scripts/golden.py [--seeds 5] [--scenarios a,b] [--out tests/data/golden.json] [-j 2]

A scenario's headline metrics are the ones its thesis gives a figure for (``analysis/published.published``) plus
its ``outcome``. Re-run after a change that is *meant* to change results, and say in the commit why they moved.
"""

from __future__ import annotations

import argparse
import json
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

GOLDEN = Path(__file__).resolve().parents[1] / "tests" / "data" / "golden.json"
SKIP = {"palace-sweep": "a frequency sweep for `visnav margins`, not a flight with headline figures"}


def headline(scenario: str, seed: int) -> dict:
    """The headline metrics of one run of ``scenario`` at ``seed`` (numbers, booleans and strings as metrics.json
    has them)."""
    from visnav.analysis.published import published
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation

    sc = load_scenario(scenario, [], seed)
    result = make_simulation(sc).run()
    m = result.metrics
    names = [p.metric for p in published(sc)[0]] + ["outcome"]
    out = {}
    for k in names:
        v = m.get(k)
        if isinstance(v, float) and not math.isfinite(v):
            v = None
        out[k] = v
    if result.error:
        out["error"] = result.error
    return out


def _job(args: tuple[str, int]) -> tuple[str, int, dict]:
    scenario, seed = args
    return scenario, seed, headline(scenario, seed)


def main() -> None:
    from visnav.scenarios.schema import builtin_names

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--scenarios", default="")
    ap.add_argument("--out", default=str(GOLDEN))
    ap.add_argument("-j", type=int, default=2)
    a = ap.parse_args()
    names = [s for s in (a.scenarios.split(",") if a.scenarios else builtin_names()) if s not in SKIP]
    out_path = Path(a.out)
    golden = json.loads(out_path.read_text()) if out_path.is_file() else {}
    jobs = [(s, k) for s in names for k in range(1, a.seeds + 1)]
    with ProcessPoolExecutor(a.j) as pool:
        for scenario, seed, figs in pool.map(_job, jobs):
            golden.setdefault(scenario, {})[str(seed)] = figs
            print(scenario, seed, figs, flush=True)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(golden, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
