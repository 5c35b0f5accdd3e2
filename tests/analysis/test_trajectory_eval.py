"""visnav's ATE / RPE / alignment against evo (the peer library) on the same TUM files, to 1e-6."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from visnav.analysis.trajectory_eval import (Trajectory, TrajectoryError, associate, evaluate, read_trajectory,
                                             segment_drift, umeyama)
from visnav.analysis.trajectory_export import write_tum_file

evo_sync = pytest.importorskip("evo.core.sync", reason="evo is a dev dependency (pip install -e '.[dev]')")
from evo.core import metrics as evo_metrics  # noqa: E402
from evo.core.geometry import umeyama_alignment  # noqa: E402
from evo.tools import file_interface  # noqa: E402


def _pair(tmp_path, seed=0, n=400, rate=10.0, jitter=0.004, scale=1.0):
    """A curved 3-D reference and a noisy, rotated, shifted, scaled, differently sampled estimate."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    p = np.column_stack([20 * np.sin(0.05 * t), 15 * np.cos(0.03 * t) * t / 10, -10 - 0.2 * t])
    eul = np.column_stack([0.1 * np.sin(t), 0.05 * np.cos(t), 0.02 * t])
    ref = Trajectory(t, p, Rotation.from_euler("xyz", eul).as_quat(), name="ref")
    r = Rotation.from_euler("z", 12, degrees=True)
    te = t[::2][5:] + rng.uniform(-jitter, jitter, len(t[::2][5:]))  # sparser, jittered, starts later
    pe = np.column_stack([np.interp(te, t, p[:, k]) for k in range(3)])
    pe = scale * r.apply(pe + rng.normal(0, 0.3, pe.shape) + np.cumsum(rng.normal(0, 0.02, pe.shape), axis=0)) \
        + [3.0, -2.0, 1.0]
    qe = (r * Rotation.from_euler("xyz", eul[::2][5:] + rng.normal(0, 0.01, (len(te), 3)))).as_quat()
    est = Trajectory(te, pe, qe, name="est")
    fr, fe = tmp_path / "ref.tum", tmp_path / "est.tum"
    write_tum_file(fr, ref, frame="test")
    write_tum_file(fe, est, frame="test")
    assert read_trajectory(fr).frame == "test"
    return fr, fe


def _evo(fr, fe, align, max_diff, rpe_delta=1, unit="frames"):
    r = file_interface.read_tum_trajectory_file(str(fr))
    e = file_interface.read_tum_trajectory_file(str(fe))
    r, e = evo_sync.associate_trajectories(r, e, max_diff=max_diff)
    if align != "none":
        e.align(r, correct_scale=(align == "sim3"))
    a = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    a.process_data((r, e))
    u = evo_metrics.Unit.frames if unit == "frames" else evo_metrics.Unit.meters
    p = evo_metrics.RPE(evo_metrics.PoseRelation.translation_part, delta=rpe_delta, delta_unit=u,
                        all_pairs=False, pairs_from_reference=True)
    p.process_data((r, e))
    return a.get_all_statistics(), p.get_all_statistics(), len(r.timestamps)


@pytest.mark.parametrize("align", ["none", "se3", "sim3"])
@pytest.mark.parametrize("rpe_delta,unit", [(1, "frames"), (5, "frames"), (10.0, "m")])
def test_ate_rpe_equal_evo_on_the_same_files(tmp_path, align, rpe_delta, unit):
    fr, fe = _pair(tmp_path, scale=1.3 if align == "sim3" else 1.0)
    ours = evaluate(read_trajectory(fr), read_trajectory(fe), alignment=align, max_diff=0.01,
                    rpe_delta=rpe_delta, rpe_unit=unit)
    a, p, matched = _evo(fr, fe, align, 0.01, rpe_delta, unit)
    assert ours.matched == matched
    for k in ("rmse", "mean", "median", "std", "min", "max", "sse"):
        assert ours.ape.size and abs(ours.summary()[f"ate_{k}_m"] - a[k]) <= 1e-6 * max(1.0, abs(a[k])), k
        assert abs(ours.summary()[f"rpe_{k}_m"] - p[k]) <= 1e-6 * max(1.0, abs(p[k])), k


def test_association_equals_evo_with_offset_and_ties(tmp_path):
    fr, fe = _pair(tmp_path, jitter=0.02)
    ref, est = read_trajectory(fr), read_trajectory(fe)
    r_evo = file_interface.read_tum_trajectory_file(str(fr))
    e_evo = file_interface.read_tum_trajectory_file(str(fe))
    for max_diff, off in [(0.01, 0.0), (0.02, 0.09), (0.015, -0.11)]:
        r, e = associate(ref, est, max_diff, off)
        r2, e2 = evo_sync.associate_trajectories(r_evo, e_evo, max_diff=max_diff, offset_2=off)
        np.testing.assert_array_equal(r.t, r2.timestamps)
        np.testing.assert_array_equal(e.t, e2.timestamps)


