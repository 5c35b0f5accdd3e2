"""PALACE report pages (seed 000 ch. 4-5) from a drift campaign directory and a margins.csv.

Drift vs altitude per surface beside Figs. 4.2-4.4 and Table 4.1, MPE noise sigma vs altitude
against R/(f√12) plus laser noise, margin tables in the layout of Tables 5.1 and 5.2 beside the
thesis', and Bode plots of the measured broken-loop responses (``frf.npz`` of ``visnav margins``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


# --------------------------------------------------------------------------- FRF storage
def _frf_name(key) -> str:
    alt, delay, comp, axis = key
    d = "gps" if delay is None else f"{float(delay):g}"
    return f"{float(alt):g}|{d}|{comp}|{axis}"


def save_frfs(path, frfs: dict) -> None:
    """Broken-loop responses keyed (altitude, delay or None, compensated, axis) to one ``.npz``."""
    arrays = {}
    for key, f in frfs.items():
        name = _frf_name(key)
        arrays[f"{name}|w"] = np.asarray(f["w"], float)
        arrays[f"{name}|H"] = np.asarray(f["H"], complex)
        arrays[f"{name}|coherence"] = np.asarray(f["coherence"], float)
    np.savez_compressed(path, **arrays)


def load_frfs(path) -> dict:
    """The inverse of ``save_frfs``: {(altitude, delay or None, compensated str, axis): {w, H, coherence}}."""
    out: dict = {}
    with np.load(path) as z:
        for name in z.files:
            alt, d, comp, axis, field = name.split("|")
            key = (float(alt), None if d == "gps" else float(d), comp, axis)
            out.setdefault(key, {})[field] = z[name]
    return out
