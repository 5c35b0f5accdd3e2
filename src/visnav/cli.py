"""Command line: ``visnav run SCENARIO``, ``visnav scenarios``, ``visnav keys``, ``visnav montecarlo``, ``visnav bridge``, ...

User errors (bad scenario, key, value, file, unwritable or occupied ``--out``) are one line on
stderr and exit code 2, never a traceback; Ctrl-C writes what a run has and exits 130. Help texts are
rich markup: units in brackets are written escaped (``\\[m]``).
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path
from typing import List, NoReturn, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

import visnav
import time as _time
import csv
import time

app = typer.Typer(add_completion=False, no_args_is_help=True, help="visnav: UAV navigation without GPS")
# off a terminal (``make run``, a pipe, a log) rich would lay tables out 80 columns wide: widen them (issue #32)
console = Console(width=None if sys.stdout.isatty() or os.environ.get("COLUMNS") else 140)
err_console = Console(stderr=True)


def _builtin_names() -> str:
    return ", ".join(sorted(p.stem for p in (Path(visnav.__file__).parent / "scenarios").glob("*.toml")))


def _fail(message, code: int = 2) -> NoReturn:
    """One line on stderr, then exit (2: a user error)."""
    err_console.print(f"[red]error:[/red] {escape(str(message))}", soft_wrap=True)
    raise typer.Exit(code)


def _print_json(obj) -> None:
    from visnav.io.json_values import jsonable

    print(json.dumps(jsonable(obj), indent=2))


def _version(value: bool) -> None:
    if value:
        print(f"visnav {visnav.__version__}")
        raise typer.Exit()


@app.callback()
def _main(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="print the version and exit")) -> None:
    """visnav: UAV navigation without GPS"""


def _metrics_table(title: str, names, *columns: str) -> Table:
    """A table whose first column (the metric names) is never cut, not even 80 columns wide off a terminal
    (issue #32: "hpl_bound_violat…" under ``make run``); the other columns fold. ``">value"``: right-justified."""
    t = Table(title=title)
    t.add_column("metric", no_wrap=True, min_width=max((len(str(n)) for n in names), default=6))
    for c in columns:
        t.add_column(c.removeprefix(">"), justify="right" if c.startswith(">") else "left", overflow="fold")
    return t


class RunProgress:
    """A run's progress (issue #32: 70 s of ``--sil`` without a word): a rich bar on a terminal, else one plain
    line every ``every_s`` seconds of wall time on ``con`` (a log, ``make run``). ``update(t, info)`` each step."""

    every_s = 10.0

    def __init__(self, name: str, total_s: float, con: Console, clock=None, unit: str = "s"):
        self.name, self.total, self.con, self.unit = name, float(total_s), con, unit
        self.clock = clock or time.perf_counter
        self._bar = self._task = None
        self._t0 = self._next = 0.0
        self._shown = -1

    def __enter__(self) -> "RunProgress":
        self._t0 = self.clock()
        self._next = self._t0 + self.every_s
        if self.con.is_terminal:
            self._bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.fields[info]}"),
                                 TimeElapsedColumn(), TimeRemainingColumn(), console=self.con, transient=True)
            self._bar.__enter__()
            self._task = self._bar.add_task(self.name, total=self.total, info="")
        return self

    def update(self, t: float, info: str = "", total: float | None = None) -> None:
        """``t`` done of ``total`` (``unit``: simulated seconds, or replayed events; ``total`` may be given late)."""
        if total is not None:
            self.total = float(total)
        at = f"t={t:.1f} s of {self.total:g} s" if self.unit == "s" else f"{t:.0f} of {self.total:.0f} {self.unit}"
        if self._bar is not None:
            if int(t) != self._shown:  # once a simulated second (an event: the caller's pace)
                self._shown = int(t)
                self._bar.update(self._task, completed=t, total=self.total, info=f"{at} {info}")
            return
        now = self.clock()
        if now >= self._next:
            self._next = now + self.every_s
            pct = f" ({100.0 * t / self.total:.0f} %)" if self.total > 0 else ""
            self.con.print(f"{self.name}: {at}{pct}{', ' + info if info else ''}, {now - self._t0:.0f} s elapsed",
                           soft_wrap=True, highlight=False)

    def __exit__(self, *exc) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.3f}"
    return str(v)


@app.command(help="Run one closed-loop simulation and write its run directory (scenario.toml, log.h5, "
             "truth.tum, estimate.tum, metrics.json, report.html). Built-in scenarios: " + _builtin_names() + ".")
