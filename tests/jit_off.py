"""Run test code in a fresh interpreter with the kernels' compiler switched off (``VISNAV_JIT=0``, visnav/jit.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_without_jit(code: str) -> None:
    """Run ``code`` (which must print ``ok`` last) with VISNAV_JIT=0 and this checkout's src and tests on the path;
    fails with the interpreter's stderr when it does not print ``ok``."""
    env = {**os.environ, "VISNAV_JIT": "0", "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT)])}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]
