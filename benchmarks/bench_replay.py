"""Benchmark: ``visnav record`` + ``visnav replay`` per navigator (issue #14).

Run: ``PYTHONPATH=src python benchmarks/bench_replay.py [--set KEY=VALUE ...] [--only SCENARIO|NAVIGATOR]``.
Flies each scenario once with the recording proxy, replays the folder, and prints a markdown table:
simulated time, record wall time, folder size, replay wall time, replay real-time factor (flight time /
replay wall time, also on CPU time) and the largest position difference between the replayed and the
closed-loop estimates over the whole flight. ``main()`` returns the rows.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from visnav.io.recording import Recording  # noqa: E402
from visnav.app.replay import replay  # noqa: E402
from visnav.scenarios.schema import load_scenario  # noqa: E402
from visnav.app.record import record  # noqa: E402

#: (navigator, scenario) pairs
CASES = [("palace", "palace-landing"), ("witas", "witas-homing"), ("deck", "deck-moving"), ("deck", "deck-static"),
         ("condor", "condor-orbit")]


def _max_difference(closed, replayed) -> float:
    a, b = closed.get("estimate"), replayed.get("estimate")
    idx = np.searchsorted(b["t"], a["t"])
    assert np.array_equal(b["t"][idx], a["t"])
    va = np.asarray(a["valid"], bool) if "valid" in a else np.ones(len(a["t"]), bool)  # the deck loop logs no valid
    return float(np.max(np.abs(np.asarray(a["position"])[va] - np.asarray(b["position"])[idx][va])))


def bench(navigator: str, scenario: str, overrides=()) -> dict:
    sc = load_scenario(scenario, list(overrides))
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        rec = record(sc, d)
        rec_wall = time.perf_counter() - t
        size = sum(f.stat().st_size for f in Path(d).rglob("*") if f.is_file())
        res = replay(Recording.open(d), navigator)
    m = res.metrics
    return {"navigator": navigator, "scenario": sc.run.name, "flight_s": m["flight_duration_s"],
            "frames": m["frames_used"], "record_wall_s": rec_wall, "folder_mb": size / 1e6,
            "replay_wall_s": m["replay_wall_s"], "rtf": m["replay_real_time_factor"],
            "rtf_cpu": m["replay_real_time_factor_cpu"], "max_diff_m": _max_difference(rec.run.log, res.log),
            "ate_rmse_m": m.get("ate_rmse_m", float("nan"))}


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", action="append", default=[], dest="overrides")
    ap.add_argument("--only", action="append", help="a navigator or a scenario (repeatable)")
    a = ap.parse_args(argv)
    rows = [bench(n, s, a.overrides) for n, s in CASES if not a.only or n in a.only or s in a.only]
    print("| navigator | scenario | flight [s] | frames | record wall [s] | folder [MB] | replay wall [s] | "
          "replay RTF (wall / CPU) | max position difference to the closed loop [m] | ATE rmse [m] |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['navigator']} | {r['scenario']} | {r['flight_s']:.1f} | {r['frames']} | "
              f"{r['record_wall_s']:.1f} | "
              f"{r['folder_mb']:.0f} | {r['replay_wall_s']:.1f} | {r['rtf']:.1f} / {r['rtf_cpu']:.1f} | "
              f"{r['max_diff_m']:.3g} | {r['ate_rmse_m']:.3f} |")
    return rows


if __name__ == "__main__":
    main()
