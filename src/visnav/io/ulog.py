"""PX4 ULog reader for the INS / AHRS check (pyulog).

Reads the raw IMU (``sensor_combined``: ``gyro_rad[0..2]`` at ``timestamp``, ``accelerometer_m_s2``
at ``timestamp + accelerometer_timestamp_relative``), PX4's own attitude (``vehicle_attitude.q``,
scalar-first, FRD -> NED, at ``timestamp_sample`` when logged) and, when present, the magnetometer
(``vehicle_magnetometer.magnetometer_ga`` or else ``sensor_mag.x/y/z``, or in older logs
``sensor_combined.magnetometer_ga[3]`` at ``timestamp + magnetometer_timestamp_relative``), the
barometric altitude (``vehicle_air_data.baro_alt_meter``, older logs ``sensor_combined.baro_alt_meter``)
and the magnetic declination PX4 used (parameter ``EKF2_MAG_DECL`` [deg]).

A truncated file (a cut download: the last message ends past the end of the file) is read up to
the damage; ``ULogData.truncated`` is set and a note says how much was read (bytes, seconds, topics).

Timestamps are microseconds in the log; here seconds from the first IMU sample (``t0_us`` keeps the
absolute origin). Rows with NaN / inf are dropped, out-of-order or repeated timestamps are sorted /
de-duplicated; each such repair is described in ``ULogData.notes``. A log without the needed topics
is refused with a message naming them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["ULogData", "read_ulog", "clean_series", "REQUIRED_TOPICS"]

REQUIRED_TOPICS = ("sensor_combined", "vehicle_attitude")
_MAG_TOPICS = ("vehicle_magnetometer", "sensor_mag")
_BARO_TOPICS = ("vehicle_air_data",)
_INVALID_REL = 10_000_000  # |relative timestamp| beyond this: PX4's "no sample" marker (INT32 max)


@dataclass
class ULogData:
    path: str
    t0_us: int  # absolute time of t = 0 [us]
    imu_t: np.ndarray  # (N,) [s]
    accel: np.ndarray  # (N, 3) specific force FRD [m/s^2]
    gyro: np.ndarray  # (N, 3) [rad/s]
    att_t: np.ndarray  # (M,) [s]
    att_quat: np.ndarray  # (M, 4) scalar-first, body FRD -> NED
    mag_t: np.ndarray | None = None  # (K,) [s]
    mag: np.ndarray | None = None  # (K, 3) body [gauss]
    declination_deg: float | None = None  # EKF2_MAG_DECL when logged
    notes: list[str] = field(default_factory=list)
    mag_source: str | None = None  # the topic the magnetometer came from (None: not found)
    baro_t: np.ndarray | None = None  # (B,) [s]
    baro_alt: np.ndarray | None = None  # (B,) barometric altitude [m]
    truncated: bool = False  # the file ends inside a message (read up to there)


def clean_series(t_us, values: np.ndarray, what: str, notes: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Drop rows with NaN / inf (in time or values), sort by time, drop repeated timestamps.
    Appends one line per repair to ``notes``; returns (t_us int64, values)."""
    t = np.asarray(t_us, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64).reshape(len(t), -1)
    bad = ~(np.isfinite(t) & np.all(np.isfinite(v), axis=1))
    if bad.any():
        notes.append(f"{what}: dropped {int(bad.sum())} of {len(t)} samples with NaN/inf values")
        t, v = t[~bad], v[~bad]
    back = int(np.sum(np.diff(t) < 0))
    if back:
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        notes.append(f"{what}: {back} out-of-order timestamps, samples re-sorted by time")
    dup = np.r_[False, np.diff(t) == 0]
    if dup.any():
        notes.append(f"{what}: dropped {int(dup.sum())} samples with a repeated timestamp")
        t, v = t[~dup], v[~dup]
    if len(t) < 2:
        raise ValueError(f"{what}: fewer than 2 valid samples in the log")
    return t.astype(np.int64), v


def _cols(d: dict, names: list[str], topic: str) -> np.ndarray:
    missing = [n for n in names if n not in d]
    if missing:
        raise ValueError(f"topic {topic} lacks fields {missing}")
    return np.column_stack([np.asarray(d[n], dtype=np.float64) for n in names])


def ulog_cut(path) -> tuple[bool, int, int]:
    """(the file ends inside a message, its size in bytes, topics subscribed before that), from the
    ULog message headers (16-byte file header, then messages of uint16 size + uint8 type + payload;
    an 'A' message subscribes a topic: uint8 multi_id, uint16 msg_id, name)."""
    b = Path(path).read_bytes()
    n, pos, topics = len(b), 16, set()
    while pos + 3 <= n:
        size = b[pos] | (b[pos + 1] << 8)
        if b[pos + 2] == 0x41 and pos + 3 + size <= n:  # 'A': add logged message
            topics.add(b[pos + 6:pos + 3 + size])
        pos += 3 + size
    return pos != n, n, len(topics)


def _relative_series(d: dict, fields: list[str], rel_field: str, what: str, notes: list[str]):
    """Samples carried inside ``sensor_combined`` (older PX4): stamped ``timestamp + rel`` where
    ``rel`` is valid; repeated stamps (the same sample re-sent with every IMU message) dropped."""
    t = np.asarray(d["timestamp"], dtype=np.int64)
    rel = np.asarray(d.get(rel_field, np.zeros(len(t))), dtype=np.int64)
    ok = np.abs(rel) < _INVALID_REL
    vals = _cols(d, fields, "sensor_combined")[ok]
    ts = t[ok] + rel[ok]
    keep = np.r_[True, np.diff(ts) != 0]  # the held sample repeated: keep its first copy
    return clean_series(ts[keep], vals[keep], what, notes)


