"""PX4 ULog reader (pyulog): the raw sensors, PX4's attitude and the events of every log generation.

Read, whichever of them the log has (each layout of PX4's history):

* IMU: ``sensor_combined`` (``gyro_rad[0..2]`` at ``timestamp``, ``accelerometer_m_s2`` at ``timestamp +
  accelerometer_timestamp_relative``), or, in a log without it, the separate ``sensor_gyro`` and
  ``sensor_accel`` topics (instance 0, ``x/y/z`` at ``timestamp_sample``; the accelerometer interpolated
  onto the gyro's times). A log at ~1 Hz (PX4's low-rate logging profile) is read like any other.
* attitude: ``vehicle_attitude.q`` (scalar-first, FRD -> NED, at ``timestamp_sample`` when logged).
* magnetometer: ``vehicle_magnetometer.magnetometer_ga``, ``sensor_mag.x/y/z``, or in older logs
  ``sensor_combined.magnetometer_ga[3]`` at ``timestamp + magnetometer_timestamp_relative``; the
  declination PX4 used (parameter ``EKF2_MAG_DECL`` [deg]).
* barometer: ``vehicle_air_data.baro_alt_meter``, older ``sensor_combined.baro_alt_meter``, else
  ``sensor_baro.pressure`` turned into a pressure altitude (ISA, eq. below).
* GPS: ``vehicle_gps_position``, else ``sensor_gps``: latitude / longitude / altitude in either
  generation's fields (``lat``/``lon`` [1e-7 deg], ``alt`` [mm]; or ``latitude_deg``, ``longitude_deg``,
  ``altitude_msl_m``), NED velocity when ``vel_ned_valid``; fixes below a 3D fix (``fix_type`` < 3) dropped.
* ``distance_sensor`` (``current_distance``, ``orientation``: 25 = downward), optical flow
  (``vehicle_optical_flow``, ``sensor_optical_flow`` or the older ``optical_flow``: integrated flow and
  gyro over ``integration_timespan``, turned into rates), camera events (``camera_capture``, else
  ``camera_trigger``: sequence number, and the position where the capture message has it).

A field whose every sample is invalid (PX4's INT32-max "no sample" relative stamp, NaN) leaves its
stream out with a note. A damaged file (a cut download: the last message ends past the end of the file;
or bytes that are not ULog messages) is read to the damage (pyulog resynchronises past garbage when
it can); ``ULogData.truncated`` is set and ``ULogData.summary`` says in one line what was read.

Timestamps are microseconds in the log; here seconds from the first IMU sample (``t0_us`` keeps the
absolute origin). Rows with NaN / inf are dropped, out-of-order or repeated timestamps are sorted /
de-duplicated; each such repair is described in ``ULogData.notes``. A log without an IMU or an
attitude is refused with a message naming the topics.
"""

from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import struct
from visnav.io.streams import read_summary

__all__ = ["ULogData", "read_ulog", "clean_series", "ulog_damage", "REQUIRED_TOPICS"]

REQUIRED_TOPICS = ("sensor_combined", "vehicle_attitude")
_IMU_TOPICS = ("sensor_gyro", "sensor_accel")
_MAG_TOPICS = ("vehicle_magnetometer", "sensor_mag")
_BARO_TOPICS = ("vehicle_air_data", "sensor_baro")
_GPS_TOPICS = ("vehicle_gps_position", "sensor_gps")
_EVENT_TOPICS = ("distance_sensor", "vehicle_optical_flow", "sensor_optical_flow", "optical_flow", "camera_capture",
                 "camera_trigger")