def run(
    scenario: str = typer.Argument("palace-landing", help="built-in scenario name or path to a .toml file "
                                   "(visnav scenarios lists them; visnav keys SCENARIO lists what --set takes)"),
    seed: Optional[int] = typer.Option(None, help="override run.seed"),
    out: Optional[str] = typer.Option(None, help="run directory (default runs/<scenario>-<time>); must be new or "
                                      "empty unless --force"),
    set_: List[str] = typer.Option([], "--set", help="override a key, e.g. --set sensors.imu.delay_s=0.043"),
    report: bool = typer.Option(True, help="write report.html"),
    map_: Optional[str] = typer.Option(None, "--map", help="geo-referenced image (PNG/JPEG + world file) as the "
                                       "world (and, for witas-homing, the degraded reference map)"),
    force: bool = typer.Option(False, "--force", help="write into a non-empty --out (the files of an earlier "
                               "run there are removed first)"),
    json_: bool = typer.Option(False, "--json", help="print a machine-readable summary (JSON) on stdout"),
    sil: bool = typer.Option(False, "--sil", help="software in the loop: the navigator runs in `visnav bridge` (a "
                             "subprocess) over MAVLink on 127.0.0.1, the simulation plays the autopilot (real time)"),
    sil_external: bool = typer.Option(False, "--sil-external", help="with --sil: do not start the bridge, print its "
                                      "command line and wait for it (start it in another terminal)"),
) -> None:
    """Run one closed-loop simulation and write its run directory."""
    from visnav.analysis.published import summary_rows
    from visnav.analysis.report import run_notes
    from visnav.app.runs import new_run_dir, write_run
    from visnav.scenarios.schema import ScenarioError, load_scenario
    from visnav.app.missions import make_simulation

    try:
        sc = load_scenario(scenario, set_, seed)
        if map_:  # the mission's own map if it has one (witas-homing fits its loop inside), else the world's
            key = {"witas-homing": "world.witas_map.file", "mav-geolocation": "world.geo_map.file"}.get(
                sc.mission.type, "world.map_file")
            sc = load_scenario(scenario, list(set_) + [f"{key}={json.dumps(str(Path(map_).resolve()))}"], seed)
        if sil or sil_external:
            from visnav.app.sil import sil_simulation

            sim = sil_simulation(sc)
        else:
            sim = make_simulation(sc)
        out_dir = new_run_dir(sc.run.name, out, force)
    except (ScenarioError, FileNotFoundError, ValueError) as exc:
        _fail(exc)
    except KeyboardInterrupt:
        err_console.print("interrupted before the run started: nothing written")
        raise typer.Exit(130)
    for note in getattr(sim, "notes", []):
        err_console.print(f"[yellow]note:[/yellow] {escape(note)}", soft_wrap=True)
    if sil and not sil_external:
        err_console.print(f"--sil: starting `visnav bridge` and waiting for it, then {sc.run.duration_s:g} s of real "
                          "time", soft_wrap=True)
    with RunProgress(sc.run.name, sc.run.duration_s, err_console) as prog:
        def progress(t, total):
            prog.update(t, f"mode {sim.mission.mode}")

        if sil or sil_external:  # the same scenario, its navigator in `visnav bridge` (app/sil.py)
            from visnav.app.sil import SilError, run_sil

            try:
                result = run_sil(sc, progress=progress, sim=sim, out_dir=Path(out_dir) / "bridge",
                                 spawn=not sil_external,
                                 notify=lambda m: err_console.print(escape(m), soft_wrap=True))
            except SilError as exc:
                _fail(exc)
        else:
            result = sim.run(progress=progress)
    try:
        write_run(result, out_dir, report=report)
    except OSError as exc:
        _fail(f"cannot write the run directory {out_dir}: {exc}")
    except KeyboardInterrupt:
        result.interrupted = True
    if result.interrupted:
        err_console.print(f"interrupted: what the run had is in {out_dir} (metrics.json: \"interrupted\": true)",
                          soft_wrap=True)
        raise typer.Exit(130)
    if json_:
        _print_json({"run_dir": str(out_dir), "scenario": sc.run.name, "seed": sc.run.seed,
                     "metrics": result.metrics, "error": result.error})
        raise typer.Exit(1 if result.error else 0)
    from visnav.analysis.outcome import verdict_line

    console.print(escape(verdict_line(result.metrics)), style="bold", soft_wrap=True)  # the verdict first (#30)
    rows, omitted, source = summary_rows(sc, result.metrics)
    table = _metrics_table(f"{sc.run.name} (seed {sc.run.seed})", [r.metric for r in rows], ">this run",
                           f"thesis: {source}", "verdict")
    for r in rows:
        table.add_row(r.metric, escape(r.ours), escape(r.thesis), r.verdict)
    console.print(table)
    if omitted:
        console.print(f"not applicable to this run: {', '.join(omitted)}")
    for line in run_notes(result):
        console.print(escape(line))
    console.print(f"run directory: {out_dir}")
    if result.error:
        err_console.print(f"[red]the run stopped early:[/red] {escape(result.error)} (what it had is saved)")
        raise typer.Exit(1)


@app.command()
def montecarlo(
    scenario: str = typer.Argument(..., help="built-in scenario name or path to a .toml file"),
    n: int = typer.Option(10, "-n", "--runs", help="number of seeds (1..N, or from --first-seed)"),
    first_seed: int = typer.Option(1, help="first seed"),
    workers: int = typer.Option(2, help="local worker processes"),
    scheduler: Optional[str] = typer.Option(None, help="Dask scheduler address (tcp://host:8786)"),
    set_: List[str] = typer.Option([], "--set", help="override a key for every run"),
    grid: List[str] = typer.Option([], "--grid", help="sweep a key: --grid mission.altitude_m=6,12,18"),
    out: Optional[str] = typer.Option(None, help="campaign directory (default runs/<scenario>-mc-<time>)"),
    new: bool = typer.Option(False, "--new", help="--out holds a campaign of another configuration: start a "
                             "fresh one beside it (<out>-2, ...) instead of refusing"),
    json_: bool = typer.Option(False, "--json", help="print the summary (JSON) on stdout"),
) -> None:
    """Run N seeds (times every grid point). Resumable: rerunning the same campaign with its --out skips
    finished runs; another configuration there is refused (or --new)."""

    from visnav.app.montecarlo import Campaign, CampaignError, parse_grid

    try:
        if n < 1:
            raise CampaignError(f"-n must be at least 1, got {n}")
        g = parse_grid(grid)
        out_dir = out or f"runs/{scenario.rsplit('/', 1)[-1].removesuffix('.toml')}-mc-{_time.strftime('%Y%m%d-%H%M%S')}"
        camp = Campaign(scenario, list(range(first_seed, first_seed + n)), out_dir, list(set_), g, workers, scheduler)
        done, todo = camp.prepare(new=new)
    except CampaignError as exc:
        _fail(exc)
    if camp.moved_from is not None:
        err_console.print(f"{camp.moved_from} holds another campaign: starting a new one in {camp.out}", soft_wrap=True)
    if done:
        err_console.print(f"{done} already done, {todo} to run", soft_wrap=True)
    try:
        with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.fields[info]}"),
                      TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(), console=err_console) as prog:
            task = prog.add_task(f"campaign {scenario}", total=todo or None, info="")

            def progress(i, total, row):
                prog.update(task, total=total, completed=i,
                            info=f"{i}/{total} seed {row['seed']} {row.get('status')}")

            summary = camp.run(progress)
    except CampaignError as exc:
        _fail(exc)
    except KeyboardInterrupt:
        from visnav.app.montecarlo import _read_csv

        err_console.print(f"interrupted: {len(_read_csv(camp.runs_csv))} finished runs are in {camp.runs_csv}; to "
                          f"resume, run the same command with --out {camp.out}", soft_wrap=True)
        raise typer.Exit(130)
    if json_:
        _print_json({"campaign_dir": str(camp.out), "summary": summary})
        raise typer.Exit(1 if summary["failed"] else 0)
    source = summary.get("published_source", "")
    table = _metrics_table(f"{scenario}: {summary['count']} runs, {summary['failed']} failed",
                           [*summary["metrics"], *summary.get("rates", {})],
                           *(f">{c}" for c in ("mean", "median", "p95", "min", "max", source or "thesis")))
    for k, v in summary["metrics"].items():
        table.add_row(k, *(f"{v[c]:.4g}" for c in ("mean", "median", "p95", "min", "max")), v.get("published", ""))
    for k, v in summary.get("rates", {}).items():
        table.add_row(k, f"rate {v['rate']:.0%}", f"{v['count']} of {v['n']}", "", "", "", v.get("published", ""))
    console.print(table)
    for k, v in summary["metrics"].items():
        if "in_band" in v:
            console.print(f"{k}: {v['in_band']} of {v['n']} runs inside {v['band'][0]:g}-{v['band'][1]:g}")
    from visnav.analysis.outcome import outcome_text

    if outcome_text(summary.get("outcomes", {})):
        console.print(outcome_text(summary["outcomes"]), style="bold")
    console.print(f"campaign directory: {camp.out}")
    if summary["failed"]:
        raise typer.Exit(1)