def read_ulog(path) -> ULogData:
    """Read a PX4 ULog; raises FileNotFoundError / ValueError with a one-line reason."""
    from pyulog import ULog

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"ULog file not found: {p}")
    try:
        u = ULog(str(p), list(REQUIRED_TOPICS + _MAG_TOPICS + _BARO_TOPICS))
    except Exception as exc:  # pyulog raises bare Exceptions on bad headers
        raise ValueError(f"{p}: not a readable ULog ({exc})") from exc
    cut, size, n_topics = ulog_cut(p)
    notes: list[str] = []
    if cut or u.file_corruption:
        secs = max(0.0, (u.last_timestamp - u.start_timestamp) * 1e-6)
        what = "truncated (it ends inside a message)" if cut else "corrupt in places"
        notes.append(f"the file is {what}: read up to the damage, {size} bytes, {secs:.1f} s of data, "
                     f"{n_topics} topics")
    topics = {d.name: d for d in u.data_list if d.multi_id == 0}
    missing = [tpc for tpc in REQUIRED_TOPICS if tpc not in topics]
    if missing:
        raise ValueError(f"{p.name}: log lacks the topic(s) {', '.join(missing)} needed for the AHRS check"
                         + (f" ({notes[0]})" if notes else ""))
    try:
        out = _extract(p, u, topics, notes)
    except ValueError as exc:
        raise ValueError(f"{exc} ({notes[0]})" if notes and cut else str(exc)) from None
    out.truncated = cut
    return out


def _extract(p: Path, u, topics: dict, notes: list[str]) -> ULogData:
    sc = topics["sensor_combined"].data
    gyro_t = np.asarray(sc["timestamp"], dtype=np.int64)
    rel = np.asarray(sc.get("accelerometer_timestamp_relative", np.zeros(len(gyro_t))), dtype=np.int64)
    gyro = _cols(sc, [f"gyro_rad[{i}]" for i in range(3)], "sensor_combined")
    accel = _cols(sc, [f"accelerometer_m_s2[{i}]" for i in range(3)], "sensor_combined")
    # the accelerometer sample time differs from the gyro's by `rel`; interpolate it onto the gyro
    # time when it does (PX4 reports INT32 max for 'no accel sample in this message')
    ok_rel = np.abs(rel) < _INVALID_REL
    if np.any(rel[ok_rel] != 0):
        acc_t = gyro_t + np.where(ok_rel, rel, 0)
        ta, accel_c = clean_series(acc_t, accel, "sensor_combined accelerometer", notes)
        accel = np.column_stack([np.interp(gyro_t, ta, accel_c[:, i]) for i in range(3)])
        notes.append("sensor_combined: accelerometer interpolated onto the gyro timestamps")
    t_imu, imu = clean_series(gyro_t, np.hstack([accel, gyro]), "sensor_combined", notes)
    va = topics["vehicle_attitude"].data
    att_t = va["timestamp_sample"] if "timestamp_sample" in va else va["timestamp"]
    t_att, q = clean_series(att_t, _cols(va, [f"q[{i}]" for i in range(4)], "vehicle_attitude"),
                            "vehicle_attitude", notes)
    qn = np.linalg.norm(q, axis=1)
    if np.any(np.abs(qn - 1.0) > 1e-3):
        notes.append(f"vehicle_attitude: {int(np.sum(np.abs(qn - 1) > 1e-3))} non-unit quaternions normalised")
    q = q / qn[:, None]
    t0 = int(t_imu[0])
    out = ULogData(str(p), t0, (t_imu - t0) * 1e-6, imu[:, :3], imu[:, 3:], (t_att - t0) * 1e-6, q, notes=notes)
    mag_fields = [f"magnetometer_ga[{i}]" for i in range(3)]
    for name, fields in (("vehicle_magnetometer", mag_fields), ("sensor_mag", ["x", "y", "z"]),
                         ("sensor_combined", mag_fields)):
        if name in topics and all(f in topics[name].data for f in fields):
            md = topics[name].data
            try:
                if name == "sensor_combined":  # older PX4: the magnetometer inside sensor_combined
                    t_mag, mag = _relative_series(md, fields, "magnetometer_timestamp_relative", name, notes)
                else:
                    mt = md["timestamp_sample"] if "timestamp_sample" in md else md["timestamp"]
                    t_mag, mag = clean_series(mt, _cols(md, fields, name), name, notes)
            except ValueError as exc:
                notes.append(f"{name}: unusable ({exc}); no magnetometer")
                continue
            out.mag_t, out.mag, out.mag_source = (t_mag - t0) * 1e-6, mag, name
            break
    else:
        notes.append("no magnetometer (vehicle_magnetometer, sensor_mag, sensor_combined.magnetometer_ga): "
                     "yaw is gyro-only")
    for name in ("vehicle_air_data", "sensor_combined"):
        if name in topics and "baro_alt_meter" in topics[name].data:
            bd = topics[name].data
            try:
                if name == "sensor_combined":
                    tb, alt = _relative_series(bd, ["baro_alt_meter"], "baro_timestamp_relative", name, notes)
                else:
                    bt = bd["timestamp_sample"] if "timestamp_sample" in bd else bd["timestamp"]
                    tb, alt = clean_series(bt, _cols(bd, ["baro_alt_meter"], name), name, notes)
            except ValueError:
                continue
            out.baro_t, out.baro_alt = (tb - t0) * 1e-6, alt[:, 0]
            break
    decl = u.initial_parameters.get("EKF2_MAG_DECL")
    if decl is not None and np.isfinite(decl):
        out.declination_deg = float(decl)
    return out
