"""Command line: ``visnav run SCENARIO``, ``visnav scenarios``."""

from __future__ import annotations

import sys
from typing import List, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

app = typer.Typer(add_completion=False, no_args_is_help=True, help="visnav: UAV navigation without GPS")
console = Console()


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.3f}"
    return str(v)


@app.command()
def run(
    scenario: str = typer.Argument("palace-landing", help="built-in scenario name or path to a .toml file"),
    seed: Optional[int] = typer.Option(None, help="override run.seed"),
    out: Optional[str] = typer.Option(None, help="run directory (default runs/<scenario>-<time>)"),
    set_: List[str] = typer.Option([], "--set", help="override a key, e.g. --set sensors.imu.delay_s=0.043"),
    report: bool = typer.Option(True, help="write report.html"),
) -> None:
    """Run one closed-loop simulation and write its run directory."""
    from visnav.analysis.metrics import PALACE_PUBLISHED
    from visnav.io.runs import new_run_dir, write_run
    from visnav.scenarios.schema import ScenarioError, load_scenario
    from visnav.sim.loop import Simulation

    try:
        sc = load_scenario(scenario, set_, seed)
        sim = Simulation(sc)
    except (ScenarioError, FileNotFoundError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2)
    out_dir = new_run_dir(sc.run.name, out)
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.fields[info]}"),
                  TimeElapsedColumn(), console=console, transient=True) as prog:
        task = prog.add_task(sc.run.name, total=sc.run.duration_s, info="")

        def progress(t, total):
            if int(t * 10) % 10 == 0:
                prog.update(task, completed=t, info=f"t={t:5.1f}s {sim.mission.mode}")

        result = sim.run(progress=progress)
    write_run(result, out_dir, report=report)
    table = Table(title=f"{sc.run.name} (seed {sc.run.seed})")
    table.add_column("metric")
    table.add_column("this run", justify="right")
    table.add_column("seed 000 (Hubbard 2007)")
    for k, v in result.metrics.items():
        table.add_row(k, _fmt(v), PALACE_PUBLISHED.get(k, ""))
    console.print(table)
    console.print(f"run directory: {out_dir}")
    if result.error:
        console.print(f"[red]the run stopped early:[/red] {result.error} (what it had is saved)")
        raise typer.Exit(1)


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


def main() -> None:  # pragma: no cover
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
