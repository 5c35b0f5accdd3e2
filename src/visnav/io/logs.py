"""Flight logs read directly into a ``Recording`` (the same streams and columns as the folder format).

* ArduPilot DataFlash ``.bin`` of either era (pymavlink's ``DFReader`` indexes the messages and parses the
  FMT formats; each message type is then decoded at once with numpy from the indexed offsets): stamped in
  ``TimeUS`` (ArduPilot >= 3.3) or ``TimeMS`` (older; the older GPS message's ``TimeMS`` is GPS time of week
  and its ``T`` the boot time), FMTU multipliers applied where the log has them (else the format char's own;
  MAG then in milligauss). IMU (instance 0; else IMU2 / IMU3), ATT (else AHR2, XKF1 / NKF1 core 0, EKF1),
  BARO, MAG (else MAG2), GPS (3D fix), RFND, OF, CAM (else TRIG; an older CAM stamped only in GPS time is
  put on the boot clock through the GPS messages).
* ROS 1 / ROS 2 bags without ROS (``rosbags``): sensor_msgs Imu, NavSatFix, Range, Image,
  CompressedImage. ROS body axes are FLU and world axes ENU (REP 103); they are turned into FRD / NED.
  The bag's receive time is the delivery time (``t_recv_s``), the header stamp the instant (``t_s``).
* PX4 ULog through ``io/ulog.py`` (IMU, attitude, magnetometer, GPS, baro, distance sensor, optical flow,
  camera events); MAVLink ``.tlog`` through ``io/tlog.py``.

Every log reader reads to the end of the file or to the damage and says in one line what it read
(``Recording.summary``: seconds, the byte of the damage, the message counts).
Positions from latitude / longitude are NED about the first fix; a magnetometer's field becomes a
tilt-compensated heading with the attitude of the log (declination added when the log has it).
A ``camera.yaml`` beside the log (same folder) describes the camera of a bag's images.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from visnav.geometry.rotations import dcm_to_euler
from visnav.io.recording import Recording, RecordingError, read_camera_yaml
from visnav.io.streams import (camera_stream, flow_stream, gps_stream, heading_stream, mag_field_stream,
                                read_summary, sorted_stream)
from visnav.io.euroc import is_euroc, read_euroc
from visnav.io.photos import is_photo_folder, read_photos
from visnav.io.tlog import read_tlog
import struct
import re
from visnav.io.ulog import read_ulog
import os
import sys
import contextlib
import io


def open_recording(path: str | Path, allow_truncated: bool = False) -> Recording:
    """A recording folder (or a ``visnav bridge`` log folder: its ``recording/``), a DataFlash ``.bin``, a PX4
    ``.ulg``, a MAVLink ``.tlog`` (io/tlog.py), an EuRoC / ASL folder (io/euroc.py), a folder of geotagged photos
    (io/photos.py) or a ROS bag (``.bag`` / ROS 2 folder); ``allow_truncated``: a folder's CSV cut while written is
    read up to its first short row."""
    p = Path(path)
    if p.is_dir() and (p / "bridge.tlog").is_file() and (p / "recording").is_dir():  # a `visnav bridge` log folder
        p = p / "recording"

    if is_euroc(p):  # the EuRoC / ASL dataset layout (mav0/imu0, cam0, ground truth)
        return read_euroc(p)
    if p.is_dir() and not (p / "metadata.yaml").is_file():
        return read_photos(p) if is_photo_folder(p) else Recording.open(p, allow_truncated)
    if not p.exists():
        raise RecordingError(f"{p}: no such recording folder or log")
    suffix = p.suffix.lower()
    if suffix == ".bin":
        return read_dataflash(p)
    if suffix == ".ulg":
        return read_px4(p)
    if suffix == ".tlog":
        return read_tlog(p)
    if suffix in (".bag", ".db3", ".mcap") or p.is_dir():
        return read_rosbag(p.parent if suffix in (".db3", ".mcap") else p)
    raise RecordingError(f"{p}: not a recording folder, .ulg, .bin, .tlog or ROS bag")


def _camera_beside(p: Path):
    f = p.parent / "camera.yaml" if not p.is_dir() else p / "camera.yaml"
    return read_camera_yaml(f) if f.is_file() else None


# ------------------------------------------------------------------------------------------ DataFlash
_NP = {"b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4", "f": "<f4", "d": "<f8", "q": "<i8",
       "Q": "<u8", "e": "<f2"}


_BUILTIN_MULT = frozenset("cCeEL")  # format chars pymavlink already scales (centi-units, 1e-7 degrees)


def _df_fmtu(reader) -> dict[int, str]:
    """FMTU: message type -> its multiplier ids (one char per column; MULT maps a char to a factor)."""

    fmt = next((f for f in reader.formats.values() if f.name == "FMTU"), None)
    if fmt is None or fmt.type >= len(reader.offsets) or "MultIds" not in fmt.colhash:
        return {}
    out = {}
    for ofs in reader.offsets[fmt.type]:
        body = reader.data_map[ofs + 3:ofs + fmt.len]
        if len(body) + 3 < fmt.len:
            break
        el = struct.unpack(fmt.msg_struct, body)
        out[int(el[fmt.colhash["FmtType"]])] = el[fmt.colhash["MultIds"]].split(b"\0")[0].decode("ascii", "replace")
    return out


def _df_type(reader, name: str, notes: list, fmtu: dict | None = None) -> dict[str, np.ndarray] | None:
    """All messages of one DataFlash type as columns, or None if absent. Multipliers applied: the format
    char's own (c, C, e, E: x0.01; L: x1e-7), else the FMTU one where the log has it (the time columns
    stay in their raw units). ``out["_fmtu"]`` (0-d) says whether FMTU described the type."""

    fmt = next((f for f in reader.formats.values() if f.name == name), None)
    if fmt is None or fmt.type >= len(reader.offsets) or not reader.offsets[fmt.type]:
        return None
    fields = re.findall(r"(\d*)([a-zA-Z])", fmt.msg_struct[1:])
    dt = np.dtype([(c, f"S{n}" if s == "s" else _NP[s]) for c, (n, s) in zip(fmt.columns, fields)])
    offs = np.asarray(reader.offsets[fmt.type], np.int64) + 3
    whole = offs + dt.itemsize <= reader.data_len
    if not whole.all():  # a message cut by the end of the file (a truncated log) is not read
        notes.append(f"{name}: log truncated; read {int(whole.sum())} messages, the last one was cut and is dropped")
        offs = offs[whole]
    buf = np.frombuffer(reader.data_map, np.uint8)
    rec = buf[offs[:, None] + np.arange(dt.itemsize)].copy().view(dt).ravel()
    mult_ids = (fmtu or {}).get(fmt.type)
    out = {}
    for i, (c, mul) in enumerate(zip(fmt.columns, fmt.msg_mults)):
        v = rec[c]
        raw_units = mul is None and c not in ("TimeUS", "TimeMS", "T") and v.dtype.kind in "iuf"
        if raw_units and mult_ids and i < len(mult_ids):
            mul = reader.mult_lookup.get(mult_ids[i])
            mul = None if mul in (None, 0.0, 1.0) else mul
        out[c] = v.astype(float) * mul if mul is not None else v
    out["_fmtu"] = np.array(bool(mult_ids))
    out["_format"] = np.array(fmt.format)
    return out


def _df_damage(reader) -> tuple[int | None, bool]:
    """(the byte where the log stops being a sequence of messages, None when it reads to the end; whether
    that is a message cut by the end of the file): each message is 0xA3 0x95, its type, then the rest of
    the length its FMT gives."""
    data, n, lengths = reader.data_map, reader.data_len, {t: f.len for t, f in reader.formats.items()}
    ofs = 0
    while ofs + 3 <= n:
        if data[ofs] != 0xA3 or data[ofs + 1] != 0x95 or data[ofs + 2] not in lengths:
            return ofs, False
        if ofs + lengths[data[ofs + 2]] > n:
            return ofs, True
        ofs += lengths[data[ofs + 2]]
    return (None, False) if ofs == n else (ofs, True)


def _df_time(d: dict) -> np.ndarray:
    """A DataFlash message's boot time [s]: ``TimeUS`` [us] (ArduPilot >= 3.3), else the older ``T`` [ms]
    of GPS messages (whose ``TimeMS`` is the GPS time of week), else ``TimeMS`` [ms]."""
    if "TimeUS" in d:
        return d["TimeUS"].astype(float) * 1e-6
    if "T" in d and "TimeMS" in d:
        return d["T"].astype(float) * 1e-3
    if "TimeMS" in d:
        return d["TimeMS"].astype(float) * 1e-3
    raise KeyError("no TimeUS / TimeMS column")


def read_dataflash(path: Path) -> Recording:
    """An ArduPilot DataFlash log of either era (module docstring)."""
    try:
        from pymavlink.DFReader import DFReader_binary

        with _quiet():
            reader = DFReader_binary(str(path))  # it prints per bad byte; the damage is located below
    except Exception as exc:  # pymavlink raises bare Exceptions on damaged logs
        raise RecordingError(f"{path}: not a readable DataFlash log ({exc})") from None
    notes: list[str] = []
    fmtu = _df_fmtu(reader)
    names = ("IMU", "IMU2", "IMU3", "ATT", "AHR2", "XKF1", "NKF1", "EKF1", "BARO", "MAG", "MAG2", "GPS", "RFND", "OF",
             "CAM", "TRIG")
    get = {n: _df_type(reader, n, notes, fmtu) for n in names}

    def first(d, keys=("I", "Instance", "C")):  # instance / core 0 of a multi-instance message
        if d is None:
            return None
        key = next((k for k in keys if k in d and np.ndim(d[k])), None)
        return {k: (v[d[key] == 0] if np.ndim(v) else v) for k, v in d.items()} if key else d

    imu_name = next((n for n in ("IMU", "IMU2", "IMU3") if get[n] is not None), None)
    if imu_name is None:
        raise RecordingError(f"{path}: no IMU messages (the log lacks what every navigator needs)")
    imu = first(get[imu_name])
    try:
        t0 = float(_df_time(imu).min())
    except KeyError:
        raise RecordingError(f"{path}: {imu_name} messages have neither TimeUS nor TimeMS") from None
    ts = lambda d: _df_time(d) - t0  # noqa: E731
    streams: dict[str, dict] = {}
    streams["imu"] = sorted_stream({"t_s": ts(imu),
                                    **{f"a{a}_mps2": imu[f"Acc{a.upper()}"].astype(float) for a in "xyz"},
                                    **{f"g{a}_radps": imu[f"Gyr{a.upper()}"].astype(float) for a in "xyz"}},
                                   notes, imu_name)
    att_name = next((n for n in ("ATT", "AHR2", "XKF1", "NKF1", "EKF1") if get[n] is not None), None)
    if att_name is not None:
        a = first(get[att_name])
        streams["attitude"] = sorted_stream({"t_s": ts(a), "roll_rad": np.radians(a["Roll"].astype(float)),
                                             "pitch_rad": np.radians(a["Pitch"].astype(float)),
                                             "yaw_rad": np.angle(np.exp(1j * np.radians(a["Yaw"].astype(float))))},
                                            notes, att_name)
        if att_name != "ATT":
            notes.append(f"no ATT messages: the attitude is {att_name}'s")
    if get["BARO"] is not None:
        b = first(get["BARO"])
        streams["baro"] = sorted_stream({"t_s": ts(b), "altitude_m": b["Alt"].astype(float)}, notes, "BARO")
    g = first(get["GPS"])
    if g is not None:
        g = {k: (v[g["Status"] >= 3] if np.ndim(v) else v) for k, v in g.items()} if "Status" in g else g  # 3D fix
        if len(g["Lat"]):
            vel = None
            if all(k in g for k in ("Spd", "GCrs", "VZ")):
                crs = np.radians(g["GCrs"].astype(float))
                vel = np.column_stack([g["Spd"] * np.cos(crs), g["Spd"] * np.sin(crs), g["VZ"]]).astype(float)
            streams["gps"] = sorted_stream(gps_stream(ts(g), g["Lat"].astype(float), g["Lng"].astype(float),
                                                      g["Alt"].astype(float), vel), notes, "GPS")
        else:
            notes.append("GPS: no 3D fix in the log")
    r = first(get["RFND"])
    if r is not None and ("Dist" in r or "Dist1" in r):
        dcol = "Dist" if "Dist" in r else "Dist1"
        dist = r[dcol].astype(float)
        raw = str(r["_format"])[list(k for k in r if not k.startswith("_")).index(dcol)]
        if raw not in _BUILTIN_MULT and raw not in "fd" and not bool(r["_fmtu"]):
            dist = dist * 0.01  # an integer distance without a multiplier: centimetres (older logs)
        orient = r.get("Orient", r.get("Orient1", np.full(len(dist), 25)))
        streams["range"] = sorted_stream({"t_s": ts(r), "range_m": np.where(dist > 0, dist, np.nan),
                                          "sensor": np.where(orient == 25, "sonar", "laser")}, notes, "RFND")
    mag_name = "MAG" if get["MAG"] is not None else "MAG2" if get["MAG2"] is not None else None
    if mag_name is not None:
        m = first(get[mag_name])
        mag = np.column_stack([m["MagX"], m["MagY"], m["MagZ"]]).astype(float)
        if not bool(m["_fmtu"]):
            mag = mag * 1e-3  # no FMTU: ArduPilot logs milligauss
        streams["mag_field"] = sorted_stream(mag_field_stream(ts(m), mag), notes, mag_name)
        if "attitude" in streams:
            f = streams["mag_field"]
            streams["magnetometer"] = heading_stream(f["t_s"], np.column_stack([f["mx_ga"], f["my_ga"], f["mz_ga"]]),
                                                     streams["attitude"])
    of = get["OF"]
    if of is not None and all(k in of for k in ("flowX", "flowY", "bodyX", "bodyY")):
        flow = np.column_stack([of[k].astype(float) if k in of else np.full(len(of["flowX"]), np.nan)
                                for k in ("flowX", "flowY", "bodyX", "bodyY", "Qual")])
        streams["optical_flow"] = sorted_stream(flow_stream(ts(of), flow), notes, "OF")
    cam_name = "CAM" if get["CAM"] is not None else "TRIG" if get["TRIG"] is not None else None
    if cam_name is not None:
        c = first(get[cam_name])
        t_cam = _cam_time(c, get["GPS"])
        if t_cam is None:
            notes.append(f"{cam_name}: no boot time (TimeUS / TimeMS) and no GPS time map: camera events left out")
        else:
            seq = c["Img"] if "Img" in c else np.arange(len(t_cam))
            lla = np.column_stack([c["Lat"], c["Lng"], c["Alt"]]).astype(float) if "Lat" in c else None
            streams["camera_trigger"] = sorted_stream(camera_stream(t_cam - t0, seq, lla), notes, cam_name)
    rec = Recording(path, _camera_beside(path), streams)
    at, cut = _df_damage(reader)
    s = streams["imu"]["t_s"]
    parts = [f"{'TimeUS' if 'TimeUS' in imu else 'TimeMS'} era" + (", FMTU multipliers" if fmtu else ""),
             f"{imu_name} {s[-1] - s[0]:.1f} s ({len(s)} samples)"]
    others = [n for n in ("IMU", "IMU2", "IMU3") if get[n] is not None and n != imu_name]
    if "I" in get[imu_name] and len(np.unique(get[imu_name]["I"])) > 1:
        others.append(f"{imu_name} instances {', '.join(str(int(i)) for i in np.unique(get[imu_name]['I'])[1:])}")
    if others:
        parts.append(f"not read: {', '.join(others)}")
    for key, label in (("attitude", att_name), ("gps", "GPS"), ("baro", "BARO"), ("mag_field", mag_name),
                       ("range", "RFND"), ("optical_flow", "OF"), ("camera_trigger", cam_name)):
        if key in streams:
            parts.append(f"{label} {len(streams[key]['t_s'])}")
    rec.summary = read_summary(Path(path).name, float(s[-1] - s[0]), reader.data_len, at, cut, parts)
    rec.notes += notes
    return rec


class _quiet:
    """Silence stdout and stderr down to the file descriptors (pymavlink's C indexer prints a line per bad
    byte of a damaged log to fd 2)."""

    def __enter__(self):
        for f in (sys.stdout, sys.stderr):
            try:
                f.flush()
            except (AttributeError, ValueError):
                pass
        self.null = os.open(os.devnull, os.O_WRONLY)
        self.saved = [os.dup(1), os.dup(2)]
        os.dup2(self.null, 1)
        os.dup2(self.null, 2)

        self.py = [contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO())]
        for c in self.py:
            c.__enter__()
        return self

    def __exit__(self, *exc):
        for c in reversed(self.py):
            c.__exit__(*exc)
        os.dup2(self.saved[0], 1)
        os.dup2(self.saved[1], 2)
        for fd in (*self.saved, self.null):
            os.close(fd)
        return False


def _cam_time(c: dict, gps: dict | None) -> np.ndarray | None:
    """A camera event's boot time [s]: its own TimeUS / TimeMS, else (older CAM, stamped in GPS time only)
    its ``GPSTime`` [ms of week] mapped through the GPS messages' (GPS time, boot time) pairs."""
    if "TimeUS" in c or "TimeMS" in c:
        return _df_time(c)
    if gps is not None and "GPSTime" in c and "TimeMS" in gps and "T" in gps and len(gps["T"]) > 1:
        gt, bt = gps["TimeMS"].astype(float), gps["T"].astype(float)
        o = np.argsort(gt)
        return np.interp(c["GPSTime"].astype(float), gt[o], bt[o]) * 1e-3
    return None


