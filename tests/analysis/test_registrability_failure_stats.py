"""The failure statistics of scripts/geolocation_registrability.py (lowest-scoring quarter against the rest)."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).parents[2] / "scripts" / "geolocation_registrability.py"


def _mod():
    spec = importlib.util.spec_from_file_location("geolocation_registrability", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_low_quarter_split_and_fisher_p_against_the_hypergeometric_sum():
    # 8 frames: the 2 lowest scores are the lowest quarter
    scores = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8])
    failed = np.array([1, 1, 0, 0, 0, 0, 0, 1], bool)
    st = _mod().low_quarter_stats(scores, failed)
    assert (st["fail_low"], st["n_low"], st["fail_rest"], st["n_rest"]) == (2, 2, 1, 6)
    s2 = _mod().low_quarter_stats(np.r_[np.zeros(4), np.ones(12)],
                                  np.r_[[1, 1, 1, 0], [1, 0, 0, 0], np.zeros(8)].astype(bool))
    # 4 low (3 failed) against 12 (1 failed): p = P(a >= 3) + P(a = 0) under the hypergeometric(16, 4, 4)
    h = [math.comb(4, a) * math.comb(12, 4 - a) / math.comb(16, 4) for a in range(5)]
    p = sum(x for x in h if x <= h[3] * (1 + 1e-9))
    assert s2["p_fisher"] == pytest.approx(p, rel=1e-9)
    assert s2["ci95"][0] < s2["odds_ratio"] < s2["ci95"][1]
    assert s2["rate_low"] == 0.75 and s2["rate_rest"] == pytest.approx(1 / 12)