@app.command()
def faults(
    scenario: str = typer.Argument(..., help="built-in scenario name or path to a .toml file"),
    faults_: List[str] = typer.Option(["all"], "--faults", help="'all' (every fault that applies) or fault names"),
    n: int = typer.Option(10, "-n", "--runs", help="seeds per fault (1..N, or from --first-seed)"),
    first_seed: int = typer.Option(1, help="first seed"),
    workers: int = typer.Option(2, help="local worker processes"),
    set_: List[str] = typer.Option([], "--set", help="override a key for every run"),
    out: Optional[str] = typer.Option(None, help="campaign directory (default runs/<scenario>-faults-<time>)"),
    new: bool = typer.Option(False, "--new", help="a sub-campaign directory holds another configuration: start "
                             "fresh ones beside it instead of refusing"),
) -> None:
    """Fault campaign (issue #18): the fault-free case and every fault that applies to the scenario on N seeds,
    one Monte Carlo campaign each in DIR/<fault>/ (resumable); writes DIR/faults.csv and DIR/faults.md."""

    from visnav.app.fault_campaign import FAULT_COLUMNS, campaigns, fault_row, faults_for, write_tables
    from visnav.app.montecarlo import CampaignError, _read_csv

    names = [x for f in faults_ for x in f.split(",") if x.strip()]
    try:
        if n < 1:
            raise CampaignError(f"-n must be at least 1, got {n}")
        chosen = faults_for(scenario, list(set_), names)
    except ValueError as exc:  # ScenarioError and CampaignError are ValueErrors
        _fail(exc)
    out_dir = Path(out or f"runs/{scenario.rsplit('/', 1)[-1].removesuffix('.toml')}-faults-"
                          f"{_time.strftime('%Y%m%d-%H%M%S')}")
    table, per_fault = [], {}
    try:
        for name, camp in campaigns(scenario, n, out_dir, chosen, list(set_), workers, first_seed):
            try:
                done, todo = camp.prepare(new=new)
            except CampaignError as exc:
                _fail(exc)
            err_console.print(f"{name}: {done} done, {todo} to run", soft_wrap=True)
            camp.run()
            rows = _read_csv(camp.runs_csv)
            per_fault[name] = rows
            table.append(fault_row(name, rows))
    except KeyboardInterrupt:
        err_console.print(f"interrupted: finished runs are kept in {out_dir}/<fault>/runs.csv; to resume, run the "
                          f"same command with --out {out_dir}", soft_wrap=True)
        raise typer.Exit(130)
    write_tables(out_dir, table, per_fault, scenario, n)
    t = Table(title=f"{scenario}: faults on {n} seeds")
    for col in FAULT_COLUMNS:  # a narrow console folds a column name, it never cuts it (issue #32 item 7)
        t.add_column(col, justify="left" if col == "fault" else "right", overflow="fold")
    for r in table:
        t.add_row(*(("–" if math.isnan(r[c]) else f"{r[c]:.3g}") if isinstance(r[c], float) else str(r[c])
                    for c in FAULT_COLUMNS))
    console.print(t)
    console.print(f"fault campaign: {out_dir / 'faults.csv'}, {out_dir / 'faults.md'}")


