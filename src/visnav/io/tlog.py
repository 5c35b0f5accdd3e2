"""MAVLink telemetry logs (``.tlog``, as QGroundControl / Mission Planner / MAVProxy / ``visnav bridge`` write
them) read into a ``Recording``.

A tlog is a sequence of records: an 8-byte big-endian arrival time [us since 1970], then one MAVLink
packet (v1: 0xFE, length, ...; v2: 0xFD, length, incompat flags, ...; 13 more bytes when signed). The
records are walked here and each packet decoded with pymavlink (``common`` dialect, CRC checked).
A cut record ends the reading; bytes that are not a record (garbage inside the file) are skipped to
where records resume (an arrival time not before the last one, a packet whose CRC holds), and the
one-line ``Recording.summary`` names the byte of the damage.

Read (from the vehicle that sent the most IMU / attitude messages, body FRD, NED):

* IMU: ``HIGHRES_IMU`` (m/s^2, rad/s, gauss), else ``SCALED_IMU`` (milli-g, mrad/s, milligauss);
* attitude: ``ATTITUDE`` (rad); GPS: ``GPS_RAW_INT`` (1e-7 deg, mm MSL, cm/s, centi-degree course;
  fixes below 3D left out); barometer: ``SCALED_PRESSURE`` (hPa -> ISA pressure altitude, relative to
  the first sample); ``DISTANCE_SENSOR`` (cm; orientation 25 = down -> ``sonar``, else ``laser``);
  ``OPTICAL_FLOW_RAD`` (integrated flow and gyro over ``integration_time_us`` -> rates);
  ``CAMERA_FEEDBACK`` (image index, position).

Time: the vehicle's own stamp where the message has one on its boot clock (``time_boot_ms``, or
``time_usec`` below 1e11 us); else the arrival time moved onto the boot clock by the median offset
between the two. ``t_s`` = 0 at the first IMU sample.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from visnav.io.recording import Recording, RecordingError
from visnav.io.recording import read_camera_yaml
from visnav.io.streams import camera_stream, flow_stream, gps_stream, heading_stream, mag_field_stream, read_summary, sorted_stream
from visnav.io.ulog import pressure_altitude

__all__ = ["read_tlog", "tlog_records"]

_WANTED = ("HIGHRES_IMU", "SCALED_IMU", "ATTITUDE", "GPS_RAW_INT", "SCALED_PRESSURE", "DISTANCE_SENSOR",
           "OPTICAL_FLOW_RAD", "CAMERA_FEEDBACK")


def _packet_len(b: bytes, p: int) -> int | None:
    """Length of the MAVLink packet at ``p`` (None: not a packet start)."""
    if p + 3 > len(b):
        return None
    if b[p] == 0xFE:
        return 8 + b[p + 1]
    if b[p] == 0xFD:
        return 12 + b[p + 1] + (13 if b[p + 2] & 0x01 else 0)
    return None


def tlog_records(b: bytes, decode):
    """(records [(arrival s, message)], damage byte or None, cut: the file ends inside a record).
    ``decode(packet bytes)`` returns a message or raises."""
    out, n, p, t_last = [], len(b), 0, -np.inf
    damage, cut = None, False
    while p + 9 <= n:
        t_us = struct.unpack_from(">Q", b, p)[0]
        plen = _packet_len(b, p + 8)
        ok = plen is not None and t_us * 1e-6 >= t_last - 1.0
        if ok and p + 8 + plen > n:
            if damage is None:
                damage, cut = p, True
            break
        msg = None
        if ok:
            try:
                msg = decode(bytearray(b[p + 8:p + 8 + plen]))
            except Exception:  # a bad CRC or header: not a record
                msg = None
        if msg is None:
            if damage is None:
                damage = p
            p += 1  # resynchronise: the next offset where a record holds
            continue
        t_last = t_us * 1e-6
        out.append((t_last, msg))
        p += 8 + plen
    if p < n and damage is None:
        damage, cut = p, True  # fewer than 9 bytes left: a cut record
    return out, damage, cut


def read_tlog(path: Path) -> Recording:
    """A MAVLink telemetry log (module docstring)."""
    from pymavlink.dialects.v20 import common


    p = Path(path)
    try:
        b = p.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read ({exc.strerror or exc})") from None
    mav = common.MAVLink(None)
    mav.robust_parsing = True
    records, damage, cut = tlog_records(b, mav.decode)
    if not records:
        raise RecordingError(f"{p}: not a MAVLink telemetry log (no valid record)")
    rows: dict[str, list] = {k: [] for k in _WANTED}
    count: dict[int, int] = {}
    for t_a, m in records:
        name = m.get_type()
        if name in rows:
            rows[name].append((t_a, m))
            if name in ("HIGHRES_IMU", "SCALED_IMU", "ATTITUDE"):
                count[m.get_srcSystem()] = count.get(m.get_srcSystem(), 0) + 1
    if not count:
        raise RecordingError(f"{p}: no HIGHRES_IMU, SCALED_IMU or ATTITUDE messages (the log lacks what every "
                             "navigator needs)")
    sysid = max(count, key=count.get)
    rows = {k: [(t, m) for t, m in v if m.get_srcSystem() == sysid] for k, v in rows.items()}

    def own(m) -> float:
        if hasattr(m, "time_boot_ms"):
            return m.time_boot_ms * 1e-3
        if hasattr(m, "time_usec") and 0 < m.time_usec < 1e11:
            return m.time_usec * 1e-6
        return np.nan

    pairs = [(own(m) - t) for v in rows.values() for t, m in v]
    pairs = [d for d in pairs if np.isfinite(d)]
    offset = float(np.median(pairs)) if pairs else 0.0
    notes: list[str] = []
    if len(count) > 1:
        notes.append(f"{len(count)} systems in the log: system {sysid} read (most IMU / attitude messages)")

    def times(v) -> np.ndarray:
        return np.array([own(m) if np.isfinite(own(m)) else t + offset for t, m in v])

    imu_name = "HIGHRES_IMU" if rows["HIGHRES_IMU"] else "SCALED_IMU" if rows["SCALED_IMU"] else None
    if imu_name is None:
        raise RecordingError(f"{p}: no HIGHRES_IMU or SCALED_IMU messages from system {sysid}")
    v = rows[imu_name]
    t_imu = times(v)
    t0 = float(np.nanmin(t_imu))
    f = 1.0 if imu_name == "HIGHRES_IMU" else None
    acc = np.array([[m.xacc, m.yacc, m.zacc] for _, m in v], float) * (1.0 if f else 9.80665e-3)  # milli-g
    gyr = np.array([[m.xgyro, m.ygyro, m.zgyro] for _, m in v], float) * (1.0 if f else 1e-3)  # mrad/s
    mag = np.array([[m.xmag, m.ymag, m.zmag] for _, m in v], float) * (1.0 if f else 1e-3)  # milligauss
    streams: dict[str, dict] = {}
    streams["imu"] = sorted_stream({"t_s": t_imu - t0, **{f"a{a}_mps2": acc[:, i] for i, a in enumerate("xyz")},
                                    **{f"g{a}_radps": gyr[:, i] for i, a in enumerate("xyz")}}, notes, imu_name)
    if np.any(np.abs(mag) > 0):
        streams["mag_field"] = sorted_stream(mag_field_stream(t_imu - t0, mag), notes, imu_name + " magnetometer")
    if rows["ATTITUDE"]:
        v = rows["ATTITUDE"]
        e = np.array([[m.roll, m.pitch, m.yaw] for _, m in v], float)
        streams["attitude"] = sorted_stream({"t_s": times(v) - t0, "roll_rad": e[:, 0], "pitch_rad": e[:, 1],
                                             "yaw_rad": np.angle(np.exp(1j * e[:, 2]))}, notes, "ATTITUDE")
    if "attitude" in streams and "mag_field" in streams:
        mf = streams["mag_field"]
        streams["magnetometer"] = heading_stream(mf["t_s"], np.column_stack([mf["mx_ga"], mf["my_ga"], mf["mz_ga"]]),
                                                 streams["attitude"])
    gps = [(t, m) for t, m in rows["GPS_RAW_INT"] if m.fix_type >= 3 and (m.lat or m.lon)]
    if len(gps) >= 2:
        lla = np.array([[m.lat * 1e-7, m.lon * 1e-7, m.alt * 1e-3] for _, m in gps])
        vel = None
        if all(m.vel != 65535 and m.cog != 65535 for _, m in gps):  # UINT16_MAX: unknown
            spd = np.array([m.vel for _, m in gps]) * 0.01
            cog = np.radians(np.array([m.cog for _, m in gps]) * 0.01)
            vel = np.column_stack([spd * np.cos(cog), spd * np.sin(cog), np.full(len(gps), np.nan)])
        t_g = times(gps) - t0
        g = gps_stream(t_g, lla[:, 0], lla[:, 1], lla[:, 2])
        if vel is not None:  # horizontal velocity from the receiver, vertical from the altitudes
            g["vn_mps"], g["ve_mps"] = vel[:, 0], vel[:, 1]
        streams["gps"] = sorted_stream(g, notes, "GPS_RAW_INT")
    elif rows["GPS_RAW_INT"]:
        notes.append("GPS_RAW_INT: fewer than 2 fixes with a 3D fix")
    if rows["SCALED_PRESSURE"]:
        v = rows["SCALED_PRESSURE"]
        alt = pressure_altitude(np.array([m.press_abs for _, m in v], float) * 100.0)
        streams["baro"] = sorted_stream({"t_s": times(v) - t0, "altitude_m": alt - alt[0]}, notes, "SCALED_PRESSURE")
    if rows["DISTANCE_SENSOR"]:
        v = rows["DISTANCE_SENSOR"]
        d = np.array([[m.current_distance, m.min_distance, m.max_distance, m.orientation] for _, m in v], float)
        ok = (d[:, 0] >= d[:, 1]) & (d[:, 0] <= d[:, 2]) & (d[:, 0] > 0)
        streams["range"] = sorted_stream({"t_s": times(v) - t0, "range_m": np.where(ok, d[:, 0] * 0.01, np.nan),
                                          "sensor": np.where(d[:, 3] == 25, "sonar", "laser")}, notes,
                                         "DISTANCE_SENSOR")
    fl = [(t, m) for t, m in rows["OPTICAL_FLOW_RAD"] if m.integration_time_us > 0]
    if fl:
        dt = np.array([m.integration_time_us for _, m in fl], float) * 1e-6
        f = np.array([[m.integrated_x, m.integrated_y, m.integrated_xgyro, m.integrated_ygyro] for _, m in fl],
                     float) / dt[:, None]
        q = np.array([m.quality for _, m in fl], float)
        dist = np.array([m.distance if m.distance > 0 else np.nan for _, m in fl], float)
        streams["optical_flow"] = sorted_stream(flow_stream(times(fl) - t0, np.column_stack([f, q]), dist), notes,
                                                "OPTICAL_FLOW_RAD")
    if rows["CAMERA_FEEDBACK"]:  # its time_usec is UTC: the arrival time is used
        v = rows["CAMERA_FEEDBACK"]
        lla = np.array([[m.lat * 1e-7, m.lng * 1e-7, m.alt_msl] for _, m in v], float)
        streams["camera_trigger"] = sorted_stream(camera_stream(np.array([t + offset for t, _ in v]) - t0,
                                                                 np.array([m.img_idx for _, m in v]), lla), notes,
                                                  "CAMERA_FEEDBACK")
    cam = p.parent / "camera.yaml"
    rec = Recording(p, read_camera_yaml(cam) if cam.is_file() else None, streams)
    s = streams["imu"]["t_s"]
    parts = [f"{imu_name} {s[-1] - s[0]:.1f} s ({len(s)} samples, system {sysid})"]
    for key, label in (("attitude", "ATTITUDE"), ("gps", "GPS_RAW_INT"), ("baro", "SCALED_PRESSURE"),
                       ("range", "DISTANCE_SENSOR"), ("optical_flow", "OPTICAL_FLOW_RAD"),
                       ("camera_trigger", "CAMERA_FEEDBACK")):
        if key in streams:
            parts.append(f"{label} {len(streams[key]['t_s'])}")
    rec.summary = read_summary(p.name, float(s[-1] - s[0]), len(b), damage, cut, parts)
    rec.notes += notes
    return rec