_INVALID_REL = 10_000_000  # |relative timestamp| beyond this: PX4's "no sample" marker (INT32 max)
_MSG_TYPES = frozenset(b"BFIMPQALRDCSO")  # the ULog message types (a byte outside them: not a message)


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
    baro_alt: np.ndarray | None = None  # (B,) barometric altitude [m] (above sea level, as PX4 logs it)
    truncated: bool = False  # the file is damaged (cut, or garbage inside): read up to there
    imu_source: str = "sensor_combined"
    baro_source: str | None = None
    gps_source: str | None = None
    gps_t: np.ndarray | None = None  # (G,) [s]
    gps_lla: np.ndarray | None = None  # (G, 3) latitude [deg], longitude [deg], altitude MSL [m]
    gps_vel: np.ndarray | None = None  # (G, 3) NED [m/s], None: not logged (central differences later)
    range_t: np.ndarray | None = None  # distance_sensor
    range_m: np.ndarray | None = None  # (R,) [m], nan = no valid return
    range_down: np.ndarray | None = None  # (R,) bool: orientation downward (25)
    flow_t: np.ndarray | None = None  # optical flow
    flow: np.ndarray | None = None  # (F, 5): flow x, y [rad/s], body rate x, y [rad/s], quality (0..255)
    flow_source: str | None = None
    flow_dist: np.ndarray | None = None  # (F,) distance the flow sensor reports [m] (nan: none)
    cam_t: np.ndarray | None = None  # camera trigger / capture events [s]
    cam_seq: np.ndarray | None = None
    cam_lla: np.ndarray | None = None  # (C, 3) where camera_capture logs it, else None
    cam_source: str | None = None
    gps_no_fix: int = 0  # GPS messages without a 3D fix (left out)
    summary: str = ""  # one line: what was read, to the end or to the damage


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
    dup = np.r_[False, np.diff(t) == 0][: len(t)]
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


def ulog_damage(path) -> tuple[int | None, int, int]:
    """(the byte offset where the ULog stops being a sequence of messages, None when it reads to its
    end; its size in bytes; topics subscribed before that), from the message headers (16-byte file
    header, then messages of uint16 size + uint8 type + payload; an 'A' message subscribes a topic:
    uint8 multi_id, uint16 msg_id, name). The damage is a message cut by the end of the file or a
    byte that is not a message type. Appended data (the flag-bits message's ``appended_offsets``): a
    message that runs past the next offset is the logger's unfinished one; reading goes on at the offset."""

    b = Path(path).read_bytes()
    n, pos, topics, appended = len(b), 16, set(), []
    if n >= 16 + 3 + 40 and b[18] == 0x42:  # 'B' flag bits: compat[8], incompat[8], appended_offsets[3]
        appended = sorted(o for o in struct.unpack_from("<3Q", b, 19 + 16) if 16 < o <= n)
    while pos + 3 <= n:
        size, kind = b[pos] | (b[pos + 1] << 8), b[pos + 2]
        if appended and pos + 3 + size > appended[0] >= pos:
            pos = appended.pop(0)
            continue
        if kind not in _MSG_TYPES or pos + 3 + size > n:
            return pos, n, len(topics)
        if kind == 0x41:  # 'A': add logged message
            topics.add(b[pos + 6:pos + 3 + size])
        pos += 3 + size
    return (None if pos == n else pos), n, len(topics)


def ulog_cut(path) -> tuple[bool, int, int]:
    """(the file is damaged, its size in bytes, topics subscribed before the damage): ``ulog_damage``."""
    at, n, topics = ulog_damage(path)
    return at is not None, n, topics


def _relative_series(d: dict, fields: list[str], rel_field: str, what: str, notes: list[str]):
    """Samples carried inside ``sensor_combined`` (older PX4): stamped ``timestamp + rel`` where
    ``rel`` is valid; repeated stamps (the same sample re-sent with every IMU message) dropped.
    Raises ValueError (fewer than 2 samples) when every sample of the field is invalid."""
    t = np.asarray(d["timestamp"], dtype=np.int64)
    rel = np.asarray(d.get(rel_field, np.zeros(len(t))), dtype=np.int64)
    ok = np.abs(rel) < _INVALID_REL
    vals = _cols(d, fields, "sensor_combined")[ok]
    ts = t[ok] + rel[ok]
    keep = np.r_[True, np.diff(ts) != 0][: len(ts)]  # the held sample repeated: keep its first copy
    return clean_series(ts[keep], vals[keep], what, notes)


def _stamp(d: dict) -> np.ndarray:
    """``timestamp_sample`` (the instant the sample describes) when logged and filled, else ``timestamp``
    (some drivers leave ``timestamp_sample`` at 0: PX4 1.14's GPS topics)."""
    ts = d.get("timestamp_sample")
    return ts if ts is not None and len(ts) and np.all(np.asarray(ts) > 0) else d["timestamp"]


