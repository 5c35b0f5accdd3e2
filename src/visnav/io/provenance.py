"""Provenance of an output: which visnav (version, git commit), which command, when, which scenario.

Written under ``provenance`` in ``metrics.json`` and as a small block in every report, so that a result
can be traced to the code and the configuration that made it. The scenario is identified by
``scenario_hash`` (SHA-256 of its fully resolved canonical TOML): two runs with the same hash flew the
same configuration, whatever files and ``--set`` overrides produced it.
"""

from __future__ import annotations

import html
import shlex
import subprocess
import sys
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path
from importlib.metadata import PackageNotFoundError, version
from visnav import __version__
from visnav.scenarios.schema import scenario_hash


def visnav_version() -> str:
    try:
        return version("visnav")
    except PackageNotFoundError:  # run from a source tree that was never installed

        return __version__


@lru_cache(maxsize=1)
def git_commit() -> str | None:
    """Commit of the git checkout this package's source is tracked in ("+dirty" when the package's files
    differ from it), or None when it is not in a git checkout (an installed wheel) or git is missing."""
    pkg = Path(__file__).resolve().parents[1]

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(pkg), *args], capture_output=True, text=True, timeout=5)

    try:
        if git("ls-files", "--error-unmatch", "__init__.py").returncode != 0:
            return None  # a checkout contains the package (a venv inside a repo) but does not track it
        head = git("rev-parse", "HEAD")
        if head.returncode != 0:
            return None
        dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".").stdout.strip()
        return head.stdout.strip() + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return None


def provenance(scenario=None, argv: list[str] | None = None) -> dict:
    """visnav_version, git_commit (None when unknown), command_line (as typed, shell-quoted), date_utc (ISO
    8601) and scenario_hash (None without a scenario)."""
    argv = list(sys.argv if argv is None else argv)
    out = {"visnav_version": visnav_version(), "git_commit": git_commit(),
           "command_line": shlex.join(argv),
           "date_utc": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    if scenario is not None:
        out["scenario"] = scenario.run.name
        out["scenario_hash"] = scenario_hash(scenario)
    return out


def provenance_html(prov: dict) -> str:
    """The block a report shows: one line per field."""
    labels = {"visnav_version": "visnav", "git_commit": "git commit", "command_line": "command",
              "date_utc": "date (UTC)", "scenario": "scenario", "scenario_hash": "scenario hash (SHA-256)"}
    rows = "".join(f"<tr><td>{html.escape(labels.get(k, k))}</td><td><code>{html.escape('unknown' if v is None else str(v))}</code></td></tr>"
                   for k, v in prov.items() if k in labels)
    return f"<h2>Provenance</h2><table class='provenance'>{rows}</table>"
