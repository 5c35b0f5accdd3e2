"""The run directory (DESIGN §6): scenario.toml, log.h5, truth.tum, estimate.tum, metrics.json, report.html."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from visnav.io.tum import tum_frame, write_run_tum
from visnav.scenarios.schema import to_toml
from visnav.analysis.outcome import apply_outcome
from visnav.io.provenance import provenance
from visnav.io.recording import COMMANDS, STREAMS, TRUTH
from visnav.analysis.report import write_report
from visnav.io.json_values import jsonable

# every file a run writes (``--force`` removes them first so that none is left from an earlier run)
RUN_FILES = ("scenario.toml", "metrics.json", "log.h5", "truth.tum", "estimate.tum", "report.html")


class OutputDirError(ValueError):
    """An output directory cannot be used; the message is one line for the user."""


def folder_kind(d: str | Path) -> str:
    """What a folder is, in words, by the files in it: "empty", "a run folder", "a campaign folder
    (campaign.json)", "a fault campaign folder (faults.csv)", "a recording (imu.csv, ...)", "your home
    directory", "the root directory", "a folder of other files (a.txt, ...)". ``--force`` replaces files only in
    the kind of folder it writes (issue #32: a campaign's report.html, or six files in ``/``, were lost)."""
    d = Path(d).expanduser()
    try:
        r = d.resolve()
    except OSError:
        r = d
    if r == Path(r.anchor):
        return "the root directory"
    if r == Path.home().resolve():
        return "your home directory"
    try:
        names = sorted(p.name for p in d.iterdir())
    except OSError:
        return "empty"
    if not names:
        return "empty"
    if "campaign.json" in names:
        return "a campaign folder (campaign.json)"
    if "faults.csv" in names or "faults.md" in names:
        return "a fault campaign folder (faults.csv)"
    if "bridge.tlog" in names:
        return "a bridge log folder (bridge.tlog)"
    if "margins.csv" in names:
        return "a margins folder (margins.csv)"

    rec = [n for n in names if n in {s.file for s in STREAMS.values()} | {TRUTH.file, COMMANDS.file, "camera.yaml"}]
    if rec:
        return f"a recording ({', '.join(rec[:3])}{', ...' if len(rec) > 3 else ''})"
    if "scenario.toml" in names or any(n in RUN_FILES for n in names):
        return "a run folder"
    other = [n for n in names if not n.startswith(".")]
    if not other:
        return "empty"
    return f"a folder of other files ({', '.join(other[:3])}{', ...' if len(other) > 3 else ''})"


def prepare_out_dir(d: str | Path, *, force: bool = False, clear: tuple[str, ...] = RUN_FILES,
                    what: str = "--out", kind: str | None = "a run folder") -> Path:
    """Create ``d`` (and parents) and check that it is writable. A directory that already holds
    files is refused unless ``force`` (then the files named in ``clear`` are removed); with ``force`` a
    folder of another ``folder_kind`` than ``kind`` (None: any but home / root) is refused, naming what it is."""
    d = Path(d)
    if d.exists() and not d.is_dir():
        raise OutputDirError(f"{what} {d}: exists and is not a directory")
    if d.is_dir() and any(d.iterdir()):
        if not force:
            raise OutputDirError(f"{what} {d}: directory is not empty; use --force to overwrite what visnav "
                                 "wrote there, or leave --out out for a new timestamped directory")
        found = folder_kind(d)
        if found in ("the root directory", "your home directory") or (kind is not None and found != "empty" and not found.startswith(kind)):
            raise OutputDirError(f"{what} {d}: is {found}, not {kind or 'an output folder'}; --force replaces "
                                 "files only in a folder of that kind: choose another --out")
        for name in clear:
            try:
                (d / name).unlink(missing_ok=True)
            except OSError as exc:
                raise OutputDirError(f"{what} {d}: cannot remove {name} ({exc.strerror or exc})") from None
    try:
        d.mkdir(parents=True, exist_ok=True)
        probe = d / ".visnav-write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise OutputDirError(f"{what} {d}: cannot write there ({exc.strerror or type(exc).__name__})") from None
    return d


def new_run_dir(name: str, out: str | Path | None = None, force: bool = False) -> Path:
    """``out`` (refused when it holds files, unless ``force``), else a new ``runs/<name>-<time>``."""
    if out is not None:
        return prepare_out_dir(out, force=force)
    base = Path("runs") / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}"
    d, i = base, 1
    while d.exists():
        d = base.with_name(f"{base.name}-{i}")
        i += 1
    return prepare_out_dir(d)


def write_run(result, out_dir: Path, report: bool = True) -> Path:
    """Write everything a run produced; each piece is written even if a later one fails. An
    interrupted run (Ctrl-C) is written as far as it got, ``"interrupted": true`` in metrics.json."""
    sc, log = result.scenario, result.log
    prov = provenance(sc)
    (out_dir / "scenario.toml").write_text(to_toml(sc))

    metrics = dict(result.metrics)
    if getattr(result, "interrupted", False):
        metrics["interrupted"] = True
    result.metrics = apply_outcome(metrics, log, sc, bool(getattr(result, "interrupted", False)))
    (out_dir / "metrics.json").write_text(json.dumps(jsonable({**metrics, "provenance": prov}), indent=2) + "\n")
    log.to_hdf5(out_dir / "log.h5", attrs={"seed": sc.run.seed,
                                           **{k: "" if v is None else v for k, v in prov.items()}})
    frame = tum_frame(sc)
    if frame is not None:
        write_run_tum(out_dir, log, frame)
    if report:
        write_report(result, out_dir / "report.html", provenance=prov)
    return out_dir
