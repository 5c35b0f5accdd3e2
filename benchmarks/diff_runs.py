"""Compare two dumps of ``benchmarks/rtf.py --dump``: metrics and every logged array.

    python benchmarks/diff_runs.py BEFORE.npz AFTER.npz [--tol 1e-9]

Prints the largest absolute difference of each logged field (truth, estimates, commands ...) and of
each numeric metric, and exits 1 when a metric differs by more than ``--tol`` (relative to 1 + |value|).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def flatten(d, prefix=""):
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def main(a_path: str, b_path: str, tol: float) -> int:
    a, b = np.load(a_path), np.load(b_path)
    ma = flatten(json.loads(str(a["__metrics__"])))
    mb = flatten(json.loads(str(b["__metrics__"])))
    worst_log = 0.0
    for k in sorted(set(a.files) | set(b.files)):
        if k == "__metrics__":
            continue
        if k not in a.files or k not in b.files:
            print(f"log {k}: only in {'before' if k in a.files else 'after'}")
            worst_log = np.inf
            continue
        x, y = a[k], b[k]
        if x.shape != y.shape:
            print(f"log {k}: shape {x.shape} vs {y.shape}")
            worst_log = np.inf
            continue
        if x.dtype.kind in "fc":
            d = float(np.nanmax(np.abs(x - y))) if x.size else 0.0
            same_nan = bool(np.array_equal(np.isnan(x), np.isnan(y)))
            worst_log = max(worst_log, d if same_nan else np.inf)
        else:
            d = 0.0 if np.array_equal(x, y) else np.inf
            worst_log = max(worst_log, d)
        if d > 0:
            print(f"log {k}: max |diff| {d:.3g}")
    print(f"log: largest difference {worst_log:.3g}")
    bad = 0
    for k in sorted(set(ma) | set(mb)):
        x, y = ma.get(k), mb.get(k)
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
            d = abs(x - y) if not (np.isnan(x) and np.isnan(y)) else 0.0
            if d > tol * (1 + abs(x)) or np.isnan(d):
                bad += 1
                print(f"metric {k}: {x!r} -> {y!r} (diff {d:.3g})")
        elif x != y:
            bad += 1
            print(f"metric {k}: {x!r} -> {y!r}")
    print(f"metrics: {len(ma)} compared, {bad} differ by more than {tol:g}")
    return 1 if bad else 0


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--tol", type=float, default=1e-9)
    a = ap.parse_args()
    sys.exit(main(a.before, a.after, a.tol))
