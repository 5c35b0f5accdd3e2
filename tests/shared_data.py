"""Where the real data of ``../shared/data`` lives (satellite maps, the PX4 log), for the tests that use it.

The folder sits beside the repository (``<repo>/../shared/data``); ``VISNAV_SHARED_DATA`` names
another place (for example from a git worktree). Tests that need a file skip, with this path in the
reason, when it is absent.
"""

from __future__ import annotations

import os
from pathlib import Path

BESIDE_REPO = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def shared_data_dir() -> Path:
    """``../shared/data`` beside the repository, else ``$VISNAV_SHARED_DATA`` (which may not exist)."""
    if BESIDE_REPO.is_dir() or not os.environ.get("VISNAV_SHARED_DATA"):
        return BESIDE_REPO
    return Path(os.environ["VISNAV_SHARED_DATA"])


def missing_reason(path: Path) -> str:
    return f"{path} not found (the shared data folder beside the repository, or set VISNAV_SHARED_DATA)"