# ------------------------------------------------------------------------------------------ PX4 ULog
def read_px4(path: Path) -> Recording:
    """A PX4 ULog through ``io/ulog.read_ulog``: IMU, attitude, magnetometer (heading and field), GPS, baro,
    distance sensor, optical flow, camera events."""
    from scipy.spatial.transform import Rotation


    try:
        u = read_ulog(path)
    except (FileNotFoundError, ValueError) as exc:
        raise RecordingError(str(exc)) from None
    streams = {"imu": {"t_s": u.imu_t, **{f"a{a}_mps2": u.accel[:, i] for i, a in enumerate("xyz")},
                       **{f"g{a}_radps": u.gyro[:, i] for i, a in enumerate("xyz")}}}
    e = dcm_to_euler(Rotation.from_quat(u.att_quat[:, [1, 2, 3, 0]]).as_matrix())
    streams["attitude"] = {"t_s": u.att_t, "roll_rad": e[:, 0], "pitch_rad": e[:, 1], "yaw_rad": e[:, 2]}
    notes = list(u.notes)
    if u.mag is not None:
        streams["magnetometer"] = heading_stream(u.mag_t, u.mag, streams["attitude"],
                                                  np.radians(u.declination_deg or 0.0))
        streams["mag_field"] = mag_field_stream(u.mag_t, u.mag)
    if u.gps_t is not None:
        streams["gps"] = gps_stream(u.gps_t, u.gps_lla[:, 0], u.gps_lla[:, 1], u.gps_lla[:, 2], u.gps_vel)
    if u.baro_t is not None:  # PX4 logs the altitude above sea level: relative to the first sample here
        streams["baro"] = {"t_s": u.baro_t, "altitude_m": u.baro_alt - u.baro_alt[0]}
        notes.append(f"baro ({u.baro_source}): altitude relative to its first sample ({u.baro_alt[0]:.1f} m)")
    if u.range_t is not None:
        streams["range"] = {"t_s": u.range_t, "range_m": u.range_m,
                            "sensor": np.where(u.range_down, "sonar", "laser")}
    if u.flow_t is not None:
        streams["optical_flow"] = flow_stream(u.flow_t, u.flow, u.flow_dist)
    if u.cam_t is not None:
        streams["camera_trigger"] = camera_stream(u.cam_t, u.cam_seq, u.cam_lla)
    rec = Recording(path, _camera_beside(path), streams, summary=u.summary)
    rec.notes += notes
    return rec


