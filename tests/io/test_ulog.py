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


# ------------------------------------------------------------ issue 12 point 6: truncated and older logs
@needs_log
def test_a_truncated_log_is_read_up_to_the_damage_and_says_so(tmp_path):
    from typer.testing import CliRunner

    from visnav.cli import app
    from visnav.io.ulog import ulog_cut

    cut = tmp_path / "cut.ulg"
    cut.write_bytes(LOG.read_bytes()[:100_000])
    assert ulog_cut(LOG)[0] is False and ulog_cut(cut)[:2] == (True, 100_000)
    d = read_ulog(cut)
    assert d.truncated and not read_ulog(LOG).truncated
    assert 0 < len(d.imu_t) < 7783 and d.imu_t[-1] < 1.0
    note = d.notes[0]
    assert "truncated" in note and "100000 bytes" in note and f"{d.imu_t[-1]:.1f} s of data" in note
    r = CliRunner().invoke(app, ["ahrs", str(cut), "--out", str(tmp_path / "a")])
    assert r.exit_code == 0, r.output
    assert "TRUNCATED" in r.stdout and "truncated" in r.stderr


def _older_layout(tmp_path, with_mag=True):
    """The sample log rewritten in the older layout: magnetometer and barometer inside
    sensor_combined (magnetometer_ga[3], baro_alt_meter, their relative timestamps), no
    vehicle_magnetometer / vehicle_air_data topics. Returns the path and the injected series."""
    from pyulog import ULog

    u = ULog(str(LOG), ["sensor_combined", "vehicle_attitude", "vehicle_magnetometer", "vehicle_air_data"])
    topics = {d.name: d for d in u.data_list}
    sc, vm, va = topics["sensor_combined"].data, topics["vehicle_magnetometer"].data, topics["vehicle_air_data"].data
    t = sc["timestamp"].astype(np.int64)
    # the latest magnetometer / baro sample at each IMU message, with its age as the relative stamp
    im = np.clip(np.searchsorted(vm["timestamp"], t, side="right") - 1, 0, None)
    ib = np.clip(np.searchsorted(va["timestamp"], t, side="right") - 1, 0, None)
    fmt = u.message_formats["sensor_combined"]
    fmt.fields = fields = [f for f in fmt.fields if not f[2].startswith("_padding")]  # new fields go at the end
    n_old = len(fields)
    if with_mag:
        for i in range(3):
            sc[f"magnetometer_ga[{i}]"] = vm[f"magnetometer_ga[{i}]"][im].astype(np.float32)
        sc["magnetometer_timestamp_relative"] = (vm["timestamp_sample"][im].astype(np.int64) - t).astype(np.int32)
        fields += [("float", 3, "magnetometer_ga"), ("int32_t", 0, "magnetometer_timestamp_relative")]
    sc["baro_alt_meter"] = va["baro_alt_meter"][ib].astype(np.float32)
    sc["baro_timestamp_relative"] = (va["timestamp_sample"][ib].astype(np.int64) - t).astype(np.int32)
    fields += [("float", 0, "baro_alt_meter"), ("int32_t", 0, "baro_timestamp_relative")]
    added = fields[n_old:]
    topics["sensor_combined"].field_data += [ULog._FieldData(f"{n}[{i}]", ty) for ty, size, n in added
                                             for i in range(size)] + [ULog._FieldData(n, ty) for ty, size, n in added
                                                                      if size == 0]
    u._data_list = [d for d in u.data_list if d.name in ("sensor_combined", "vehicle_attitude")]
    p = tmp_path / "older.ulg"
    u.write_ulog(str(p))
    return p, vm, va, t[0]


@needs_log
def test_the_older_layout_with_magnetometer_and_baro_in_sensor_combined_is_read(tmp_path):
    p, vm, va, _ = _older_layout(tmp_path)
    d = read_ulog(p)
    assert d.mag_source == "sensor_combined"
    new = read_ulog(LOG)
    # the same magnetometer samples at the same instants as the newer layout's topic
    # (those that were the latest at some IMU message)
    common, a, b = np.intersect1d(np.round(d.mag_t, 6), np.round(new.mag_t, 6), return_indices=True)
    assert len(common) > 0.9 * len(new.mag_t)
    np.testing.assert_allclose(d.mag[a], new.mag[b], rtol=1e-6)
    assert d.baro_alt is not None and len(d.baro_t) > 0.9 * len(new.baro_t)
    np.testing.assert_allclose(np.interp(new.baro_t, d.baro_t, d.baro_alt), new.baro_alt, atol=0.5)


@needs_log
def test_a_log_without_magnetometer_says_so_in_the_ahrs_table(tmp_path):
    from typer.testing import CliRunner

    from visnav.cli import app

    p, *_ = _older_layout(tmp_path, with_mag=False)
    assert read_ulog(p).mag is None
    r = CliRunner().invoke(app, ["ahrs", str(p), "--out", str(tmp_path / "a")])
    assert r.exit_code == 0, r.output
    rows = {ln.split("│")[1].strip(): ln.split("│")[2].strip() for ln in r.stdout.splitlines() if ln.count("│") == 3}
    assert rows["magnetometer"].startswith("NOT FOUND")
    assert rows["yaw_rms_diff_deg"] == "null (not observable)"  # issue 28: yaw null without a magnetometer


@needs_log
def test_the_older_layout_gives_the_same_yaw_as_the_newer_one(tmp_path):
    from visnav.analysis.ahrs_check import ahrs_check

    p, *_ = _older_layout(tmp_path)
    old, new = ahrs_check(p, None, None), ahrs_check(LOG, None, None)
    assert old["magnetometer_source"] == "sensor_combined" and new["magnetometer_source"] == "vehicle_magnetometer"
    assert old["yaw_rms_diff_deg"] == pytest.approx(new["yaw_rms_diff_deg"], abs=0.01)
    assert old["yaw_rms_diff_deg"] < 0.5 * old["gyro_only_yaw_rms_diff_deg"]