@app.command()
def margins(
    scenario: str = typer.Argument("palace-sweep", help="a hover scenario (mission.type = hover)"),
    altitudes: str = typer.Option("6,12,18,30,54", help="heights AGL \\[m], comma separated"),
    delays: str = typer.Option("0,0.1", help="simulated IMU delays \\[s], comma separated"),
    compensate: bool = typer.Option(False, help="also fly each delay compensated by the identified delays"),
    laser_delay: float = typer.Option(0.0, help="simulated laser delay \\[s] for every sweep"),
    identify_altitude: float = typer.Option(12.0, help="height \\[m] of the identification sweeps (on GPS)"),
    seed: int = typer.Option(1),
    seeds: int = typer.Option(1, help="seeds per sweep, merged (weighted by coherence)"),
    ident_seeds: Optional[int] = typer.Option(None, help="seeds of the identification sweeps (default max(seeds, 4))"),
    min_delay_confidence: float = typer.Option(0.9, help="below it (P(|error| < 5 ms)) a delay is not compensated"),
    workers: int = typer.Option(2),
    set_: List[str] = typer.Option([], "--set", help="override a key for every run"),
    out: Optional[str] = typer.Option(None, help="output directory (default runs/margins-<time>)"),
    force: bool = typer.Option(False, "--force", help="write into a non-empty --out (replaces margins.csv, frf.npz)"),
) -> None:
    """Stability margins at the cyclic actuators from closed-loop chirps (seed 000 Tables 5.1/5.2)."""

    from visnav.app.margins_campaign import check_margins_scenario, margins_campaign
    from visnav.app.runs import prepare_out_dir

    def numbers(text: str, option: str) -> list[float]:
        try:
            return [float(a) for a in text.split(",") if a.strip()]
        except ValueError:
            raise ValueError(f"{option} takes comma-separated numbers, got '{text}'") from None

    try:
        alts, dels = numbers(altitudes, "--altitudes"), numbers(delays, "--delays")
        if not alts or not dels:
            raise ValueError("--altitudes and --delays need at least one value each")
        if not 0 <= min_delay_confidence <= 1 or (ident_seeds is not None and ident_seeds < 1):
            raise ValueError("--min-delay-confidence takes a value in [0, 1] and --ident-seeds a count >= 1")
        check_margins_scenario(scenario, list(set_))
        out_dir = prepare_out_dir(out or f"runs/margins-{_time.strftime('%Y%m%d-%H%M%S')}", force=force,
                                  clear=("margins.csv", "frf.npz"), kind="a margins folder")
    except ValueError as exc:  # ScenarioError and OutputDirError are ValueErrors
        _fail(exc)
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TimeElapsedColumn(), TimeRemainingColumn(),
                  console=err_console) as prog:
        task = prog.add_task("sweeps", total=None)
        frfs: dict = {}
        rows = margins_campaign(alts, dels, compensate=compensate, seed=seed, scenario=scenario, frf_sink=frfs,
                                overrides=tuple(set_), workers=workers, laser_delay_s=laser_delay,
                                identify_altitude_m=identify_altitude, seeds=seeds, ident_seeds=ident_seeds,
                                min_delay_confidence=min_delay_confidence,
                                progress=lambda *a, **k: prog.advance(task))
    cols = ["altitude_m", "delay_s", "compensated", "lateral_pm_deg", "lateral_pm_wc_rps", "lateral_gm_db",
            "longitudinal_pm_deg", "longitudinal_pm_wc_rps", "longitudinal_gm_db", "identified_imu_delay_s"]
    extra = [k for r in rows for k in r if k not in cols]
    cols += list(dict.fromkeys(extra))
    with (out_dir / "margins.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols})
    from visnav.analysis.palace_report import save_frfs

    save_frfs(out_dir / "frf.npz", frfs)
    table = Table(title="margins at the cyclic actuators")
    for c in cols[:10]:
        table.add_column(c.replace("_", " "), justify="right")
    for r in rows:
        table.add_row(*(_fmt(r.get(c)) if r.get(c) is not None else "" for c in cols[:10]))
    console.print(table)
    console.print(f"written: {out_dir / 'margins.csv'}")


@app.command("palace-report")
def palace_report(
    drift: List[str] = typer.Option([], "--drift", help="palace-hover-drift campaign directory (repeatable)"),
    margins: Optional[str] = typer.Option(None, "--margins", help="visnav margins output directory or margins.csv"),
    out: str = typer.Option("runs/palace-report.html", help="HTML file to write"),
) -> None:
    """PALACE report page: drift vs altitude per surface, MPE noise vs range, Tables 5.1/5.2, Bode plots."""
    from visnav.analysis.palace_report import write_palace_report

    try:
        path = write_palace_report(out, drift, margins)
    except (ValueError, OSError, KeyError) as exc:
        _fail(exc)
    console.print(f"written: {path}")


@app.command(help="Recompute a run's metrics from its log.h5 and scenario.toml (the code that scores a "
             "simulated, replayed or recorded run) and print them.")
def metrics(
    run_dir: str = typer.Argument(..., help="a run directory (visnav run --out DIR)"),
    json_: bool = typer.Option(False, "--json", help="print the metrics as JSON"),
    out: Optional[str] = typer.Option(None, "--out", help="also write them as JSON to this file"),
) -> None:
    """Recompute a run's metrics from its log."""
    from visnav.analysis.run_metrics import RunDirError, from_run_dir
    from visnav.io.json_values import jsonable

    try:
        m = from_run_dir(run_dir)
    except (RunDirError, ValueError) as exc:
        _fail(exc)
    if out:
        try:
            Path(out).write_text(json.dumps(jsonable(m), indent=2) + "\n")
        except OSError as exc:
            _fail(f"cannot write {out}: {exc}")
    if json_:
        _print_json(m)
        return
    from visnav.analysis.outcome import verdict_line

    console.print(escape(verdict_line(m)), style="bold", soft_wrap=True)
    table = _metrics_table(f"metrics from {run_dir}/log.h5", m, ">value")
    for k, v in m.items():
        table.add_row(k, escape(_fmt(v)))
    console.print(table)


@app.command()
def scenarios() -> None:
    """List the built-in scenarios."""
    from visnav.scenarios.schema import builtin_names, load_scenario

    table = Table(title="built-in scenarios")
    table.add_column("name")
    table.add_column("description")
    for name in builtin_names():
        table.add_row(name, load_scenario(name).run.description)
    console.print(table)


@app.command()
def keys(
    scenario: str = typer.Argument(..., help="built-in scenario name or path to a .toml file"),
    json_: bool = typer.Option(False, "--json", help="print the keys as JSON on stdout"),
) -> None:
    """Every key --set takes for a scenario: its value there, unit, allowed range and description."""
    from visnav.scenarios.keys import settable_keys
    from visnav.scenarios.schema import ScenarioError, load_scenario

    try:
        rows = settable_keys(load_scenario(scenario))
    except ScenarioError as exc:
        _fail(exc)
    if json_:
        _print_json(rows)
        return
    table = Table(title=f"settable keys of {scenario} (--set key=value)")
    table.add_column("key", no_wrap=True)
    table.add_column("value", overflow="fold", ratio=1)
    table.add_column("unit", no_wrap=True)
    table.add_column("allowed", ratio=1)
    table.add_column("description", ratio=2)
    for r in rows:
        table.add_row(r["key"], escape(json.dumps(r["value"])), r["unit"], escape(r["allowed"]), escape(r["description"]))
    console.print(table)


@app.command()
def ahrs(
    log: str = typer.Argument(..., help="PX4 ULog (.ulg), or a recording / EuRoC folder / log with a reference attitude"),
    out: Optional[str] = typer.Option(None, "--out", help="output directory (default: runs/ahrs-<log name>)"),
    declination_deg: Optional[float] = typer.Option(
        None, "--declination-deg", help="magnetic declination \\[deg]; default: the log's EKF2_MAG_DECL, else 0"),
) -> None:
    """Our INS attitude filter (AHRS mode) on a PX4 log's raw IMU vs PX4's vehicle_attitude."""
    from visnav.analysis.ahrs_check import ahrs_check

    from visnav.app.runs import prepare_out_dir

    out_dir = Path(out) if out else Path("runs") / f"ahrs-{Path(log).stem}"
    try:
        prepare_out_dir(out_dir, force=True, clear=(), kind=None)  # writable? (ahrs overwrites its own two files)
        m = ahrs_check(log, out_dir, declination_deg)
    except (OSError, ValueError) as exc:
        _fail(exc)
    for note in m["log_notes"]:
        err_console.print(f"[yellow]log:[/yellow] {escape(note)}", soft_wrap=True)
    table = Table(title=f"AHRS vs {m['reference']} ({Path(log).name})")
    table.add_column("metric")
    table.add_column("value", justify="right")
    if m.get("log_truncated"):
        table.add_row("log file", f"TRUNCATED: {m['duration_s']:.1f} s read")
    table.add_row("magnetometer", m.get("magnetometer_source") or "NOT FOUND (yaw gyro-only)")
    for k in ("roll_rms_diff_deg", "pitch_rms_diff_deg", "yaw_rms_diff_deg", "gyro_only_yaw_rms_diff_deg",
              "declination_deg", "imu_samples", "imu_rate_hz", "ahrs_wall_s"):
        table.add_row(k, "null (not observable)" if m[k] is None else _fmt(m[k]))
    for k in ("roll_mean_diff_deg", "roll_std_diff_deg", "pitch_mean_diff_deg", "pitch_std_diff_deg",
              "reference_to_gyro_rotation_deg", "roll_rms_diff_deg_gyro_axes", "pitch_rms_diff_deg_gyro_axes",
              "accel_minus_reference_gravity_mps2"):
        if k in m:
            table.add_row(k, _fmt(m[k]) if not isinstance(m[k], list) else str([round(x, 3) for x in m[k]]))
    if m.get("yaw_unobservable_reason"):
        table.add_row("yaw", escape(m["yaw_unobservable_reason"]))
    console.print(table)
    console.print(f"written: {out_dir / 'metrics.json'}, {out_dir / 'ahrs.png'}")


@app.command("eval")
def eval_(
    reference: str = typer.Argument(..., help="reference trajectory: TUM, CSV (t_s,x_m,y_m,z_m[,qx,qy,qz,qw]) or a "
                                    "run directory (its truth.tum)"),
    estimate: Optional[str] = typer.Argument(None, help="estimate: TUM, CSV or run directory (its estimate.tum); "
                                             "default: the reference run directory's estimate.tum"),
    align: str = typer.Option("none", help="alignment before the errors: none, se3 or sim3 (Umeyama)"),
    max_diff: float = typer.Option(0.01, help="largest time difference of associated poses \\[s]"),
    offset: float = typer.Option(0.0, help="added to the estimate's time stamps before association \\[s]"),
    rpe_delta: float = typer.Option(1.0, help="RPE pair distance, in --rpe-unit"),
    rpe_unit: str = typer.Option("frames", help="RPE pair distance unit: frames or m (of reference path)"),
    drift: List[float] = typer.Option([], help="segment length for drift in % of distance \\[m] (repeatable)"),
    origin: Optional[str] = typer.Option(None, help="geodetic origin of the NED frame 'lat_deg,lon_deg[,h_m]': "
                                         "adds GeoJSON and KML exports"),
    out: Optional[str] = typer.Option(None, help="write eval.json, the aligned estimate (TUM, CSV), eval.png and "
                                      "exports here"),
    json_: bool = typer.Option(False, "--json", help="print the summary as JSON on stdout"),
) -> None:
    """Absolute trajectory error and relative pose error of an estimate against a reference (evo's definitions)."""

    from visnav.analysis.trajectory_eval import TrajectoryError, evaluate, read_trajectory

    try:
        ref_path = Path(reference)
        if estimate is None and not ref_path.is_dir():
            raise TrajectoryError(f"{reference}: give an ESTIMATE, or a run directory as REFERENCE")
        ref = read_trajectory(ref_path, which="truth")
        est = read_trajectory(Path(estimate) if estimate else ref_path, which="estimate")
        lt = None
        if origin:
            from visnav.geometry.frames import LocalTangentPlane

            try:
                vals = [float(v) for v in origin.split(",")]
                lt = LocalTangentPlane(*vals[:3])
            except (ValueError, TypeError) as exc:
                raise TrajectoryError(f"--origin must be 'lat_deg,lon_deg[,h_m]': {exc}") from None
        ev = evaluate(ref, est, alignment=align, max_diff=max_diff, offset_s=offset, rpe_delta=rpe_delta,
                      rpe_unit=rpe_unit, drift_lengths_m=drift)
        files = []
        if out:
            from visnav.analysis.trajectory_export import write_evaluation

            try:
                files = write_evaluation(ev, out, lt)
            except OSError as exc:
                raise TrajectoryError(f"cannot write to {out}: {exc.strerror or exc}") from None
    except TrajectoryError as exc:
        _fail(exc)
    s = ev.summary()
    if json_:
        print(json.dumps(s, indent=2))
        return
    table = _metrics_table(f"{est.name} vs {ref.name} (alignment {align}, {ev.matched} poses matched)", s, ">value")
    for k, v in s.items():
        table.add_row(k, _fmt(v))
    console.print(table)
    if ref.frame:
        console.print(f"frame: {escape(ref.frame)}")
    for f in files:
        console.print(f"written: {f}")


# ---------------------------------------------------------------------------------------------- bridge (#17)
def _bridge_origin(text: Optional[str]):
    from visnav.geometry.frames import LocalTangentPlane

    if text is None:
        return None
    try:
        lat, lon, alt = (float(x) for x in text.split(","))
        return LocalTangentPlane(lat, lon, alt)
    except ValueError as exc:
        raise ValueError(f"--origin must be LAT_DEG,LON_DEG,ALT_M (AMSL), got {text!r} ({exc})") from None


def _input_timeouts(items: list[str]):
    from visnav.io.bridge_freshness import FreshnessConfig

    cfg = FreshnessConfig()
    for it in items:
        k, _, v = it.partition("=")
        try:
            val = None if v.strip().lower() == "none" else float(v)
            if val is not None and not 0.0 < val < 1e6:
                raise ValueError
            cfg = cfg.with_overrides(**{k.strip(): {"timeout_s": val}})
        except ValueError as exc:
            why = str(exc) if "unknown bridge input stream" in str(exc) else "seconds must be a positive number or none"
            raise ValueError(f"--input-timeout {it!r}: {why}") from None
    return cfg


@app.command()
def bridge(
    mavlink_url: str = typer.Option(..., "--mavlink", help="udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT or a "
                                    "serial device (/dev/ttyACM0, /dev/ttyUSB0:921600)"),
    camera: str = typer.Option(..., help="cv2.VideoCapture source (device index, file, RTSP/GStreamer URL) or a "
                               "folder of images"),
    navigator: str = typer.Option("witas", help="witas, palace, or a scenario name / .toml whose navigator to run"),
    map_: Optional[str] = typer.Option(None, "--map", help="geo-referenced reference map (as visnav run --map)"),
    output: str = typer.Option("odometry", help="odometry | vision | gps-input"),
    frame: str = typer.Option("frd", help="ODOMETRY frame_id: frd (MAV_FRAME_LOCAL_FRD, PX4 and ArduPilot) or ned "
                              "(MAV_FRAME_LOCAL_NED, PX4)"),
    camera_yaml: Optional[str] = typer.Option(None, "--camera-yaml", help="camera.yaml (recorded-flight format): "
                                              "its time_offset_s stamps the frames"),
    origin: Optional[str] = typer.Option(None, help="NED origin LAT_DEG,LON_DEG,ALT_M; default: the autopilot's "
                                         "GPS_GLOBAL_ORIGIN, else its first position fix"),
    baud: int = typer.Option(57600, help="serial baud rate"),
    fps: Optional[float] = typer.Option(None, help="pace of a frame folder (default: the navigator's camera rate)"),
    duration: Optional[float] = typer.Option(None, help="stop after this many seconds (default: Ctrl-C)"),
    out: Optional[str] = typer.Option(None, help="log folder (default runs/bridge-<time>): bridge.tlog, metrics.json"),
    set_: List[str] = typer.Option([], "--set", help="override a scenario key of the navigator's scenario"),
    log_frames: bool = typer.Option(False, help="also keep every frame (lossless PNG + frames.csv) in the log folder"),
    record: bool = typer.Option(True, help="write the log as a recording (OUT/recording: every sample, frame, "
                                "mission request and estimate the navigator got; `visnav replay OUT --navigator "
                                "NAME` reruns it)"),
    health: bool = typer.Option(False, "--health", help="also send the navigator's health (DEBUG_FLOAT_ARRAY "
                                "VN_HEALTH, docs/autopilots.md) with every estimate: for a mission on the "
                                "autopilot side (the SIL)"),
    gps_sigma: float = typer.Option(2.5, "--gps-sigma", help="1-sigma \\[m] the navigator gives a position fix whose "
                                    "message carries no accuracy (GLOBAL_POSITION_INT; GPS_RAW_INT without h_acc)"),
    input_timeout: List[str] = typer.Option([], "--input-timeout", help="STREAM=SECONDS (imu, gps, height, "
                                            "camera; 'none': never): no estimate is sent while that input is older "
                                            "(defaults imu=1 camera=10, docs/autopilots.md)"),
) -> None:
    """Run a visnav navigator live: autopilot MAVLink + camera in, ODOMETRY / VISION_* / GPS_INPUT out."""

    from rich.live import Live

    from visnav.app.bridge import OUTPUTS, Bridge, BridgeConfig, BridgeRecording, status_line
    from visnav.app.bridge_navigators import build_navigator
    from visnav.io.camera_source import CameraSourceError, open_source, read_time_offset
    from visnav.io.mavlink_link import MavlinkLink, MavlinkLinkError
    from visnav.io.mavlink_messages import mavlink
    from visnav.app.navigators import NAVIGATORS
    from visnav.scenarios.schema import ScenarioError
    from visnav.flightlog import FlightLog

    fail = _fail
    navlog = FlightLog()  # what the navigator records (its own streams), in the bridge's monotonic clock

    if output not in OUTPUTS:
        fail(f"--output must be one of {', '.join(OUTPUTS)}, got {output!r}")
    if frame not in ("frd", "ned"):
        fail(f"--frame must be frd or ned, got {frame!r}")
    if not 0.0 < gps_sigma < 1000.0:
        fail(f"--gps-sigma must be a positive number of metres, got {gps_sigma:g}")
    out_dir = Path(out or f"runs/bridge-{time.strftime('%Y%m%d-%H%M%S')}")
    out_existed = out_dir.exists()
    logf = None

    def say(m: str) -> None:  # console, and bridge.log once the session is open
        console.print(escape(m), soft_wrap=True)
        if logf is not None:
            logf.write(f"{time.strftime('%H:%M:%S')} {m}\n")
            logf.flush()

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / ".write-test").touch()
        (out_dir / ".write-test").unlink()
    except OSError as exc:
        fail(f"log folder {out_dir} is not writable ({exc.strerror})")
    link = src = None
    try:
        cfg = BridgeConfig(output=output, origin=_bridge_origin(origin), freshness=_input_timeouts(input_timeout), frame_log=out_dir / "frames" if log_frames else None,
                           send_health=health, gps_sigma_m=gps_sigma, frame_id=mavlink.MAV_FRAME_LOCAL_FRD if frame == "frd" else mavlink.MAV_FRAME_LOCAL_NED)
        offset = read_time_offset(camera_yaml)
        link = MavlinkLink(mavlink_url, baud=baud, tlog=out_dir / "bridge.tlog", notify=say)
        built = build_navigator(navigator, map_, set_, recorder=navlog.record)
        src = open_source(camera, fps=fps or built.camera_hz, time_offset_s=offset)
    except (MavlinkLinkError, CameraSourceError, ScenarioError, FileNotFoundError, ValueError) as exc:
        if link is not None:
            link.close()
            tlog = out_dir / "bridge.tlog"
            if tlog.is_file() and tlog.stat().st_size == 0:
                tlog.unlink()  # a session that did not start leaves no empty tlog behind
        if not out_existed and out_dir.is_dir() and not any(out_dir.iterdir()):
            out_dir.rmdir()  # nothing left behind by a session that did not start
        fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    logf = open(out_dir / "bridge.log", "a")
    console.print(f"bridge: {built.scenario} navigator, {mavlink_url} -> {output}, camera {camera} "
                  f"({fps or built.camera_hz:g} Hz); log {out_dir}")
    rec = None
    nav = built.navigator
    if record:
        try:
            rec = BridgeRecording(nav, out_dir / "recording", built.sc, *NAVIGATORS[built.name].camera(built.sc))
        except (OSError, ValueError) as exc:
            fail(f"cannot write the recording in {out_dir / 'recording'}: {exc}")
        nav = rec.navigator
    with Live(console=console, transient=False, auto_refresh=False) as live:
        br = Bridge(link, src, nav, cfg, record=navlog.record, notify=say,
                    on_status=lambda s: live.update(status_line(s), refresh=True))
        try:
            metrics = br.run(duration_s=duration)
        except KeyboardInterrupt:
            br.stop.set()
            metrics = br.metrics()
        finally:
            link.close()
            src.close()
    if not console.is_terminal:
        console.line()  # Live leaves its last status line open off a terminal: the summary goes on its own line
    try:
        if rec is not None:
            rec.close()
        navlog.to_hdf5(out_dir / "navigator.h5", attrs={"clock": "the bridge's monotonic clock [s]"})
    except KeyboardInterrupt:
        pass
    br.write_metrics(out_dir / "metrics.json")
    lat = metrics["latency_capture_to_send_ms"]
    say(f"sent {metrics.get('estimates_out', 0)} estimates; capture-to-send latency median "
                  f"{lat['median']:.1f} ms, p95 {lat['p95']:.1f} ms; reset_counter {metrics['reset_counter']}; "
                  f"written {out_dir / 'metrics.json'}, {out_dir / 'bridge.tlog'}"
                  + (f", {out_dir / 'recording'} (visnav replay {out_dir / 'recording'} --navigator {built.name})"
                     if rec is not None else ""))
    logf.close()


