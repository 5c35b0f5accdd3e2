"""PX4 ULog reader: the sample log of ../shared/data, repaired and refused logs built from it."""


import numpy as np
import pytest

from tests.shared_data import missing_reason, shared_data_dir
from visnav.io.ulog import clean_series, read_ulog


LOG = shared_data_dir() / "px4" / "sample_px4_events.ulg"
needs_log = pytest.mark.skipif(not LOG.is_file(), reason=missing_reason(LOG))


@needs_log
def test_reads_the_sample_log():
    d = read_ulog(LOG)
    assert len(d.imu_t) == 7783 and d.imu_t[0] == 0.0
    assert (len(d.imu_t) - 1) / d.imu_t[-1] == pytest.approx(250.0, rel=1e-3)  # 4 ms gyro period
    assert np.all(np.diff(d.imu_t) > 0)
    # at rest before take-off the accelerometer reads about -g on z (FRD)
    assert d.accel[:100, 2].mean() == pytest.approx(-9.81, abs=0.05)
    np.testing.assert_allclose(np.linalg.norm(d.att_quat, axis=1), 1.0, atol=1e-9)
    assert len(d.att_t) == 622 and d.mag is not None and len(d.mag_t) == 459
    assert d.declination_deg == pytest.approx(3.323, abs=1e-3)
    assert d.notes == []


@needs_log
def test_log_without_needed_topics_is_refused_with_their_names(tmp_path):
    from pyulog import ULog

    u = ULog(str(LOG), ["vehicle_attitude"])
    p = tmp_path / "no_imu.ulg"
    u.write_ulog(str(p))
    with pytest.raises(ValueError, match="sensor_combined"):
        read_ulog(p)
    u = ULog(str(LOG), ["actuator_armed"])
    p = tmp_path / "nothing.ulg"
    u.write_ulog(str(p))
    with pytest.raises(ValueError, match="sensor_combined, vehicle_attitude"):
        read_ulog(p)


@needs_log
def test_nan_samples_are_dropped_and_reported(tmp_path):
    """(pyulog's writer orders messages by time, so out-of-order data is tested on clean_series.)"""
    from pyulog import ULog

    u = ULog(str(LOG), ["sensor_combined", "vehicle_attitude"])
    sc = next(d for d in u.data_list if d.name == "sensor_combined").data
    sc["gyro_rad[1]"][[10, 20, 30]] = np.nan
    p = tmp_path / "broken.ulg"
    u.write_ulog(str(p))
    d = read_ulog(p)
    assert len(d.imu_t) == 7783 - 3
    assert np.all(np.diff(d.imu_t) > 0) and np.all(np.isfinite(d.gyro))
    text = " | ".join(d.notes)
    assert "sensor_combined: dropped 3 of 7783 samples with NaN" in text
    assert "no magnetometer" in text


def test_missing_and_garbage_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        read_ulog(tmp_path / "none.ulg")
    bad = tmp_path / "bad.ulg"
    bad.write_bytes(b"this is not a ulog file at all" * 10)
    with pytest.raises(ValueError, match="not a readable ULog"):
        read_ulog(bad)


def test_clean_series():
    notes = []
    t = np.array([0, 10, 30, 20, 20, 40, 50])
    v = np.array([[0.0], [1], [3], [2], [2], [np.nan], [5]])
    tc, vc = clean_series(t, v, "topic", notes)
    np.testing.assert_array_equal(tc, [0, 10, 20, 30, 50])
    np.testing.assert_array_equal(vc[:, 0], [0, 1, 2, 3, 5])
    assert len(notes) == 3
    with pytest.raises(ValueError, match="fewer than 2"):
        clean_series([0, 1], [[np.nan], [1.0]], "x", [])
