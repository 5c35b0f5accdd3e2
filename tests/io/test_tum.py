"""Run directories' TUM files: valid estimates only, the frame named, and evo's APE equal to the
run's own ``ate_rmse_m`` (issue 12, point 2)."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from visnav.cli import app
from visnav.io.tum import DECK_FRAME, NED_FRAME, read_tum, tum_frame
from visnav.scenarios.schema import load_scenario


def _run(tmp_path, scenario, *sets):
    out = tmp_path / scenario
    args = ["run", scenario, "--out", str(out), "--no-report"] + [a for s in sets for a in ("--set", s)]
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    return out


def test_evo_ape_on_a_palace_run_equals_its_ate_metric(tmp_path):
    evo_metrics = pytest.importorskip("evo.core.metrics")
    from evo.core import sync
    from evo.tools import file_interface

    out = _run(tmp_path, "palace-landing", "run.duration_s=3")
    m = json.loads((out / "metrics.json").read_text())
    for name in ("truth.tum", "estimate.tum"):
        assert (out / name).read_text().splitlines()[0] == f"# timestamp tx ty tz qx qy qz qw; frame: {NED_FRAME}"
    t, p, _ = read_tum(out / "estimate.tum")
    # no (0, 0, 0) pose from before the first GPS fix: the vehicle starts 30 m up
    assert len(t) > 20 and np.all(p[:, 2] < -25)
    ref = file_interface.read_tum_trajectory_file(str(out / "truth.tum"))
    est = file_interface.read_tum_trajectory_file(str(out / "estimate.tum"))
    ref, est = sync.associate_trajectories(ref, est)
    assert est.num_poses == len(t)
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    rmse = ape.get_statistic(evo_metrics.StatisticsType.rmse)
    assert 0 < m["ate_rmse_m"] < 0.5
    assert rmse == pytest.approx(m["ate_rmse_m"], abs=1e-6)


def test_deck_runs_name_their_relative_frame_and_the_condor_ground_test_writes_no_pose(tmp_path):
    assert tum_frame(load_scenario("deck-static")) == DECK_FRAME
    assert tum_frame(load_scenario("palace-landing")) == NED_FRAME
    out = _run(tmp_path, "condor-ground-test")
    assert (out / "metrics.json").exists() and not (out / "estimate.tum").exists()
    assert not (out / "truth.tum").exists()
    assert "ate_rmse_m" not in json.loads((out / "metrics.json").read_text())
