"""Monte Carlo campaigns and parameter grids, on a local process pool or a Dask cluster (DESIGN §7).

A campaign is a scenario, a list of seeds, base ``--set`` overrides and an optional grid (the
cartesian product of ``key=v1,v2,...`` lists). Each (grid point, seed) is one run. Rows are appended
to ``<out>/runs.csv`` as runs finish, so an interrupted campaign resumes and skips what is done; a run
that raises is recorded as failed with its error and the campaign goes on. ``runs.csv`` holds only
reproducible columns (the same seeds give identical rows on any executor); wall-clock figures go to
``timings.csv``. ``summary.json`` and ``report.html`` are written at the end.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

TIMING_KEYS = ("wall_time_s", "real_time_factor")
ID_KEYS = ("seed", "status", "error")


class CampaignError(ValueError):
    """A campaign definition is invalid; the message is one line for the user."""


@dataclass(frozen=True)
class Job:
    scenario: str
    seed: int
    overrides: tuple[str, ...]
    grid: tuple[tuple[str, Any], ...] = ()

    @property
    def key(self) -> tuple:
        return (self.seed,) + tuple(_cell(v) for _, v in self.grid)


def _cell(v) -> str:
    """One CSV cell, the same text whether the value came from a run or was read back from the file."""
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return "" if math.isnan(v) else repr(v)
    if v is None:
        return ""
    return str(v)


def _toml_value(v) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v)


def run_job(job: Job) -> dict:
    """Run one simulation; never raises: a failure is a row with status 'failed' and the error."""
    import cv2

    cv2.setNumThreads(1)  # one run per core
    from visnav.scenarios.schema import load_scenario
    from visnav.sim.missions import make_simulation

    row: dict = {"seed": job.seed, **{k: v for k, v in job.grid}}
    try:
        sets = list(job.overrides) + [f"{k}={_toml_value(v)}" for k, v in job.grid]
        res = make_simulation(load_scenario(job.scenario, sets, seed=job.seed)).run()
        row["status"] = "failed" if res.error else "ok"
        row["error"] = res.error or ""
        row.update(res.metrics)
    except Exception as exc:  # noqa: BLE001 - the campaign records it and goes on
        row["status"] = "failed"
        row["error"] = f"{type(exc).__name__}: {exc}"
    return row


def parse_grid(items: Iterable[str]) -> dict[str, list]:
    """``["mission.altitude_m=6,12", "world.surface=grass,asphalt"]`` -> {key: [values]}; values as TOML."""
    from visnav.scenarios.schema import _parse_value

    grid: dict[str, list] = {}
    for it in items:
        if "=" not in it:
            raise CampaignError(f"grid entry '{it}' is not of the form key=v1,v2,...")
        key, text = it.split("=", 1)
        vals = [_parse_value(v.strip()) for v in text.split(",") if v.strip()]
        if not key.strip():
            raise CampaignError(f"grid entry '{it}' has an empty key")
        if not vals:
            raise CampaignError(f"grid '{key}' is empty: give at least one value")
        grid[key.strip()] = vals
    return grid


def validate_campaign(scenario: str, overrides: list[str], grid: dict[str, list]) -> None:
    """Load the scenario once per grid value so a bad key or value fails before any run starts."""
    from visnav.scenarios.schema import ScenarioError, load_scenario

    try:
        load_scenario(scenario, overrides)
        for k, vals in grid.items():
            for v in vals:
                load_scenario(scenario, overrides + [f"{k}={_toml_value(v)}"])
    except ScenarioError as exc:
        raise CampaignError(str(exc)) from None


def make_jobs(scenario: str, seeds: list[int], overrides: list[str], grid: dict[str, list]) -> list[Job]:
    keys = list(grid)
    combos = list(itertools.product(*[grid[k] for k in keys])) if keys else [()]
    return [Job(scenario, s, tuple(overrides), tuple(zip(keys, combo))) for combo in combos for s in seeds]


# --------------------------------------------------------------------------------------- files
def _read_csv(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _append_csv(path: Path, row: dict) -> None:
    """Append a row; when the row brings new columns, rewrite the file with the union header."""
    row = {k: _cell(v) for k, v in row.items()}
    rows = _read_csv(path)
    header = list(rows[0].keys()) if rows else []
    new = [k for k in row if k not in header]
    if rows and new:
        header += new
        tmp = path.with_suffix(".tmp")
        with tmp.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=header)
            w.writeheader()
            w.writerows(rows)
            w.writerow(row)
        os.replace(tmp, path)
        return
    if not rows:
        header = list(row)
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=header)
        if not rows and f.tell() == 0:
            w.writeheader()
        w.writerow(row)


def _as_number(v: str):
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x


def summarize(rows: list[dict], grid_keys: list[str]) -> dict:
    """count, failures, and mean / median / p95 / min / max of every numeric metric (overall and per grid point)."""

    def stats(rs: list[dict]) -> dict:
        out = {}
        keys = [k for k in (rs[0].keys() if rs else []) if k not in ID_KEYS and k not in grid_keys]
        for k in keys:
            vals = [_as_number(r.get(k)) for r in rs if r.get("status") == "ok"]
            vals = np.array([v for v in vals if v is not None and math.isfinite(v)])
            if vals.size:
                out[k] = {"mean": float(vals.mean()), "median": float(np.median(vals)),
                          "p95": float(np.percentile(vals, 95)), "min": float(vals.min()),
                          "max": float(vals.max()), "n": int(vals.size)}
        return out

    summary = {"count": len(rows), "failed": sum(r.get("status") != "ok" for r in rows), "metrics": stats(rows)}
    if grid_keys:
        groups: dict[str, list] = {}
        for r in rows:
            groups.setdefault(", ".join(f"{k}={r.get(k)}" for k in grid_keys), []).append(r)
        summary["by_grid"] = {g: {"count": len(rs), "failed": sum(x.get("status") != "ok" for x in rs),
                                  "metrics": stats(rs)} for g, rs in groups.items()}
    return summary


# --------------------------------------------------------------------------------------- runner
@dataclass
class Campaign:
    scenario: str
    seeds: list[int]
    out: Path
    overrides: list[str] = field(default_factory=list)
    grid: dict[str, list] = field(default_factory=dict)
    workers: int = 2
    scheduler: str | None = None

    def __post_init__(self) -> None:
        if not self.seeds:
            raise CampaignError("no runs: N must be at least 1")
        if self.workers < 1:
            raise CampaignError(f"--workers must be at least 1, got {self.workers}")
        self.out = Path(self.out)

    @property
    def runs_csv(self) -> Path:
        return self.out / "runs.csv"

    def pending(self) -> list[Job]:
        done = {(r["seed"],) + tuple(r.get(k, "") for k in self.grid) for r in _read_csv(self.runs_csv)}
        return [j for j in make_jobs(self.scenario, self.seeds, self.overrides, self.grid) if
                tuple(_cell(x) for x in j.key) not in done]

    def _record(self, row: dict) -> None:
        timing = {k: row.pop(k) for k in TIMING_KEYS if k in row}
        _append_csv(self.runs_csv, row)
        _append_csv(self.out / "timings.csv", {"seed": row["seed"], **{k: row.get(k) for k in self.grid},
                                                **timing})

    def run(self, progress: Callable[[int, int, dict], None] | None = None) -> dict:
        validate_campaign(self.scenario, self.overrides, self.grid)
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / "campaign.json").write_text(json.dumps(
            {"scenario": self.scenario, "seeds": self.seeds, "overrides": self.overrides, "grid": self.grid},
            indent=2, default=str))
        jobs = self.pending()
        total = len(jobs)
        for i, row in enumerate(self._execute(jobs), 1):
            self._record(row)
            if progress is not None:
                progress(i, total, row)
        rows = _read_csv(self.runs_csv)
        summary = summarize(rows, list(self.grid))
        (self.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        try:
            write_campaign_report(self.out, rows, summary, list(self.grid), self.scenario)
        except Exception as exc:  # noqa: BLE001 - the rows and summary are already on disk
            (self.out / "report.html").write_text(f"<p>report failed: {type(exc).__name__}: {exc}</p>")
        return summary

    def _execute(self, jobs: list[Job]) -> Iterable[dict]:
        if not jobs:
            return
        if self.scheduler:
            yield from self._execute_dask(jobs)
            return
        if self.workers == 1:
            for j in jobs:
                yield run_job(j)
            return
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # spawn, not fork: forking a process that already runs OpenCV / render threads can deadlock
        with ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn")) as ex:
            futs = [ex.submit(run_job, j) for j in jobs]
            for f in as_completed(futs):
                yield f.result()

    def _execute_dask(self, jobs: list[Job]) -> Iterable[dict]:
        try:
            from distributed import Client, as_completed
        except ImportError as exc:  # pragma: no cover - dask is a dependency
            raise CampaignError(f"--scheduler needs dask.distributed: {exc}") from None
        try:
            client = self.scheduler if not isinstance(self.scheduler, str) else Client(self.scheduler, timeout="5s")
        except (OSError, TimeoutError) as exc:
            raise CampaignError(f"cannot reach the Dask scheduler at {self.scheduler}: {exc}") from None
        futs = client.map(run_job, jobs, pure=False)
        for f in as_completed(futs):
            yield f.result()


def write_campaign_report(out: Path, rows: list[dict], summary: dict, grid_keys: list[str], scenario: str) -> None:
    import base64
    import html
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    metrics = [k for k in summary.get("metrics", {}) if k not in ("sim_time_s",)][:12]
    imgs = []
    for k in metrics:
        fig, ax = plt.subplots(figsize=(6, 3.2))
        if grid_keys:
            g = grid_keys[0]
            labels = sorted({r.get(g) for r in ok}, key=lambda s: (_as_number(s) is None, _as_number(s) or 0, s))
            data = [[_as_number(r[k]) for r in ok if r.get(g) == lab and _as_number(r.get(k)) is not None]
                    for lab in labels]
            ax.boxplot([d if d else [np.nan] for d in data])
            ax.set_xticks(range(1, len(labels) + 1), labels)
            ax.set_xlabel(g)
        else:
            vals = [_as_number(r.get(k)) for r in ok]
            ax.hist([v for v in vals if v is not None and math.isfinite(v)], bins=20)
        ax.set_title(k)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=80, bbox_inches="tight")
        plt.close(fig)
        imgs.append('<img src="data:image/png;base64,' + base64.b64encode(buf.getvalue()).decode() + '"/>')
    table = "".join(
        f"<tr><td>{html.escape(k)}</td>" + "".join(f"<td>{v[s]:.4g}</td>" for s in ("mean", "median", "p95", "min", "max"))
        + f"<td>{v['n']}</td></tr>" for k, v in summary.get("metrics", {}).items())
    fails = "".join(f"<li>seed {html.escape(str(r.get('seed')))}: {html.escape(str(r.get('error')))}</li>"
                    for r in rows if r.get("status") != "ok")
    doc = f"""<!doctype html><html><head><meta charset="utf-8"><title>campaign {html.escape(scenario)}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}} td,th{{padding:2px 8px;border-bottom:1px solid #ddd}}</style>
</head><body><h1>Campaign: {html.escape(scenario)}</h1><p>{summary['count']} runs, {summary['failed']} failed.
Grid: {html.escape(', '.join(grid_keys) or 'none')}.</p>
<table><tr><th>metric</th><th>mean</th><th>median</th><th>p95</th><th>min</th><th>max</th><th>n</th></tr>{table}</table>
{('<h2>Failed runs</h2><ul>' + fails + '</ul>') if fails else ''}<h2>Plots</h2>{''.join(imgs)}</body></html>"""
    (out / "report.html").write_text(doc)