def read_ulog(path) -> ULogData:
    """Read a PX4 ULog; raises FileNotFoundError / ValueError with a one-line reason."""
    from pyulog import ULog

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"ULog file not found: {p}")
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # pyulog prints its corruption warnings
            u = ULog(str(p), list(REQUIRED_TOPICS + _IMU_TOPICS + _MAG_TOPICS + _BARO_TOPICS + _GPS_TOPICS
                                  + _EVENT_TOPICS))
    except Exception as exc:  # pyulog raises bare Exceptions on bad headers
        raise ValueError(f"{p}: not a readable ULog ({exc})") from exc
    at, size, n_topics = ulog_damage(p)
    damaged = at is not None or bool(u.file_corruption)
    notes: list[str] = []
    if damaged:
        secs = max(0.0, (u.last_timestamp - u.start_timestamp) * 1e-6)
        cut = at is not None and _cut_at_end(p, at, size)
        what = ("truncated (it ends inside a message)" if cut else f"corrupt from byte {at}" if at
                else "corrupt in places")
        notes.append(f"the file is {what}: read up to the damage, {size} bytes, {secs:.1f} s of data, "
                     f"{n_topics} topics")
    topics = {d.name: d for d in u.data_list if d.multi_id == 0}
    has_imu = "sensor_combined" in topics or all(t in topics for t in _IMU_TOPICS)
    missing = [t for t in REQUIRED_TOPICS if t not in topics and (t != "sensor_combined" or not has_imu)]
    if missing:
        raise ValueError(f"{p.name}: log lacks the topic(s) {', '.join(missing)} needed for the AHRS check"
                         + (" (or sensor_gyro + sensor_accel for the IMU)" if "sensor_combined" in missing else "")
                         + (f" ({notes[0]})" if notes else ""))
    try:
        out = _extract(p, u, topics, notes)
    except ValueError as exc:
        raise ValueError(f"{exc} ({notes[0]})" if notes and damaged else str(exc)) from None
    out.truncated = damaged
    dur = float(out.imu_t[-1] - out.imu_t[0])
    if damaged:  # the IMU's span, not pyulog's (a message stamped long after the data ends would count)
        notes[0] = notes[0].replace(f"{secs:.1f} s of data", f"{dur:.1f} s of data")
    parts = [f"IMU {dur:.1f} s ({len(out.imu_t)} samples, {out.imu_source})"]
    for name, t, src in (("GPS", out.gps_t, out.gps_source), ("baro", out.baro_t, out.baro_source),
                         ("magnetometer", out.mag_t, out.mag_source), ("range", out.range_t, "distance_sensor"),
                         ("optical flow", out.flow_t, out.flow_source), ("camera events", out.cam_t, out.cam_source)):
        if t is not None:
            extra = f"; {out.gps_no_fix} more without a 3D fix" if name == "GPS" and out.gps_no_fix else ""
            parts.append(f"{name} {len(t)} ({src}{extra})")

    cut = at is not None and _cut_at_end(p, at, size)
    if damaged and at is None:
        parts.insert(0, "pyulog found corrupt messages")
    out.summary = read_summary(p.name, dur, size, at, cut, parts)
    return out


def _cut_at_end(p: Path, at: int, size: int) -> bool:
    """The message at ``at`` is whole-typed but runs past the end of the file (a cut download)."""
    with open(p, "rb") as fh:
        fh.seek(at)
        h = fh.read(3)
    return len(h) < 3 or (h[2] in _MSG_TYPES and at + 3 + (h[0] | (h[1] << 8)) > size)


def _imu(topics: dict, notes: list[str]) -> tuple[np.ndarray, np.ndarray, str]:
    """(t_us, [accel | gyro] (N, 6), source) from sensor_combined, else sensor_gyro + sensor_accel."""
    if "sensor_combined" in topics:
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
        t, imu = clean_series(gyro_t, np.hstack([accel, gyro]), "sensor_combined", notes)
        return t, imu, "sensor_combined"
    g, a = topics["sensor_gyro"].data, topics["sensor_accel"].data
    tg, gyro = clean_series(_stamp(g), _cols(g, ["x", "y", "z"], "sensor_gyro"), "sensor_gyro", notes)
    ta, acc = clean_series(_stamp(a), _cols(a, ["x", "y", "z"], "sensor_accel"), "sensor_accel", notes)
    inside = (tg >= ta[0]) & (tg <= ta[-1])
    accel = np.column_stack([np.interp(tg[inside], ta, acc[:, i]) for i in range(3)])
    notes.append("no sensor_combined: IMU from sensor_gyro + sensor_accel (instance 0), the accelerometer "
                 "interpolated onto the gyro timestamps")
    return tg[inside], np.hstack([accel, gyro[inside]]), "sensor_gyro+sensor_accel"


