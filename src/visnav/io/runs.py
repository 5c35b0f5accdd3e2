"""The run directory (DESIGN §6): scenario.toml, log.h5, truth.tum, estimate.tum, metrics.json, report.html."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from visnav.io.tum import write_tum
from visnav.scenarios.schema import to_toml


def new_run_dir(name: str, out: str | Path | None = None) -> Path:
    if out is not None:
        d = Path(out)
    else:
        d = Path("runs") / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}"
        i = 1
        base = d
        while d.exists():
            d = base.with_name(f"{base.name}-{i}")
            i += 1
    d.mkdir(parents=True, exist_ok=True)
    return d


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return None if math.isnan(v) or math.isinf(v) else v
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def write_run(result, out_dir: Path, report: bool = True) -> Path:
    """Write everything a run produced; each piece is written even if a later one fails."""
    from visnav.io.provenance import provenance

    sc, log = result.scenario, result.log
    prov = provenance(sc)
    (out_dir / "scenario.toml").write_text(to_toml(sc))
    (out_dir / "metrics.json").write_text(json.dumps(_jsonable({**result.metrics, "provenance": prov}), indent=2)
                                          + "\n")
    log.to_hdf5(out_dir / "log.h5", attrs={"seed": sc.run.seed,
                                           **{k: "" if v is None else v for k, v in prov.items()}})
    tr, es = log.get("truth"), log.get("estimate")
    if tr:
        write_tum(out_dir / "truth.tum", tr["t"], tr["position"], tr["euler"])
    if es:
        write_tum(out_dir / "estimate.tum", es["t"], es["position"], es["euler"])
    if report:
        from visnav.analysis.report import write_report

        write_report(result, out_dir / "report.html", provenance=prov)
    return out_dir