@app.command("sil-autopilot")
def sil_autopilot(
    mavlink_url: str = typer.Option("udpout:127.0.0.1:14540", "--mavlink", help="where the bridge listens "
                                    "(loopback only)"),
    duration: float = typer.Option(30.0, help="seconds to run"),
    gps_until: Optional[float] = typer.Option(None, help="stop sending GPS after this many seconds"),
) -> None:
    """A PX4 stand-in on 127.0.0.1 for trying `visnav bridge` on a desk (a circling vehicle's MAVLink)."""

    import numpy as np

    from visnav.io.mavlink_sil import SilAutopilot

    host = mavlink_url.split(":")[1] if ":" in mavlink_url else ""
    if host not in ("127.0.0.1", "localhost"):
        _fail(f"the SIL stand-in talks to 127.0.0.1 / localhost only, got {mavlink_url!r}")
    sil = SilAutopilot(mavlink_url, gps_until_s=gps_until)
    sil.start(duration)
    try:
        time.sleep(duration)
    except KeyboardInterrupt:
        pass
    finally:
        sil.stop()
    e = np.array(sil.stats.ext_errors_m) if sil.stats.ext_errors_m else np.array([np.nan])
    console.print(f"received {sil.stats.received}; external position error at its time_usec: median "
                  f"{np.median(e):.3f} m, p95 {np.percentile(e, 95):.3f} m")
