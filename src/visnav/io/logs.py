"""Flight logs read directly into a ``Recording`` (the same streams and columns as the folder format).

* ArduPilot DataFlash ``.bin`` (pymavlink's ``DFReader`` indexes the messages and parses the FMT
  formats; each message type is then decoded at once with numpy from the indexed offsets): IMU
  (instance 0), ATT, BARO, MAG, GPS, RFND.
* ROS 1 / ROS 2 bags without ROS (``rosbags``): sensor_msgs Imu, NavSatFix, Range, Image,
  CompressedImage. ROS body axes are FLU and world axes ENU (REP 103); they are turned into FRD / NED.
  The bag's receive time is the delivery time (``t_recv_s``), the header stamp the instant (``t_s``).
* PX4 ULog through ``io/ulog.py`` (IMU, attitude, magnetometer).

Positions from latitude / longitude are NED about the first fix; a magnetometer's field becomes a
tilt-compensated heading with the attitude of the log (declination added when the log has it).
A ``camera.yaml`` beside the log (same folder) describes the camera of a bag's images.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from visnav.geometry.rotations import dcm_to_euler
from visnav.io.recording import Recording, RecordingError, read_camera_yaml
from visnav.io.streams import gps_stream, heading_stream


def open_recording(path: str | Path) -> Recording:
    """A recording folder (or a ``visnav bridge`` log folder: its ``recording/``), a folder of geotagged photos
    (``io/photos.py``), a DataFlash ``.bin``, a PX4 ``.ulg`` or a ROS bag (``.bag`` / ROS 2 folder)."""
    p = Path(path)
    if p.is_dir() and (p / "bridge.tlog").is_file() and (p / "recording").is_dir():  # a `visnav bridge` log folder
        p = p / "recording"
    if p.is_dir() and not (p / "metadata.yaml").is_file():
        from visnav.io.photos import is_photo_folder, read_photos  # a folder of geotagged photos (a survey)

        return read_photos(p) if is_photo_folder(p) else Recording.open(p)
    if not p.exists():
        raise RecordingError(f"{p}: no such recording folder or log")
    suffix = p.suffix.lower()
    if suffix == ".bin":
        return read_dataflash(p)
    if suffix == ".ulg":
        return read_px4(p)
    if suffix in (".bag", ".db3", ".mcap") or p.is_dir():
        return read_rosbag(p.parent if suffix in (".db3", ".mcap") else p)
    raise RecordingError(f"{p}: not a recording folder, .bin, .ulg or ROS bag")


def _camera_beside(p: Path):
    f = p.parent / "camera.yaml" if not p.is_dir() else p / "camera.yaml"
    return read_camera_yaml(f) if f.is_file() else None


def _sorted(stream: dict, notes: list, what: str) -> dict:
    """Sort by t_s (and drop non-finite stamps): logs are repaired with a note, not refused."""
    t = stream["t_s"]
    keep = np.isfinite(t)
    if not keep.all():
        notes.append(f"{what}: {int((~keep).sum())} samples without a valid time dropped")
    o = np.argsort(np.where(keep, t, np.inf), kind="stable")[: int(keep.sum())]
    if np.any(np.diff(o) < 0):
        notes.append(f"{what}: samples re-sorted by time")
    return {k: v[o] for k, v in stream.items()}


# ------------------------------------------------------------------------------------------ DataFlash
_NP = {"b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4", "f": "<f4", "d": "<f8", "q": "<i8",
       "Q": "<u8", "e": "<f2"}


def _df_type(reader, name: str, notes: list) -> dict[str, np.ndarray] | None:
    """All messages of one DataFlash type as columns (multipliers applied), or None if absent."""
    import re

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
    out = {}
    for c, mul in zip(fmt.columns, fmt.msg_mults):
        v = rec[c]
        out[c] = v.astype(float) * mul if mul is not None else v
    return out


def read_dataflash(path: Path) -> Recording:
    """An ArduPilot DataFlash log (module docstring)."""
    import contextlib
    import io

    try:
        from pymavlink.DFReader import DFReader_binary

        with contextlib.redirect_stdout(io.StringIO()):  # DFReader prints per bad message; we count instead
            reader = DFReader_binary(str(path))
    except Exception as exc:  # pymavlink raises bare Exceptions on damaged logs
        raise RecordingError(f"{path}: not a readable DataFlash log ({exc})") from None
    notes: list[str] = []
    get = {n: _df_type(reader, n, notes) for n in ("IMU", "ATT", "BARO", "MAG", "GPS", "RFND")}
    if get["IMU"] is None:
        raise RecordingError(f"{path}: no IMU messages (the log lacks what every navigator needs)")

    def first(d, key="I"):  # instance 0 of a multi-instance message
        return {k: v[d[key] == 0] for k, v in d.items()} if key in d else d

    t0 = float(get["IMU"]["TimeUS"].min())
    ts = lambda d: (d["TimeUS"].astype(float) - t0) * 1e-6  # noqa: E731
    streams: dict[str, dict] = {}
    imu = first(get["IMU"])
    streams["imu"] = _sorted({"t_s": ts(imu), **{f"a{a}_mps2": imu[f"Acc{a.upper()}"].astype(float) for a in "xyz"},
                              **{f"g{a}_radps": imu[f"Gyr{a.upper()}"].astype(float) for a in "xyz"}}, notes, "IMU")
    if get["ATT"] is not None:
        a = get["ATT"]
        streams["attitude"] = _sorted({"t_s": ts(a), "roll_rad": np.radians(a["Roll"].astype(float)),
                                       "pitch_rad": np.radians(a["Pitch"].astype(float)),
                                       "yaw_rad": np.angle(np.exp(1j * np.radians(a["Yaw"].astype(float))))},
                                      notes, "ATT")
    if get["BARO"] is not None:
        b = first(get["BARO"])
        streams["baro"] = _sorted({"t_s": ts(b), "altitude_m": b["Alt"].astype(float)}, notes, "BARO")
    if get["GPS"] is not None:
        g = first(get["GPS"])
        g = {k: v[g["Status"] >= 3] for k, v in g.items()} if "Status" in g else g  # 3D fix or better
        if len(g["TimeUS"]):
            crs = np.radians(g["GCrs"].astype(float))
            vel = np.column_stack([g["Spd"] * np.cos(crs), g["Spd"] * np.sin(crs), g["VZ"]]).astype(float)
            streams["gps"] = _sorted(gps_stream(ts(g), g["Lat"], g["Lng"], g["Alt"].astype(float), vel), notes, "GPS")
        else:
            notes.append("GPS: no 3D fix in the log")
    if get["RFND"] is not None:
        r = first(get["RFND"], "Instance")
        sensor = np.where(r.get("Orient", np.full(len(r["TimeUS"]), 25)) == 25, "sonar", "laser")
        dist = r["Dist"].astype(float)
        streams["range"] = _sorted({"t_s": ts(r), "range_m": np.where(dist > 0, dist, np.nan), "sensor": sensor},
                                   notes, "RFND")
    if get["MAG"] is not None and "attitude" in streams:
        m = first(get["MAG"])
        mag = np.column_stack([m["MagX"], m["MagY"], m["MagZ"]]).astype(float)
        streams["magnetometer"] = _sorted(heading_stream(ts(m), mag, streams["attitude"]), notes, "MAG")
    rec = Recording(path, _camera_beside(path), streams)
    rec.notes += notes
    return rec


# ------------------------------------------------------------------------------------------ PX4 ULog
def read_px4(path: Path) -> Recording:
    """A PX4 ULog through ``io/ulog.read_ulog`` (IMU, attitude, magnetometer)."""
    from scipy.spatial.transform import Rotation

    from visnav.io.ulog import read_ulog

    try:
        u = read_ulog(path)
    except (FileNotFoundError, ValueError) as exc:
        raise RecordingError(str(exc)) from None
    streams = {"imu": {"t_s": u.imu_t, **{f"a{a}_mps2": u.accel[:, i] for i, a in enumerate("xyz")},
                       **{f"g{a}_radps": u.gyro[:, i] for i, a in enumerate("xyz")}}}
    e = dcm_to_euler(Rotation.from_quat(u.att_quat[:, [1, 2, 3, 0]]).as_matrix())
    streams["attitude"] = {"t_s": u.att_t, "roll_rad": e[:, 0], "pitch_rad": e[:, 1], "yaw_rad": e[:, 2]}
    if u.mag is not None:
        streams["magnetometer"] = heading_stream(u.mag_t, u.mag, streams["attitude"],
                                                  np.radians(u.declination_deg or 0.0))
    rec = Recording(path, _camera_beside(path), streams)
    rec.notes += list(u.notes)
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
    streams["imu"] = _sorted({"t_s": sec(ts), **{f"a{a}_mps2": acc[:, i] for i, a in enumerate("xyz")},
                              **{f"g{a}_radps": gyr[:, i] for i, a in enumerate("xyz")}, "t_recv_s": sec(tr)},
                             notes, "Imu")
    q = np.array([[m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w] for m in msgs])
    qn = np.linalg.norm(q, axis=1)
    if np.all(qn > 0.5):  # orientation present (all zeros = 'not provided', REP 145)
        C = _T_NED_ENU @ Rotation.from_quat(q / qn[:, None]).as_matrix() @ _T_FLU_FRD
        e = dcm_to_euler(C)
        streams["attitude"] = _sorted({"t_s": sec(ts), "roll_rad": e[:, 0], "pitch_rad": e[:, 1], "yaw_rad": e[:, 2],
                                       "t_recv_s": sec(tr)}, notes, "Imu orientation")
    fix = [r for r in rows["sensor_msgs/msg/NavSatFix"] if r[2].status.status >= 0]
    if fix:
        tr, ts, msgs = zip(*fix)
        lla = np.array([[m.latitude, m.longitude, m.altitude] for m in msgs])
        streams["gps"] = _sorted(gps_stream(sec(ts), lla[:, 0], lla[:, 1], lla[:, 2]) | {"t_recv_s": sec(tr)}, notes,
                                 "NavSatFix")
    if rows["sensor_msgs/msg/Range"]:
        tr, ts, msgs = zip(*rows["sensor_msgs/msg/Range"])
        r = np.array([m.range if m.min_range <= m.range <= m.max_range else np.nan for m in msgs])
        sensor = np.array(["sonar" if m.radiation_type == 0 else "laser" for m in msgs])
        streams["range"] = _sorted({"t_s": sec(ts), "range_m": r, "sensor": sensor, "t_recv_s": sec(tr)}, notes,
                                   "Range")
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