# ------------------------------------------------------------------------------------------ ROS bags
_T_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
_T_FLU_FRD = np.diag([1.0, -1.0, -1.0])


def read_rosbag(path: Path) -> Recording:
    """A ROS 1 ``.bag`` or ROS 2 bag folder (module docstring); one topic per message type (the first)."""
    import cv2
    from rosbags.highlevel import AnyReader
    from scipy.spatial.transform import Rotation

    wanted = ("sensor_msgs/msg/Imu", "sensor_msgs/msg/NavSatFix", "sensor_msgs/msg/Range", "sensor_msgs/msg/Image",
              "sensor_msgs/msg/CompressedImage")
    rows: dict[str, list] = {k: [] for k in wanted}
    try:
        with AnyReader([path]) as reader:
            conns = {}
            for c in reader.connections:
                conns.setdefault(c.msgtype, c)
            use = [c for k, c in conns.items() if k in wanted]
            if not any(c.msgtype == "sensor_msgs/msg/Imu" for c in use):
                raise RecordingError(f"{path}: no sensor_msgs/Imu topic (topics: "
                                     f"{', '.join(sorted(c.topic for c in reader.connections)) or 'none'})")
            for conn, t_ns, raw in reader.messages(connections=use):
                msg = reader.deserialize(raw, conn.msgtype)
                rows[conn.msgtype].append((t_ns, msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec, msg))
    except RecordingError:
        raise
    except Exception as exc:  # rosbags' own errors name the damaged file
        raise RecordingError(f"{path}: not a readable ROS bag ({exc})") from None
    imu = rows["sensor_msgs/msg/Imu"]
    t0 = min(s for _, s, _ in imu)
    sec = lambda ns: (np.asarray(ns, np.int64) - t0) * 1e-9  # noqa: E731
    notes: list[str] = []
    streams: dict[str, dict] = {}
    tr, ts, msgs = zip(*imu)
    acc = np.array([[m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z] for m in msgs])
    gyr = np.array([[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z] for m in msgs])
    acc, gyr = acc @ _T_FLU_FRD, gyr @ _T_FLU_FRD  # FLU -> FRD (a diagonal, its own transpose)
    streams["imu"] = sorted_stream({"t_s": sec(ts), **{f"a{a}_mps2": acc[:, i] for i, a in enumerate("xyz")},
                                    **{f"g{a}_radps": gyr[:, i] for i, a in enumerate("xyz")}, "t_recv_s": sec(tr)},
                                   notes, "Imu")
    q = np.array([[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for m in msgs])
    qn = np.linalg.norm(q, axis=1)
    if np.all(qn > 0.5):  # orientation present (all zeros = 'not provided', REP 145)
        C = _T_NED_ENU @ Rotation.from_quat(q / qn[:, None]).as_matrix() @ _T_FLU_FRD
        e = dcm_to_euler(C)
        streams["attitude"] = sorted_stream({"t_s": sec(ts), "roll_rad": e[:, 0], "pitch_rad": e[:, 1],
                                             "yaw_rad": e[:, 2], "t_recv_s": sec(tr)}, notes, "Imu orientation")
    fix = [r for r in rows["sensor_msgs/msg/NavSatFix"] if r[2].status.status >= 0]
    if fix:
        tr, ts, msgs = zip(*fix)
        lla = np.array([[m.latitude, m.longitude, m.altitude] for m in msgs])
        streams["gps"] = sorted_stream(gps_stream(sec(ts), lla[:, 0], lla[:, 1], lla[:, 2]) | {"t_recv_s": sec(tr)},
                                       notes, "NavSatFix")
    if rows["sensor_msgs/msg/Range"]:
        tr, ts, msgs = zip(*rows["sensor_msgs/msg/Range"])
        r = np.array([m.range if m.min_range <= m.range <= m.max_range else np.nan for m in msgs])
        sensor = np.array(["sonar" if m.radiation_type == 0 else "laser" for m in msgs])
        streams["range"] = sorted_stream({"t_s": sec(ts), "range_m": r, "sensor": sensor, "t_recv_s": sec(tr)},
                                         notes, "Range")
    images = None
    frames = rows["sensor_msgs/msg/Image"] or rows["sensor_msgs/msg/CompressedImage"]
    if frames:
        tr, ts, msgs = zip(*frames)
        images = [_ros_image(m, cv2) for m in msgs]
        streams["frames"] = {"t_s": sec(ts), "file": np.array([f"image#{i}" for i in range(len(msgs))]),
                             "t_recv_s": sec(tr)}
        if np.any(np.diff(streams["frames"]["t_s"]) < 0):
            raise RecordingError(f"{path}: image stamps out of order")
    rec = Recording(path, _camera_beside(path), streams, images=images)
    if frames and rec.camera is None:
        raise RecordingError(f"{path}: the bag has images but no camera.yaml beside it (intrinsics, mount)")
    rec.notes += notes
    return rec


def _ros_image(m, cv2):
    if hasattr(m, "format"):  # CompressedImage
        return cv2.imdecode(np.frombuffer(bytes(m.data), np.uint8), cv2.IMREAD_GRAYSCALE)
    data = np.frombuffer(bytes(m.data), np.uint8)
    if m.encoding in ("mono8", "8UC1"):
        return data.reshape(m.height, m.step)[:, : m.width].copy()
    if m.encoding in ("rgb8", "bgr8"):
        img = data.reshape(m.height, m.step)[:, : 3 * m.width].reshape(m.height, m.width, 3)
        return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY if m.encoding == "rgb8" else cv2.COLOR_BGR2GRAY)
    return None  # other encodings: counted as a dropped frame
