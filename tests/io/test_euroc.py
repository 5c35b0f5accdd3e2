"""EuRoC / ASL reader: a folder written here per the ASL spec, and the shared V1_01 excerpt."""

from __future__ import annotations

import numpy as np
import pytest

from tests.shared_data import missing_reason, shared_data_dir
from visnav.io.euroc import read_euroc
from visnav.io.logs import open_recording
from visnav.io.recording import RecordingError

EUROC = shared_data_dir() / "euroc_v1_01"


def _write_asl(root, T_BS_rows, n_imu=400, gt="csv"):
    """A minimal ASL folder: IMU at 200 Hz with x up at rest, two frames, ground truth."""
    import cv2

    mav = root / "mav0"
    (mav / "imu0").mkdir(parents=True)
    (mav / "cam0" / "data").mkdir(parents=True)
    t0 = 1403715273262142976  # beyond float64's integer precision: read as int64
    ts = t0 + np.arange(n_imu, dtype=np.int64) * 5_000_000
    rows = [f"{t},0.01,0.02,0.03,9.81,0.0,0.0" for t in ts]
    (mav / "imu0" / "data.csv").write_text("#timestamp [ns],w_RS_S_x,w_RS_S_y,w_RS_S_z,a_RS_S_x,a_RS_S_y,a_RS_S_z\n"
                                           + "\n".join(rows) + "\n")
    for k in range(2):
        cv2.imwrite(str(mav / "cam0" / "data" / f"{ts[10 * k + 3]}.png"), np.full((48, 64), 100, np.uint8))
    (mav / "cam0" / "data.csv").write_text("#timestamp [ns],filename\n" + "".join(
        f"{ts[10 * k + 3]},{ts[10 * k + 3]}.png\n" for k in range(2)))
    data = ", ".join(str(float(x)) for x in np.asarray(T_BS_rows, float).ravel())
    (mav / "cam0" / "sensor.yaml").write_text(
        "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [" + data + "]\nrate_hz: 20\n"
        "resolution: [64, 48]\ncamera_model: pinhole\nintrinsics: [50.0, 51.0, 31.5, 23.5]\n"
        "distortion_model: radial-tangential\ndistortion_coefficients: [-0.28, 0.07, 0.0002, 0.00002]\n")
    if gt == "csv":
        (mav / "state_groundtruth_estimate0").mkdir()
        # body x up in a z-up world: q_RS = rotation of -90 deg about world y (x_B -> z_R)
        q = (np.sqrt(0.5), 0.0, -np.sqrt(0.5), 0.0)
        (mav / "state_groundtruth_estimate0" / "data.csv").write_text(
            "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n"
            + "".join(f"{t},1.0,2.0,3.0,{q[0]},{q[1]},{q[2]},{q[3]}\n" for t in ts[::4]))
    return ts


# camera looking along body +z, camera x = body y, camera y = -body x (the V1 MAV's layout)
T_CAM = [[0, -1, 0, 0.1], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]


def test_asl_folder_is_read_per_spec(tmp_path):
    ts = _write_asl(tmp_path, T_CAM)
    rec = open_recording(tmp_path)  # the common reader dispatches on the layout
    i = rec.streams["imu"]
    assert len(i["t_s"]) == 400 and i["t_s"][1] == pytest.approx(0.005, abs=1e-12)
    f = rec.streams["frames"]
    assert f["t_s"][0] == pytest.approx((ts[3] - ts[0]) * 1e-9, abs=1e-12)  # exact from int64 ns
    # IMU x up at rest -> FRD down = -x, forward = the camera's axis (+z), right = down x forward = +y
    np.testing.assert_allclose([i["ax_mps2"][0], i["ay_mps2"][0], i["az_mps2"][0]], [0.0, 0.0, -9.81])
    np.testing.assert_allclose([i["gx_radps"][0], i["gy_radps"][0], i["gz_radps"][0]], [0.03, 0.02, -0.01])
    R = rec.camera.mount.R_cam_to_body
    np.testing.assert_allclose(R @ [0, 0, 1], [1, 0, 0], atol=1e-12)  # optical axis = forward
    np.testing.assert_allclose(R @ [0, 1, 0], [0, 0, 1], atol=1e-12)  # image down = body down
    cam = rec.camera.camera
    assert (cam.fx, cam.fy, cam.cx, cam.cy, cam.width) == (50.0, 51.0, 31.5, 23.5, 64)
    assert cam.dist[:4] == pytest.approx((-0.28, 0.07, 0.0002, 0.00002))
    # ground truth: the body x up in the z-up world -> level in FRD/NED
    assert np.degrees(np.abs(rec.truth["roll_rad"]).max()) < 1e-6
    assert np.degrees(np.abs(rec.truth["pitch_rad"]).max()) < 1e-6
    assert rec.truth["d_m"][0] == pytest.approx(-3.0) and rec.truth["n_m"][0] == pytest.approx(2.0)
    assert rec.image(0)[0].shape == (48, 64)


def test_bad_T_BS_and_models_named_in_one_line(tmp_path):
    _write_asl(tmp_path, [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    with pytest.raises(RecordingError, match="T_BS is not a rotation"):
        read_euroc(tmp_path)
    y = tmp_path / "mav0" / "cam0" / "sensor.yaml"
    _write_asl(tmp_path / "b", T_CAM)
    y = tmp_path / "b" / "mav0" / "cam0" / "sensor.yaml"
    y.write_text(y.read_text().replace("radial-tangential", "equidistant"))
    with pytest.raises(RecordingError, match="equidistant"):
        read_euroc(tmp_path / "b")


@pytest.mark.skipif(not EUROC.is_dir(), reason=missing_reason(EUROC))
def test_shared_euroc_v1_01_opens():
    rec = open_recording(EUROC)
    assert len(rec.streams["imu"]["t_s"]) == 29120 and len(rec.streams["frames"]["t_s"]) == 95
    assert len(rec.truth["t_s"]) > 2800
    i = rec.streams["imu"]
    f0 = np.array([i["ax_mps2"][:100].mean(), i["ay_mps2"][:100].mean(), i["az_mps2"][:100].mean()])
    # at rest the accelerometer's pitch agrees with Vicon's (-22.3 deg): the axes and the truth frame match
    pitch = np.degrees(np.arctan2(f0[0], np.hypot(f0[1], f0[2])))
    assert pitch == pytest.approx(np.degrees(rec.truth["pitch_rad"][0]), abs=0.5)
