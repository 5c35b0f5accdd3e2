"""The one run scaffold (app/loop.run_scaffold) of every system: Ctrl-C or an exception stops the run, which
keeps the log it had and scores it from that log."""

import numpy as np
import pytest

from visnav.scenarios.schema import load_scenario
from visnav.app.missions import make_simulation


@pytest.mark.parametrize("name, keys, stream", [
    ("deck-static", ["run.duration_s=3"], "vehicle"),  # logged every step
    ("condor-orbit", ["run.duration_s=3"], "truth"),  # logged at 10 Hz
    ("mav-geolocation-single", ["run.duration_s=3"], "truth"),
])
@pytest.mark.parametrize("stop", [KeyboardInterrupt, RuntimeError])
def test_a_stopped_run_keeps_its_log_and_is_scored_from_it(name, keys, stream, stop):
    sim = make_simulation(load_scenario(name, keys, seed=1))
    inner, calls = sim.logger, []

    def logger(step):
        inner(step)
        calls.append(step.t)
        if len(calls) == 5:
            raise stop("stopped by the test")

    sim.logger = logger
    r = sim.run()
    t_stop = calls[-1]
    log = r.log.get(stream)
    assert len(log["t"]) == 5 and log["t"][-1] == pytest.approx(t_stop)
    if stop is KeyboardInterrupt:
        assert r.interrupted and r.error is None
    else:
        assert not r.interrupted and r.error == f"RuntimeError at t={t_stop:.2f}s: stopped by the test"
        assert list(r.log.get("error")["message"]) == [r.error]
    assert np.isfinite(t_stop) and t_stop < 1.0
