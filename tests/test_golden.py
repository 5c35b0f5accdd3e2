"""Golden figures (issue #31): the headline metrics of every built-in scenario, seeds 1-5, against the values stored
in tests/data/golden.json by scripts/golden.py.

Tolerance, per metric: 2 % of the stored value, or an absolute floor in the metric's unit (0.01 m, 0.05 deg,
0.05 s, 0.01 m/s, 0.05 %, 0.05 px), whichever is larger. Why: the same code on another CPU (libm, BLAS, SIMD)
changes a closed-loop run in the last digits, and a mode switch or a gate that flips on such a difference moves a
figure by far less than 2 %; a change of what a result means (a filter that is worse, a controller that overshoots)
moves it by more. Outcomes (safe / unsafe / ...) and booleans must be equal. A seed whose run flips between two
branches on last-digit changes stores both (``also``, with ``why``): witas-homing seed 4 (deck-moving seed 1 did until the
reference lead of issue 30 round 14 moved its landing; not re-checked for branches since). The default run flies three quick
scenarios at seed 1; ``-m slow`` flies every stored scenario and seed.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

GOLDEN = Path(__file__).resolve().parent / "data" / "golden.json"
FLOORS = (("_pct", 0.05), ("_deg", 0.05), ("_mps", 0.01), ("_px", 0.05), ("_m", 0.01), ("_s", 0.05))
QUICK = ("pfcm-segment", "condor-ground-test", "mav-geolocation-single")


def _script():
    spec = importlib.util.spec_from_file_location("golden", Path(__file__).parents[1] / "scripts" / "golden.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _stored() -> dict:
    return json.loads(GOLDEN.read_text()) if GOLDEN.is_file() else {}


def tolerance(metric: str, value: float) -> float:
    floor = next((f for suffix, f in FLOORS if metric.endswith(suffix)), 0.0)
    return max(0.02 * abs(value), floor)


def differences(stored: dict, now: dict) -> list[str]:
    """What moved beyond its tolerance (one line per metric; empty when the run agrees)."""
    out = []
    for k, want in stored.items():
        got = now.get(k)
        if isinstance(want, bool) or isinstance(want, str) or want is None or got is None:
            if got != want:
                out.append(f"{k}: {got!r}, stored {want!r}")
        elif not (isinstance(got, (int, float)) and math.isfinite(got) and abs(got - want) <= tolerance(k, want)):
            out.append(f"{k}: {got!r}, stored {want!r} (tolerance {tolerance(k, want):.3g})")
    return out


def matches(stored: dict, now: dict) -> list[str]:
    """``differences`` against the stored figures, or against any of the alternatives a seed with two outcomes
    stores in ``also`` (with ``why``: a seed whose run flips between two branches on last-digit changes, each
    branch reproduced by a perturbation of 1e-9 or less); the main entry's differences when none matches."""
    main = {k: v for k, v in stored.items() if k not in ("also", "why")}
    first = differences(main, now)
    if first and any(not differences(alt, now) for alt in stored.get("also", [])):
        return []
    return first


def test_a_seed_with_two_stored_outcomes_matches_either():
    stored = {"drift_pct": 0.36, "also": [{"drift_pct": 1.18}], "why": "two branches"}
    assert matches(stored, {"drift_pct": 0.361}) == [] and matches(stored, {"drift_pct": 1.179}) == []
    assert matches(stored, {"drift_pct": 0.8}) == ["drift_pct: 0.8, stored 0.36 (tolerance 0.05)"]


def test_the_comparison_sees_a_change_of_meaning():
    stored = {"touchdown_error_m": 0.30, "outcome": "safe", "landed": True}
    assert differences(stored, {"touchdown_error_m": 0.305, "outcome": "safe", "landed": True}) == []
    assert differences(stored, {"touchdown_error_m": 0.33, "outcome": "safe", "landed": True})
    assert differences(stored, {"touchdown_error_m": 0.30, "outcome": "unsafe", "landed": True})
    assert differences(stored, {"touchdown_error_m": math.nan, "outcome": "safe", "landed": True})


def _cases(quick: bool) -> list:
    stored = _stored()
    if quick:
        return [pytest.param(s, "1", id=f"{s}-1") for s in QUICK if "1" in stored.get(s, {})]
    return [pytest.param(s, k, id=f"{s}-{k}", marks=pytest.mark.slow) for s in sorted(stored) for k in stored[s]]


def test_every_builtin_scenario_has_golden_figures():
    from visnav.scenarios.schema import builtin_names

    SKIP = _script().SKIP
    stored = _stored()
    missing = [s for s in builtin_names() if s not in SKIP and s not in stored]
    assert not missing, f"no golden figures for {missing}: run scripts/golden.py --scenarios {','.join(missing)}"


@pytest.mark.parametrize("scenario,seed", _cases(quick=True))
def test_golden_figures_quick(scenario, seed):
    assert matches(_stored()[scenario][seed], _script().headline(scenario, int(seed))) == []


@pytest.mark.parametrize("scenario,seed", _cases(quick=False))
def test_golden_figures(scenario, seed):
    assert matches(_stored()[scenario][seed], _script().headline(scenario, int(seed))) == []
