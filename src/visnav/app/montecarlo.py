"""Monte Carlo campaigns and parameter grids, on a local process pool or a Dask cluster (DESIGN §7).

A campaign is a scenario, a list of seeds, base ``--set`` overrides and an optional grid (the
cartesian product of ``key=v1,v2,...`` lists). Each (grid point, seed) is one run. Rows are appended
to ``<out>/runs.csv`` as runs finish, so an interrupted campaign resumes and skips what is done; a run
that raises is recorded as failed with its error and the campaign goes on. ``runs.csv`` holds only
reproducible columns (the same seeds give identical rows on any executor); wall-clock figures go to
``timings.csv``. ``summary.json`` and ``report.html`` are written at the end.

Resuming is safe: ``campaign.json`` holds the SHA-256 of the resolved scenario (``--set`` applied,
seed left out) and the grid keys; a directory holding a campaign of another configuration is refused
with the keys that differ (``new=True`` starts a fresh directory beside it instead). More seeds or
more grid values extend a campaign. Ctrl-C leaves ``runs.csv`` with the finished runs only.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from visnav.analysis.campaign_report import _as_number, write_campaign_report
from visnav.app.missions import make_simulation
from visnav.app.runs import OutputDirError, prepare_out_dir
from visnav.io.provenance import provenance
from visnav.scenarios.schema import load_scenario, _parse_value, ScenarioError, scenario_hash
import multiprocessing
from visnav.analysis.report import published_bands, published_figures
from concurrent.futures import ProcessPoolExecutor, as_completed

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
    #: frames render on a second thread (``Simulation.render_thread``): worth it where the run has a core to
    #: spare, not where the campaign runs a simulation per core (the thread's hand-overs cost ~15 % CPU)
    render_thread: bool = True

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

    row: dict = {"seed": job.seed, **{k: v for k, v in job.grid}}
    try:
        sets = list(job.overrides) + [f"{k}={_toml_value(v)}" for k, v in job.grid]
        sim = make_simulation(load_scenario(job.scenario, sets, seed=job.seed))
        sim.render_thread = job.render_thread  # (the same numbers either way)
        res = sim.run()
        if res.interrupted:  # Ctrl-C inside the run: no row (the campaign stops, resumable)
            raise KeyboardInterrupt
        row["status"] = "failed" if res.error else "ok"
        row["error"] = res.error or ""
        row.update(res.metrics)
    except Exception as exc:  # noqa: BLE001 - the campaign records it and goes on
        row["status"] = "failed"
        row["error"] = f"{type(exc).__name__}: {exc}"
    return row


def parse_grid(items: Iterable[str]) -> dict[str, list]:
    """``["mission.altitude_m=6,12", "world.surface=grass,asphalt"]`` -> {key: [values]}; values as TOML."""

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


_BOOL = {"True": True, "False": False, "true": True, "false": False}


def outcome_counts(rows: list[dict]) -> dict[str, int]:
    """outcome (analysis/outcome.py) -> runs, and ``hpl_violated_while_ok``: runs with a step over the HPL while ok."""
    out: dict[str, int] = {}
    for r in rows:
        if r.get("outcome"):
            out[str(r["outcome"])] = out.get(str(r["outcome"]), 0) + 1
    n = sum((_as_number(r.get("hpl_bound_violations")) or 0) > 0 for r in rows)
    return out | ({"hpl_violated_while_ok": n} if n else {})


def summarize(rows: list[dict], grid_keys: list[str], published: dict | None = None,
              bands: dict | None = None) -> dict:
    """count, failures, and mean / median / p95 / min / max of every numeric metric, the rate of
    every boolean one (landed, aborted, returned_home, ...), overall and per grid point; with
    ``published`` (metric -> the thesis' figure) that figure beside each metric that has one; with ``bands``
    (metric -> (lo, hi)) how many runs lie inside each band (``in_band`` of ``n``, and the ``band``): a filter
    consistent in the 95 % chi2 band of its NEES puts 95 % of its runs there."""
    published, bands = published or {}, bands or {}

    def stats(rs: list[dict]) -> tuple[dict, dict]:
        out, rates = {}, {}
        keys = [k for k in (rs[0].keys() if rs else []) if k not in ID_KEYS and k not in grid_keys]
        ok = [r for r in rs if r.get("status") == "ok"]
        for k in keys:
            cells = [r.get(k) for r in ok if r.get(k) not in (None, "")]
            if cells and all(c in _BOOL for c in cells):
                b = np.array([_BOOL[c] for c in cells])
                rates[k] = {"rate": float(b.mean()), "count": int(b.sum()), "n": int(b.size)}
                if k in published:
                    rates[k]["published"] = published[k]
                continue
            vals = [_as_number(c) for c in cells]
            vals = np.array([v for v in vals if v is not None and math.isfinite(v)])
            if vals.size:
                out[k] = {"mean": float(vals.mean()), "median": float(np.median(vals)),
                          "p95": float(np.percentile(vals, 95)), "min": float(vals.min()),
                          "max": float(vals.max()), "n": int(vals.size)}
                if k in published:
                    out[k]["published"] = published[k]
                if k in bands:
                    lo, hi = bands[k]
                    out[k]["in_band"], out[k]["band"] = int(((vals >= lo) & (vals <= hi)).sum()), [lo, hi]
        return out, rates

    metrics, rates = stats(rows)
    summary = {"count": len(rows), "failed": sum(r.get("status") != "ok" for r in rows), "metrics": metrics,
               "rates": rates, "outcomes": outcome_counts(rows)}
    if grid_keys:
        groups: dict[str, list] = {}
        for r in rows:
            groups.setdefault(", ".join(f"{k}={r.get(k)}" for k in grid_keys), []).append(r)
        summary["by_grid"] = {}
        for g, rs in groups.items():
            m, rt = stats(rs)
            summary["by_grid"][g] = {"count": len(rs), "failed": sum(x.get("status") != "ok" for x in rs),
                                     "metrics": m, "rates": rt}
    return summary


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def config_diff(old: dict, new: dict, limit: int = 8) -> str:
    """'key: old -> new' for every key that differs between two resolved scenarios (dicts)."""
    a, b = _flatten(old), _flatten(new)
    diffs = [f"{k}: {a.get(k, '(absent)')!r} -> {b.get(k, '(absent)')!r}" for k in sorted(set(a) | set(b))
             if a.get(k, None) != b.get(k, None)]
    more = f" and {len(diffs) - limit} more" if len(diffs) > limit else ""
    return "; ".join(diffs[:limit]) + more


def _published(sc) -> tuple[dict, str, dict]:
    try:
        return (*published_figures(sc), published_bands(sc))
    except Exception:  # noqa: BLE001 - the figures are a comment beside the numbers, never a reason to stop
        return {}, "", {}


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

    def identity(self) -> dict:
        """What a resume must match: the resolved scenario without its seed (hash and content), the grid keys."""

        sc = load_scenario(self.scenario, self.overrides, seed=0)
        self._published = _published(sc)
        return {"scenario_hash": scenario_hash(sc, ignore_seed=True), "grid_keys": list(self.grid),
                "resolved": sc.model_dump(mode="json")}

    def prepare(self, new: bool = False) -> tuple[int, int]:
        """Check the campaign and its directory, write campaign.json; returns (runs done, runs to do).
        A directory holding another configuration's campaign (or anything else) is refused, or with
        ``new`` the campaign moves to the first free ``<out>-2``, ``<out>-3``, ... (``self.moved_from``)."""
        validate_campaign(self.scenario, self.overrides, self.grid)
        ident = self.identity()
        self.moved_from = None
        problem = self._conflict(ident)
        if problem and new:
            self.moved_from, i = self.out, 2
            while (self.out.parent / f"{self.moved_from.name}-{i}").exists():
                i += 1
            self.out = self.out.parent / f"{self.moved_from.name}-{i}"
        elif problem:
            raise CampaignError(f"{self.out}: {problem}; use --new to start a fresh campaign beside it, "
                                "or another --out")
        try:
            prepare_out_dir(self.out, force=True, clear=(), kind=None)
        except OutputDirError as exc:
            raise CampaignError(str(exc)) from None
        old = self._read_json()
        seeds = sorted(set(self.seeds) | set(old.get("seeds", [])))
        grid = {k: list(dict.fromkeys(list(old.get("grid", {}).get(k, [])) + list(v))) for k, v in self.grid.items()}
        (self.out / "campaign.json").write_text(json.dumps(
            {"scenario": self.scenario, "seeds": seeds, "overrides": self.overrides, "grid": grid, **ident},
            indent=2, default=str))
        todo = len(self.pending())
        self._prepared = True
        return len(make_jobs(self.scenario, self.seeds, self.overrides, self.grid)) - todo, todo

    def _read_json(self) -> dict:
        p = self.out / "campaign.json"
        try:
            return json.loads(p.read_text()) if p.is_file() else {}
        except (OSError, ValueError):
            return {"unreadable": True}

    def _conflict(self, ident: dict) -> str | None:
        """Why ``self.out`` cannot take this campaign (None when it can: absent, empty or the same configuration)."""
        if not self.out.exists():
            return None
        if not self.out.is_dir():
            return "exists and is not a directory"
        old = self._read_json()
        if not old:
            return None if not any(self.out.iterdir()) else "not empty and holds no campaign.json (not a campaign)"
        if "scenario_hash" not in old:
            return "its campaign.json has no configuration hash (older visnav or unreadable): cannot resume it safely"
        if old["scenario_hash"] != ident["scenario_hash"]:
            return "holds a campaign of another configuration (" + config_diff(old.get("resolved", {}),
                                                                              ident["resolved"]) + ")"
        if list(old.get("grid_keys", [])) != ident["grid_keys"]:
            return f"holds a campaign over another grid (keys {old.get('grid_keys')} -> {ident['grid_keys']})"
        return None

    def _record(self, row: dict) -> None:
        timing = {k: row.pop(k) for k in TIMING_KEYS if k in row}
        _append_csv(self.runs_csv, row)
        _append_csv(self.out / "timings.csv", {"seed": row["seed"], **{k: row.get(k) for k in self.grid},
                                                **timing})

    def run(self, progress: Callable[[int, int, dict], None] | None = None) -> dict:
        """Run what is pending (``prepare`` first when not done); Ctrl-C propagates with runs.csv
        holding the finished runs only."""
        if not getattr(self, "_prepared", False):
            self.prepare()
        jobs = self.pending()
        total = len(jobs)
        for i, row in enumerate(self._execute(jobs), 1):
            self._record(row)
            if progress is not None:
                progress(i, total, row)
        rows = _read_csv(self.runs_csv)
        published, source, bands = getattr(self, "_published", ({}, "", {}))
        summary = summarize(rows, list(self.grid), published, bands)
        if published:
            summary["published_source"] = source

        prov = provenance()
        prov["scenario"] = str(self.scenario)
        prov["scenario_hash"] = self.identity()["scenario_hash"]  # the campaign's: the resolved scenario without its seed
        summary["provenance"] = prov
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
        jobs = [replace(j, render_thread=False) for j in jobs]  # a run per core: frames render on its own thread

        # spawn, not fork: forking a process that already runs OpenCV / render threads can deadlock
        with ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn")) as ex:
            futs = [ex.submit(run_job, j) for j in jobs]
            try:
                for f in as_completed(futs):
                    yield f.result()
            except BaseException:  # Ctrl-C (or the consumer stops): queued runs are dropped, not waited for
                ex.shutdown(wait=False, cancel_futures=True)
                raise

    def _execute_dask(self, jobs: list[Job]) -> Iterable[dict]:
        try:
            from distributed import Client, as_completed
        except ImportError as exc:  # pragma: no cover - dask is a dependency
            raise CampaignError(f"--scheduler needs dask.distributed: {exc}") from None
        try:
            client = self.scheduler if not isinstance(self.scheduler, str) else Client(self.scheduler, timeout="5s")
        except (OSError, TimeoutError) as exc:
            raise CampaignError(f"cannot reach the Dask scheduler at {self.scheduler}: {exc}") from None
        futs = client.map(run_job, [replace(j, render_thread=False) for j in jobs], pure=False)
        for f in as_completed(futs):
            yield f.result()