# ---- seed 002 ch. 7: registrability map (geoloc) -------------------------------------------------
@app.command("map-quality")
def map_quality(
    map_file: str = typer.Argument(..., help="geo-referenced image (PNG/JPEG + world file, or GeoTIFF)"),
    altitude: float = typer.Option(70.0, "--altitude", help="flight height above ground \\[m]"),
    out: str = typer.Option("runs/map-quality", "--out", help="output directory"),
    cell_m: float = typer.Option(10.0, "--cell-m", help="cell size \\[m]"),
    hfov_deg: float = typer.Option(53.0, "--hfov-deg", help="camera field of view across the frame \\[deg]"),
    validate_n: int = typer.Option(0, "--validate", help="also register N rendered frames and compare failures"),
    same_day: bool = typer.Option(False, "--same-day", help="frames drawn from the map itself (default: another "
                                  "day: the relief's texture changes and moves, world/appearance.py)"),
) -> None:
    """Registrability of a map: per cell, how reliably a nadir frame taken there registers (PNG + world file + .npy)."""

    import numpy as np

    from visnav.analysis.registrability import registrability_map, validate, write_registrability
    from visnav.world.maps import GeoImage

    try:
        if not (altitude > 0 and cell_m > 0 and 0 < hfov_deg < 180 and validate_n >= 0):
            raise ValueError(f"--altitude, --cell-m must be > 0, --hfov-deg in (0, 180), --validate >= 0 "
                             f"(got {altitude}, {cell_m}, {hfov_deg}, {validate_n})")
        geo = GeoImage.load(map_file)
        day = {"unstable_m": 0.0} if same_day else {}
        reg = registrability_map(geo, altitude, hfov_deg=hfov_deg, cell_m=cell_m, **day)
        paths = write_registrability(reg, geo, Path(out))
    except (FileNotFoundError, ValueError, OSError) as exc:
        _fail(exc)
    s = reg.score
    console.print(f"{geo.name}: {s.shape[0]} x {s.shape[1]} cells of {reg.cell_m:.1f} m, score median "
                  f"{float(np.median(s)):.3f}, 10th-90th percentile {float(np.percentile(s, 10)):.3f}-"
                  f"{float(np.percentile(s, 90)):.3f}")
    if validate_n:
        v = validate(reg, geo, n=validate_n, **day)
        console.print(f"validation ({validate_n} frames): failure rate {v['fail_rate_low']:.2f} where the score "
                      f"is at most its median ({v['score_median']:.3f}), {v['fail_rate_high']:.2f} above")
    console.print("written: " + ", ".join(str(p) for p in paths.values()))


