"""The PALACE result scripts (scripts/palace_pm_trend.py, scripts/palace_drift_tables.py)."""

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

SCRIPTS = Path(__file__).parents[1] / "scripts"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_pm_trend_slope_and_standard_error_match_scipy_linregress():
    rng = np.random.default_rng(3)
    x = np.repeat([6.0, 12.0, 18.0, 30.0, 54.0], 6)
    y = 43.0 - 0.07 * x + rng.normal(0.0, 3.0, x.size)
    y[4] = np.nan  # a sweep without a margin is left out
    b, se = _load("palace_pm_trend")._slope(x, y)
    ok = np.isfinite(y)
    ref = stats.linregress(x[ok], y[ok])
    assert b == pytest.approx(ref.slope, rel=1e-10)
    assert se == pytest.approx(ref.stderr, rel=1e-10)


def test_drift_tables_merge_wind_directions_per_altitude(tmp_path, capsys):
    cols = ["seed", "status", "surface", "altitude_m", "world.wind_from_deg", "drift_px", "drift_m",
            "tracker_lost", "mpe_noise_sigma_m", "mean_range_m"]
    rows = [(1, "ok", "grass", 6, 0, 10.0), (2, "ok", "grass", 6, 0, 20.0), (1, "ok", "grass", 6, 90, 40.0),
            (1, "ok", "grass", 12, 0, 5.0), (2, "failed", "grass", 12, 0, "")]
    d = tmp_path / "camp"
    d.mkdir()
    with (d / "runs.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow([*r, 0.1, False, 0.02, 7.6])
    _load("palace_drift_tables").main([str(d)])
    out = capsys.readouterr().out
    assert "5 runs, 1 failed, 0 tracks lost" in out
    assert "| grass | 6 | 3 | 23.33 | 40.00 |" in out  # (10 + 20 + 40) / 3, max over both winds
    assert "| grass | 12 | 1 | 5.00 | 5.00 |" in out