def test_umeyama_recovers_a_known_similarity_and_equals_evo():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(50, 3)) * [10, 5, 2]
    rot = Rotation.from_rotvec([0.3, -0.2, 1.1]).as_matrix()
    y = 2.5 * x @ rot.T + [1.0, 2.0, 3.0]
    r, t, c = umeyama(x, y, with_scale=True)
    np.testing.assert_allclose(r, rot, atol=1e-12)
    np.testing.assert_allclose(t, [1, 2, 3], atol=1e-10)
    assert c == pytest.approx(2.5, abs=1e-12)
    y_noisy = y + rng.normal(0, 0.5, y.shape)
    r1, t1, c1 = umeyama(x, y_noisy, with_scale=True)
    r2, t2, c2 = umeyama_alignment(x.T, y_noisy.T, True)
    np.testing.assert_allclose(r1, r2, atol=1e-12)
    np.testing.assert_allclose(t1, t2, atol=1e-10)
    assert c1 == pytest.approx(c2, abs=1e-12)


def test_segment_drift_of_a_constant_scale_error_is_that_error():
    t = np.arange(1000) * 0.1
    p = np.column_stack([t * 5.0, np.zeros_like(t), np.zeros_like(t)])  # 5 m/s straight line
    q = np.tile([0, 0, 0, 1.0], (len(t), 1))
    ref = Trajectory(t, p, q)
    est = Trajectory(t, p * 1.02, q)  # 2 % odometry scale error: 2 % drift on every segment
    d = segment_drift(ref, est, 100.0)
    assert len(d) > 0
    np.testing.assert_allclose(d, 2.0, rtol=1e-9)


def test_bad_inputs_name_the_file(tmp_path):
    (tmp_path / "bad.tum").write_text("1 2 3\n")
    with pytest.raises(TrajectoryError, match="bad.tum: a TUM file has 8 columns"):
        read_trajectory(tmp_path / "bad.tum")
    with pytest.raises(TrajectoryError, match="no such file"):
        read_trajectory(tmp_path / "missing.tum")
    (tmp_path / "ooo.tum").write_text("2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n")
    with pytest.raises(TrajectoryError, match="out of order"):
        read_trajectory(tmp_path / "ooo.tum")
    (tmp_path / "nocol.csv").write_text("t_s,a,b\n0,1,2\n")
    with pytest.raises(TrajectoryError, match="position columns"):
        read_trajectory(tmp_path / "nocol.csv")
    ref = Trajectory([0.0, 1.0], np.zeros((2, 3)), np.tile([0, 0, 0, 1.0], (2, 1)))
    far = Trajectory([10.0, 11.0], np.zeros((2, 3)), np.tile([0, 0, 0, 1.0], (2, 1)))
    with pytest.raises(TrajectoryError, match="no matching time stamps"):
        associate(ref, far)


def test_csv_and_tum_give_the_same_evaluation(tmp_path):
    fr, fe = _pair(tmp_path)
    est = read_trajectory(fe)
    csv = tmp_path / "est.csv"
    np.savetxt(csv, np.column_stack([est.t, est.p, est.q]), delimiter=",", fmt="%.9f",
               header="t_s,x_m,y_m,z_m,qx,qy,qz,qw", comments="")
    a = evaluate(read_trajectory(fr), est, alignment="se3").summary()
    b = evaluate(read_trajectory(fr), read_trajectory(csv), alignment="se3").summary()
    assert a["ate_rmse_m"] == pytest.approx(b["ate_rmse_m"], abs=1e-6)


def test_eval_command_writes_outputs_and_exports_lat_lon(tmp_path):
    import json

    from typer.testing import CliRunner

    from visnav.cli import app
    from visnav.geometry.frames import LocalTangentPlane

    fr, fe = _pair(tmp_path)
    out = tmp_path / "ev"
    res = CliRunner().invoke(app, ["eval", str(fr), str(fe), "--align", "se3", "--drift", "20", "--out", str(out),
                                   "--origin", "60.4,22.46,30", "--json"])
    assert res.exit_code == 0, res.output
    s = json.loads(res.output)
    a, _, _ = _evo(fr, fe, "se3", 0.01)
    assert s["ate_rmse_m"] == pytest.approx(a["rmse"], abs=1e-6)
    assert json.loads((out / "eval.json").read_text())["ate_rmse_m"] == pytest.approx(s["ate_rmse_m"])
    gj = json.loads((out / "trajectories.geojson").read_text())
    lon, lat, h = np.array(gj["features"][0]["geometry"]["coordinates"][0])
    ref, _ = associate(read_trajectory(fr), read_trajectory(fe))  # the evaluated (associated) reference
    np.testing.assert_allclose(LocalTangentPlane(60.4, 22.46, 30).geodetic_to_ned(lat, lon, h), ref.p[0], atol=1e-3)
    assert (out / "trajectories.kml").read_text().count("<Placemark>") == 2
    bad = CliRunner().invoke(app, ["eval", str(tmp_path / "none.tum"), str(fe)])
    assert bad.exit_code == 2 and "no such file" in bad.output and "Traceback" not in bad.output