# ------------------------------------------------------------------ record / replay (issue #14)
@app.command("record")
def record_(
    scenario: str = typer.Argument(..., help="built-in scenario name or .toml (palace-landing, witas-homing, "
                                   "pad-landing, deck-moving, deck-static, condor-orbit, ...)"),
    out: str = typer.Option(..., help="recording folder to write (docs/recordings.md)"),
    seed: Optional[int] = typer.Option(None, help="override run.seed"),
    set_: List[str] = typer.Option([], "--set", help="override a key, e.g. --set run.duration_s=20"),
    force: bool = typer.Option(False, "--force", help="write into a non-empty --out (the recording's own files "
                               "there are removed first)"),
) -> None:
    """Fly a scenario's closed loop and write what its navigator saw as a recorded flight."""
    from visnav.io.recording import RecordingError
    from visnav.scenarios.schema import ScenarioError, load_scenario
    from visnav.app.record import record

    err = Console(stderr=True)
    try:
        sc = load_scenario(scenario, set_, seed)
        with RunProgress(f"recording {sc.run.name}", sc.run.duration_s, err) as prog:
            res = record(sc, out, force=force, progress=lambda t, total: prog.update(t))
    except (ScenarioError, RecordingError, FileNotFoundError, ValueError) as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}", soft_wrap=True)
        raise typer.Exit(2)
    console.print(f"recorded {escape(sc.run.name)}: " + ", ".join(f"{v} {k}" for k, v in res.counts.items() if v))
    console.print(f"recording: {res.out_dir}")
    if getattr(res.run, "interrupted", False):
        err.print(f"interrupted: the recording holds the flight up to the interruption ({res.out_dir})")
        raise typer.Exit(130)
    if res.run.error:
        console.print(f"[red]the flight stopped early:[/red] {escape(res.run.error)} (what it had is recorded)")
        raise typer.Exit(1)


