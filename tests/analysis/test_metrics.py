"""Drift accounting of seed 000 §5.4 on constructed logs."""

import numpy as np

from visnav.analysis.metrics import mpe_drift
from visnav.flightlog import FlightLog


def _log(fixes, inits):
    log = FlightLog()
    for t in np.arange(0, 10.01, 0.1):
        log.record("truth", t, position=np.array([t, 0.0, -10.0]))
    for t, err in fixes:
        log.record("mpe", t, position=np.array([t, 0.0, -10.0]) + err)
    for t, err in inits:
        log.record("track_init", t, init_position=np.array([t, 0.0, -10.0]) + err)
    return log


def test_gps_reinit_banks_the_drift_vector():
    # drift 0.3 m north before a re-init from GPS (error 0), then 0.4 m east at the end: |(0.3, 0.4)| = 0.5
    fixes = [(1.0, [0.1, 0, 0]), (4.9, [0.3, 0, 0]), (5.1, [0.0, 0, 0]), (9.9, [0.0, 0.4, 0])]
    inits = [(0.5, [0, 0, 0]), (5.0, [0, 0, 0])]
    d, vec = mpe_drift(_log(fixes, inits))
    assert abs(d - 0.5) < 1e-9
    np.testing.assert_allclose(vec[:2], [0.3, 0.4], atol=1e-9)


def test_reinit_from_own_estimate_is_not_counted_twice():
    # the new reference inherits the 0.3 m drift (init error = drift): final error 0.35 is the total
    fixes = [(4.9, [0.3, 0, 0]), (9.9, [0.35, 0, 0])]
    inits = [(0.5, [0, 0, 0]), (5.0, [0.3, 0, 0])]
    d, _ = mpe_drift(_log(fixes, inits))
    assert abs(d - 0.35) < 1e-9


def test_gps_error_at_first_initialisation_is_not_tracker_drift():
    fixes = [(9.9, [0.05, 0.02, 0])]
    inits = [(0.5, [0.05, 0.02, 0])]
    d, _ = mpe_drift(_log(fixes, inits))
    assert d < 1e-9
