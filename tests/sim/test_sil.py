"""`visnav run SCENARIO --sil`: the closed loop flown with the navigator behind the bridge over MAVLink on
127.0.0.1 (sim/sil.py). Real time: the short variant flies 6 s; the full landing is marked slow."""

import numpy as np
import pytest

from visnav.scenarios.schema import load_scenario
from visnav.sim.sil import run_sil

pytestmark = pytest.mark.realtime  # paced to the wall clock: run apart from the CPU-heavy suite (Makefile)


def test_palace_sil_short_flies_on_the_bridge_output():
    r = run_sil(load_scenario("palace-landing", ["run.duration_s=6"]))
    assert r.error is None, r.error
    m = r.metrics
    diag = {k: m.get(k) for k in ("link_ok", "sil_odometry_received", "sil_stamp_error_ms_max", "sil_frames_dropped",
                                  "timesync_rtt_ms", "latency_capture_to_send_ms", "sil_notes")}
    assert m["link_ok"] and m["sil_odometry_received"] > 5, diag  # ~55 on a quiet machine
    assert m["sil_stamp_error_ms_max"] < 2.0, diag  # ODOMETRY time_usec vs the instant it describes
    assert set(m["latency_capture_to_send_ms"]) == {"median", "p95", "n"}
    # the estimate the controller flew on (what came back over MAVLink) against truth
    tr, est = r.log.get("truth"), r.log.get("estimate")
    sel = est["t"] > 2.0
    truth = np.array([np.interp(est["t"][sel], tr["t"], tr["position"][:, i]) for i in range(3)]).T
    err = np.linalg.norm(est["position"][sel] - truth, axis=1)
    assert np.median(err) < 0.5, (np.median(err), diag)


@pytest.mark.slow
def test_palace_landing_over_sil_lands_like_in_process():
    r = run_sil(load_scenario("palace-landing"))
    assert r.error is None and r.metrics["landed"] and not r.metrics["aborted"]
    assert r.metrics["touchdown_error_m"] < 1.0
    assert r.metrics["sil_stamp_error_ms_max"] < 2.0
