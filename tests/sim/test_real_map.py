"""The same landing over a real geo-referenced orthophoto (../shared/data), when it is present."""


import numpy as np
import pytest

from tests.shared_data import shared_data_dir
from visnav.scenarios.schema import load_scenario
from visnav.app.loop import Simulation

DATA = shared_data_dir()
MAP = DATA / "satellite_column.png"


@pytest.mark.skipif(not MAP.exists(), reason=f"real map not found: {MAP}")
def test_world_from_real_orthophoto_renders_and_tracks():
    sc = load_scenario("palace-landing", [f"world.map_file='{MAP}'", "mission.start_height_m=14",
                                          "mission.settle_s=1", "run.duration_s=12"], seed=1)
    sim = Simulation(sc)
    g = sim.world.ground
    assert abs(g.resolution_m - 0.25) < 0.01
    n0, n1, e0, e1 = g.extent_ned()
    assert n0 < 0 < n1 and e0 < 0 < e1  # the landing point (0, 0) is on the map (its centre)
    res = sim.run()
    assert res.error is None
    trk = res.log.get("tracker")
    assert len(trk["t"]) > 50 and np.mean(trk["coherence"]) > 0.5
