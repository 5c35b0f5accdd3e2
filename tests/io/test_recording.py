"""The recorded-flight folder: exact round trip of every measurement type, delivery order, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.io.recording import Recording, RecordingError
from visnav.io.recording_writer import RecordingWriter
from visnav.measurements import (AttitudeSample, BaroSample, Frame, GpsSample, HeadingSample, ImuSample,
                                 RangeSample)

CAM = PinholeCamera(64, 48, 80.123456789012345, 81.0 / 3.0, 31.7, 23.1, (0.1, -0.02, 1e-3, 0, 0, 0, 0, 0))
MOUNT = FixedMount.depressed(60.0, lever_arm=(0.8, 0.0, -0.6))


def _samples(rng):
    img = rng.integers(0, 256, (48, 64), dtype=np.uint8)
    t = 0.1 + 0.2  # 0.30000000000000004: not representable in few digits
    return [
        ImuSample(t, rng.normal(size=3), rng.normal(size=3) / 7.0),
        AttitudeSample(t, rng.normal(size=3)),
        GpsSample(t + 0.01, rng.normal(size=3) * 1e3, rng.normal(size=3), 0.123),
        RangeSample(t + 0.02, float("nan"), "sonar", 0.0),
        RangeSample(t + 0.02, np.pi * 3, "laser", -0.01),
        BaroSample(t + 0.03, np.e),
        HeadingSample(t + 0.04, -2.0 / 3.0),
        Frame(t + 0.05, img, 7),
    ]


def _write(tmp_path, samples, order=None):
    w = RecordingWriter(tmp_path)
    for k, m in enumerate(samples):
        w.add(m, t_recv=m.t + 0.5, seq=(order[k] if order else w.next_seq()))
    w.close(CAM, MOUNT, 0.0)
    return tmp_path


def test_round_trip_is_exact_and_in_delivery_order(tmp_path):
    src = _samples(np.random.default_rng(3))
    rec = Recording.open(_write(tmp_path, src))
    assert rec.camera.camera == CAM
    np.testing.assert_array_equal(rec.camera.mount.R_cam_to_body, MOUNT.R_cam_to_body)
    tr, sq, si, ri = rec.delivery()
    assert np.all(np.diff(tr) >= 0)
    np.testing.assert_array_equal(tr, [m.t + 0.5 for m in src])  # delivery times and order come back
    np.testing.assert_array_equal(sq, np.arange(1, len(src) + 1))
    got = [rec.sample(_name(rec, j), int(i)) for j, i in zip(si, ri)]
    assert [type(m) for m in got] == [type(m) for m in src]
    for a, b in zip(src, got):
        for f in a.__dataclass_fields__:
            x, y = getattr(a, f), getattr(b, f)
            if isinstance(x, np.ndarray):
                np.testing.assert_array_equal(x, y)  # bit for bit (17 digits, lossless PNG)
            elif isinstance(x, float) and np.isnan(x):
                assert np.isnan(y)
            else:
                assert x == y, f


def _name(rec, j):
    from visnav.io.recording import STREAM_NAMES

    return STREAM_NAMES[j]


def test_seq_breaks_ties_of_equal_delivery_times(tmp_path):
    rng = np.random.default_rng(1)
    a = ImuSample(1.0, rng.normal(size=3), rng.normal(size=3))
    b = AttitudeSample(1.0, rng.normal(size=3))
    w = RecordingWriter(tmp_path)
    w.add(b, 1.0, 1)  # the attitude was delivered first
    w.add(a, 1.0, 2)
    w.close(CAM, MOUNT)
    rec = Recording.open(tmp_path)
    _, _, si, _ = rec.delivery()
    assert [_name(rec, j) for j in si] == ["attitude", "imu"]


def test_missing_frame_file_names_it(tmp_path):
    _write(tmp_path, _samples(np.random.default_rng(0)))
    (tmp_path / "frames" / "000000.png").unlink()
    with pytest.raises(RecordingError, match=r"000000\.png: frame file missing"):
        Recording.open(tmp_path)


def test_corrupt_frame_is_skipped_and_counted(tmp_path):
    _write(tmp_path, _samples(np.random.default_rng(0)))
    (tmp_path / "frames" / "000000.png").write_bytes(b"not a png")
    rec = Recording.open(tmp_path)
    i = list(rec.streams).index("frames")
    assert rec.sample("frames", 0) is None and i >= 0
    assert rec.skipped == {"frames": 1}
    assert "000000.png: cannot be decoded" in rec.notes[0]


def test_missing_column_and_out_of_order_and_bad_number(tmp_path):
    _write(tmp_path, _samples(np.random.default_rng(0)))
    (tmp_path / "baro.csv").write_text("t_s,alt\n0,1\n")
    with pytest.raises(RecordingError, match=r"baro\.csv: missing column\(s\) altitude_m"):
        Recording.open(tmp_path)
    (tmp_path / "baro.csv").write_text("t_s,altitude_m\n0,1\n0.2,1\n0.1,2\n")
    with pytest.raises(RecordingError, match=r"baro\.csv: line 4: timestamps out of order"):
        Recording.open(tmp_path)
    (tmp_path / "baro.csv").write_text("t_s,altitude_m\n0,1\n0.2,abc\n")
    with pytest.raises(RecordingError, match=r"baro\.csv: line 3: column altitude_m holds 'abc'"):
        Recording.open(tmp_path)


def test_camera_yaml_without_intrinsics(tmp_path):
    _write(tmp_path, _samples(np.random.default_rng(0)))
    (tmp_path / "camera.yaml").write_text("image_size: [64, 48]\nR_cam_to_body: [[1,0,0],[0,1,0],[0,0,1]]\n")
    with pytest.raises(RecordingError, match=r"camera\.yaml: no intrinsics"):
        Recording.open(tmp_path)


def test_navigator_needs_streams_and_cli_says_so_in_one_line(tmp_path):
    from visnav.cli import app

    _write(tmp_path, _samples(np.random.default_rng(0))[:2])  # IMU + attitude only
    r = CliRunner().invoke(app, ["replay", str(tmp_path), "--navigator", "palace"])
    assert r.exit_code == 2
    assert "palace navigator needs gps.csv" in r.output and "Traceback" not in r.output
    (tmp_path / "imu.csv").write_text("t_s,ax_mps2\n0,1\n")
    r = CliRunner().invoke(app, ["replay", str(tmp_path), "--navigator", "palace"])
    assert r.exit_code == 2 and "imu.csv: missing column(s) ay_mps2" in r.output


def test_geodetic_gps_and_magnetometer_vectors_are_converted(tmp_path):
    """A user's gps.csv in latitude / longitude without velocity, a magnetometer.csv of field vectors."""
    from visnav.io.recording import write_csv

    _write(tmp_path, _samples(np.random.default_rng(0))[:2])
    t = np.arange(0.0, 2.0, 0.2)
    lat = 45.0 + 1e-5 * t  # due north at M * radians(1e-5) m/s
    write_csv(tmp_path / "gps.csv", {"t_s": t, "lat_deg": lat, "lon_deg": 7.0 + 0 * t, "alt_m": 100 + 0 * t})
    yaw = np.radians(30.0)
    write_csv(tmp_path / "attitude.csv", {"t_s": t, "roll_rad": 0 * t, "pitch_rad": 0 * t, "yaw_rad": yaw + 0 * t})
    write_csv(tmp_path / "magnetometer.csv", {"t_s": t, "mx": 0.2 * np.cos(yaw) + 0 * t,
                                              "my": -0.2 * np.sin(yaw) + 0 * t, "mz": 0.4 + 0 * t})
    rec = Recording.open(tmp_path)
    g = rec.streams["gps"]
    a, e2 = 6378137.0, 6.69437999014e-3
    M = a * (1 - e2) / (1 - e2 * np.sin(np.radians(45.0)) ** 2) ** 1.5
    np.testing.assert_allclose(g["vn_mps"], M * np.radians(1e-5), rtol=1e-4)
    np.testing.assert_allclose(g["n_m"][-1], M * np.radians(1e-5 * t[-1]), rtol=1e-4)
    np.testing.assert_allclose(rec.streams["magnetometer"]["heading_rad"], yaw, atol=1e-12)
    (tmp_path / "gps.csv").write_text("t_s,lat_deg\n0,45\n")
    with pytest.raises(RecordingError, match=r"gps\.csv: missing column.*or t_s, lat_deg, lon_deg, alt_m"):
        Recording.open(tmp_path)


