"""Run every benchmark (make bench) and print the tables that go into BENCHMARKS.md."""

from __future__ import annotations

import datetime
import os
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_condor  # noqa: E402
import bench_deck  # noqa: E402
import bench_geolocation  # noqa: E402
import bench_ins  # noqa: E402
import bench_landing  # noqa: E402
import bench_pad  # noqa: E402
import bench_render  # noqa: E402
import bench_steps  # noqa: E402
import bench_tracker  # noqa: E402
import bench_witas  # noqa: E402

if __name__ == "__main__":
    print(f"# {datetime.date.today()} on {platform.machine()} {platform.processor() or ''}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}\n")
    for mod in (bench_render, bench_tracker, bench_steps, bench_landing, bench_ins, bench_witas, bench_deck,
                bench_condor, bench_geolocation, bench_pad):
        print(f"\n## {mod.__name__}\n")
        mod.main()