def _extract(p: Path, u, topics: dict, notes: list[str]) -> ULogData:
    t_imu, imu, imu_source = _imu(topics, notes)
    va = topics["vehicle_attitude"].data
    t_att, q = clean_series(_stamp(va), _cols(va, [f"q[{i}]" for i in range(4)], "vehicle_attitude"),
                            "vehicle_attitude", notes)
    qn = np.linalg.norm(q, axis=1)
    if np.any(np.abs(qn - 1.0) > 1e-3):
        notes.append(f"vehicle_attitude: {int(np.sum(np.abs(qn - 1) > 1e-3))} non-unit quaternions normalised")
    q = q / qn[:, None]
    t0 = int(t_imu[0])
    sec = lambda t: (np.asarray(t, np.int64) - t0) * 1e-6  # noqa: E731
    out = ULogData(str(p), t0, sec(t_imu), imu[:, :3], imu[:, 3:], sec(t_att), q, notes=notes, imu_source=imu_source)
    mag_fields = [f"magnetometer_ga[{i}]" for i in range(3)]
    for name, fields in (("vehicle_magnetometer", mag_fields), ("sensor_mag", ["x", "y", "z"]),
                         ("sensor_combined", mag_fields)):
        if name in topics and all(f in topics[name].data for f in fields):
            md = topics[name].data
            try:
                if name == "sensor_combined":  # older PX4: the magnetometer inside sensor_combined
                    t_mag, mag = _relative_series(md, fields, "magnetometer_timestamp_relative", name, notes)
                else:
                    t_mag, mag = clean_series(_stamp(md), _cols(md, fields, name), name, notes)
            except ValueError as exc:
                notes.append(f"{name}: unusable ({exc}); no magnetometer")
                continue
            out.mag_t, out.mag, out.mag_source = sec(t_mag), mag, name
            break
    else:
        notes.append("no magnetometer (vehicle_magnetometer, sensor_mag, sensor_combined.magnetometer_ga): "
                     "yaw is gyro-only")
    _baro(out, topics, notes, sec)
    _gps(out, topics, notes, sec)
    _events(out, topics, notes, sec)
    decl = u.initial_parameters.get("EKF2_MAG_DECL")
    if decl is not None and np.isfinite(decl):
        out.declination_deg = float(decl)
    return out


def pressure_altitude(p_pa) -> np.ndarray:
    """ISA pressure altitude [m] of a static pressure [Pa]: h = T0/L (1 - (p/p0)^(R L / g)), T0 = 288.15 K,
    L = 0.0065 K/m, p0 = 101325 Pa, R L / g = 0.190263 (the troposphere of the standard atmosphere)."""
    return 288.15 / 0.0065 * (1.0 - (np.asarray(p_pa, float) / 101325.0) ** 0.190263)


def _baro(out: ULogData, topics: dict, notes: list[str], sec) -> None:
    for name in ("vehicle_air_data", "sensor_combined", "sensor_baro"):
        d = topics[name].data if name in topics else None
        if d is None or ("baro_alt_meter" not in d and "pressure" not in d):
            continue
        try:
            if name == "sensor_combined":
                tb, alt = _relative_series(d, ["baro_alt_meter"], "baro_timestamp_relative", name, notes)
            elif name == "sensor_baro":
                pr = _cols(d, ["pressure"], name)
                pr = pr * (100.0 if np.nanmedian(pr) < 2000 else 1.0)  # older PX4 logs the pressure in mbar
                tb, alt = clean_series(_stamp(d), pressure_altitude(pr), name, notes)
            else:
                tb, alt = clean_series(_stamp(d), _cols(d, ["baro_alt_meter"], name), name, notes)
        except ValueError as exc:
            notes.append(f"{name}: no barometer from it ({exc})")
            continue
        out.baro_t, out.baro_alt, out.baro_source = sec(tb), alt[:, 0], name
        return