def test_frames_from_one_video_file(tmp_path):
    """frames.csv may name one video and per-frame times; frames come back in order (lossless FFV1 here)."""
    import cv2

    from visnav.io.recording import write_csv

    _write(tmp_path, _samples(np.random.default_rng(0))[:2])
    rng = np.random.default_rng(9)
    imgs = [cv2.GaussianBlur(rng.integers(0, 256, (48, 64), dtype=np.uint8), (5, 5), 1.0) for _ in range(6)]
    vw = cv2.VideoWriter(str(tmp_path / "flight.avi"), cv2.VideoWriter_fourcc(*"FFV1"), 10.0, (64, 48), False)
    assert vw.isOpened()
    for im in imgs:
        vw.write(im)
    vw.release()
    t = 0.3 + 0.1 * np.arange(6)
    write_csv(tmp_path / "frames.csv", {"t_s": t, "file": np.array(["flight.avi"] * 6, dtype=object)})
    rec = Recording.open(tmp_path)
    got = [rec.sample("frames", i) for i in (0, 1, 2, 4, 5, 3)]  # forward, a skip, then back
    for f, k in zip(got, (0, 1, 2, 4, 5, 3)):
        assert f.t == t[k]
        np.testing.assert_array_equal(f.image, imgs[k])


def test_two_range_finders_in_one_file_are_in_order_each_not_together(tmp_path):
    """range.csv holds the laser and the sonar (one link message for both): the bridge's clock mapping once put a
    sonar sample 2 us before the laser sample written just before it, and the replay of its own recording was
    refused. Each sensor's stamps must be in order; the file's need not be. A sensor going back is still refused."""
    from visnav.io.recording import STREAMS, read_csv

    p = tmp_path / "range.csv"
    p.write_text("t_s,range_m,sensor\n1.0,5.0,laser\n1.000002260,5.0,laser\n1.000002258,5.1,sonar\n1.1,5.0,laser\n")
    out = read_csv(p, STREAMS["range"])
    assert list(out["sensor"]) == ["laser", "laser", "sonar", "laser"]
    p.write_text("t_s,range_m,sensor\n1.0,5.0,laser\n1.2,5.1,sonar\n1.1,5.0,laser\n1.15,5.1,sonar\n")
    with pytest.raises(RecordingError, match=r"range\.csv: line 5: timestamps out of order \(t_s 1\.15 after 1\.2\)"):
        read_csv(p, STREAMS["range"])