@app.command("replay")
def replay_(
    recording: str = typer.Argument(..., help="recording folder (docs/recordings.md), a visnav bridge log folder, an "
                                    "EuRoC folder, a folder of geotagged photos, PX4 .ulg, ArduPilot DataFlash .bin, "
                                    "MAVLink .tlog, or ROS bag (.bag / ROS 2 folder)"),
    navigator: str = typer.Option(..., help="navigator: palace, witas, pad, deck, condor, geolocation or vo "
                                  "(app/navigators.py)"),
    map_: Optional[str] = typer.Option(None, "--map", help="reference map (PNG/JPEG + world file) for witas and geolocation"),
    out: Optional[str] = typer.Option(None, help="run directory (default runs/replay-<navigator>-<time>)"),
    time_offset: Optional[str] = typer.Option(None, help="camera clock offset: 'auto' (gyro/camera "
                                              "cross-correlation) or seconds (t_imu = t_camera + offset); "
                                              "default camera.yaml's"),
    rate: float = typer.Option(10.0, help="estimate rate when the recording has no recorded queries \\[Hz]"),
    gps_until: Optional[float] = typer.Option(None, help="withhold GPS after this time \\[s] (a GPS-denied run on a "
                                              "real flight; the fixes stay the reference when there is no truth.csv)"),
    force: bool = typer.Option(False, "--force", help="write into a non-empty --out (the files of an earlier run "
                               "there are removed first)"),
    no_check: bool = typer.Option(False, "--no-check", help="skip `visnav check` (replay even with problems)"),
    allow_truncated: bool = typer.Option(False, "--allow-truncated", help="a recording CSV cut while written (a "
                                         "short last row): replay the rows before it"),
    frames: Optional[str] = typer.Option(None, "--frames", help="frame folder or video on its own clock (needs "
                                         "--time-offset auto or seconds: t_imu = t_frame + offset)"),
    fps: Optional[float] = typer.Option(None, "--fps", help="frame rate of --frames when the names are not stamps"),
    camera_yaml: Optional[str] = typer.Option(None, "--camera-yaml", help="camera.yaml for --frames"),
) -> None:
    """Run a navigator on a recorded flight and write a run directory (log.h5, estimate.tum, metrics.json)."""
    from visnav.io.logs import open_recording
    from visnav.io.recording import RecordingError
    from visnav.app.replay import ReplayOptions, replay, write_replay
    from visnav.app.runs import new_run_dir
    from visnav.scenarios.schema import ScenarioError

    err = Console(stderr=True)
    out_dir = None
    try:  # the output first (issue #32: --out FILE failed only after the replay's work)
        out_dir = new_run_dir(f"replay-{navigator}", out, force)
    except ValueError as exc:
        err.print(f"[red]error:[/red] {escape(str(exc))}", soft_wrap=True)
        raise typer.Exit(2)
    try:
        offset = None
        if time_offset is not None and time_offset != "auto":
            try:
                offset = float(time_offset)
            except ValueError:
                raise RecordingError(f"--time-offset must be 'auto' or seconds, got {time_offset!r}") from None
        if not (rate > 0):
            raise RecordingError(f"--rate must be > 0 Hz, got {rate}")
        rec = open_recording(recording, allow_truncated)
        if rec.summary:  # a log: what was read, to the end or to the damage
            err.print(f"log: {escape(rec.summary)}", soft_wrap=True)
        if frames:
            from visnav.io.own_frames import attach_frames

            if time_offset is None:
                raise RecordingError("--frames on their own clock need --time-offset auto or seconds")
            attach_frames(rec, frames, fps, camera_yaml)
        if not no_check:  # issue 29: a recording whose conventions or calibration are wrong is refused
            from visnav.analysis.check import run_check

            with console.status(f"checking {escape(recording)}"):
                problems = run_check(rec, max_frames=60).summary["problems"]
            if problems:
                raise RecordingError(f"{recording}: `visnav check` found {len(problems)} problem(s) "
                                     "(replay anyway with --no-check):\n  " + "\n  ".join(problems))
        opts = ReplayOptions(map_path=map_, output_rate_hz=rate, gps_until_s=gps_until,
                             time_offset="auto" if time_offset == "auto" else offset)
        with RunProgress(f"replay on {navigator}", 1.0, err_console, unit="events") as prog:
            res = replay(rec, navigator, opts, progress=lambda k, n: prog.update(k, "", total=n))
        write_replay(res, out_dir, title=f"replay of {recording} on {navigator}")
    except (RecordingError, ScenarioError, ValueError) as exc:
        if not any(out_dir.iterdir()):
            out_dir.rmdir()  # made for this replay: not left behind empty
        err.print(f"[red]error:[/red] {escape(str(exc))}", soft_wrap=True)
        raise typer.Exit(2)
    except OSError as exc:
        err.print(f"[red]error:[/red] cannot write {escape(str(out))}: {escape(exc.strerror or str(exc))}")
        raise typer.Exit(2)
    console.print(escape(res.verdict), style="bold", soft_wrap=True)  # the verdict first, as a run's (#32)
    table = _metrics_table(f"replay of {escape(recording)} on {navigator}", res.metrics, ">value")
    for k, v in res.metrics.items():
        table.add_row(k, _fmt(v))
    console.print(table)
    for n in res.notes:
        console.print(f"[yellow]note:[/yellow] {escape(n)}")
    console.print(f"run directory: {out_dir}")
    if res.metrics.get("interrupted"):
        raise typer.Exit(130)
    if "error" in res.metrics:
        raise typer.Exit(1)


# ------------------------------------------------------------------ check (issue 29)
@app.command("check")
def check_(
    recording: str = typer.Argument(..., help="recording folder, EuRoC folder, .ulg, .bin, .tlog or ROS bag"),
    json_: bool = typer.Option(False, "--json", help="print check.json on stdout"),
    out: Optional[str] = typer.Option(None, "--out", help="write check.json and check.html here "
                                      "(default runs/check-<name>)"),
    max_frames: Optional[int] = typer.Option(None, help="use at most this many frames (the most rotating stretch)"),
    frames: Optional[str] = typer.Option(None, "--frames", help="frame folder or video on its own clock "
                                         "(replaces the recording's frames; the offset is searched over every lag)"),
    fps: Optional[float] = typer.Option(None, "--fps", help="frame rate of --frames when the names are not stamps"),
    camera_yaml: Optional[str] = typer.Option(None, "--camera-yaml", help="camera.yaml for --frames"),
) -> None:
    """Verify a recording's conventions and calibration from the flight itself (docs/check.md)."""
    from visnav.analysis.check import run_check, write_check
    from visnav.io.logs import open_recording
    from visnav.io.recording import RecordingError

    try:
        rec = open_recording(recording)
        if frames:
            from visnav.io.own_frames import attach_frames

            attach_frames(rec, frames, fps, camera_yaml)
        with console.status(f"checking {escape(recording)}"):
            res = run_check(rec, max_frames=max_frames)
        out_dir = Path(out) if out else Path("runs") / f"check-{Path(recording).resolve().name}"
        doc = write_check(res, out_dir, f"visnav check: {recording}")
    except (RecordingError, ValueError) as exc:
        _fail(exc)
    except OSError as exc:
        _fail(f"cannot write {out}: {exc.strerror or exc}")
    if json_:
        _print_json(doc)
        return
    table = Table(title=f"check of {escape(recording)}")
    for c in ("check", "status", "measured", "expected"):
        table.add_column(c)
    colour = {"ok": "green", "warning": "yellow", "problem": "red", "not observable": "dim"}
    for n, s, m, e in res.rows:
        table.add_row(escape(n), f"[{colour[s]}]{s}[/{colour[s]}]", escape(str(m)), escape(str(e)))
    console.print(table)
    for p in res.summary["problems"]:
        console.print(f"[red]problem:[/red] {escape(p)}", soft_wrap=True)
    console.print(f"written: {out_dir / 'check.json'}, {out_dir / 'check.html'}")


def main() -> None:  # pragma: no cover
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