def _gps(out: ULogData, topics: dict, notes: list[str], sec) -> None:
    for name in _GPS_TOPICS:
        d = topics[name].data if name in topics else None
        if d is None:
            continue
        if "latitude_deg" in d:
            lla = _cols(d, ["latitude_deg", "longitude_deg", "altitude_msl_m"], name)
        elif "lat" in d:
            lla = _cols(d, ["lat", "lon", "alt"], name) * np.array([1e-7, 1e-7, 1e-3])
        else:
            notes.append(f"{name}: no latitude / longitude fields")
            continue
        vel_f = ["vel_n_m_s", "vel_e_m_s", "vel_d_m_s"]
        has_vel = all(f in d for f in vel_f) and ("vel_ned_valid" not in d or np.all(d["vel_ned_valid"][:] != 0))
        vals = np.hstack([lla, _cols(d, vel_f, name)]) if has_vel else lla
        fix = np.asarray(d.get("fix_type", np.full(len(lla), 3)))
        ok = (fix >= 3) & (np.abs(lla[:, 0]) > 1e-6)  # 3D fix or better; (0, 0) = no position
        out.gps_no_fix = int((~ok).sum())  # not a repair: the receiver had no 3D fix yet (in the summary)
        try:
            tg, v = clean_series(np.asarray(_stamp(d))[ok], vals[ok], name, notes)
        except ValueError as exc:
            notes.append(f"{name}: no GPS from it ({exc})")
            continue
        out.gps_t, out.gps_lla, out.gps_source = sec(tg), v[:, :3], name
        out.gps_vel = v[:, 3:6] if has_vel else None
        return


def _events(out: ULogData, topics: dict, notes: list[str], sec) -> None:
    d = topics["distance_sensor"].data if "distance_sensor" in topics else None
    if d is not None and "current_distance" in d:
        dist = np.asarray(d["current_distance"], float)
        lo = np.asarray(d.get("min_distance", np.zeros(len(dist))), float)
        hi = np.asarray(d.get("max_distance", np.full(len(dist), np.inf)), float)
        down = np.asarray(d.get("orientation", np.full(len(dist), 25))) == 25
        try:
            tr, v = clean_series(d["timestamp"], np.column_stack([dist, down]), "distance_sensor", notes)
            out.range_t = sec(tr)
            lo_, hi_ = np.interp(tr, d["timestamp"], lo), np.interp(tr, d["timestamp"], hi)
            out.range_m = np.where((v[:, 0] >= lo_) & (v[:, 0] <= hi_) & (v[:, 0] > 0), v[:, 0], np.nan)
            out.range_down = v[:, 1] > 0.5
        except ValueError as exc:
            notes.append(f"distance_sensor: no range from it ({exc})")
    for name, fx, fy, gx, gy, span, qual, dist in (
            ("vehicle_optical_flow", "pixel_flow[0]", "pixel_flow[1]", "delta_angle[0]", "delta_angle[1]",
             "integration_timespan_us", "quality", "distance_m"),
            ("sensor_optical_flow", "pixel_flow[0]", "pixel_flow[1]", "delta_angle[0]", "delta_angle[1]",
             "integration_timespan_us", "quality", "distance_m"),
            ("optical_flow", "pixel_flow_x_integral", "pixel_flow_y_integral", "gyro_x_rate_integral",
             "gyro_y_rate_integral", "integration_timespan", "quality", "ground_distance_m")):
        d = topics[name].data if name in topics else None
        if d is None or not all(f in d for f in (fx, fy, gx, gy, span)):
            continue
        dt = np.asarray(d[span], float) * 1e-6
        dt = np.where(dt > 0, dt, np.nan)  # no integration interval: no rate (the row is dropped)
        q = np.asarray(d.get(qual, np.full(len(dt), 255)), float)
        rng = np.asarray(d.get(dist, np.full(len(dt), -1.0)), float)
        rng = np.where(np.isfinite(rng) & (rng > 0), rng, -1.0)  # no distance: -1 here (NaN would drop the row)
        rates = np.column_stack([np.asarray(d[f], float) / dt for f in (fx, fy, gx, gy)] + [q])
        good = np.all(np.isfinite(rates), axis=1)
        try:
            tf, v = clean_series(np.asarray(_stamp(d))[good], np.column_stack([rates, rng])[good], name, [])
        except ValueError as exc:
            notes.append(f"{name}: no optical flow from it ({exc})")
            continue
        out.flow_t, out.flow, out.flow_source = sec(tf), v[:, :5], name
        out.flow_dist = np.where(v[:, 5] > 0, v[:, 5], np.nan)
        break
    for name in ("camera_capture", "camera_trigger"):
        d = topics[name].data if name in topics else None
        if d is None or "seq" not in d or len(d["timestamp"]) == 0:
            continue
        t = np.asarray(d["timestamp"], np.int64)
        o = np.argsort(t, kind="stable")
        out.cam_t, out.cam_seq, out.cam_source = sec(t[o]), np.asarray(d["seq"], np.int64)[o], name
        if all(f in d for f in ("lat", "lon", "alt")):
            out.cam_lla = np.column_stack([np.asarray(d[f], float)[o] for f in ("lat", "lon", "alt")])
        break
