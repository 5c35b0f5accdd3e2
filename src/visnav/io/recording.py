"""The recorded-flight folder (``docs/recordings.md``): writer and reader.

A recording is a folder a user can fill from their own vehicle without our code::

    camera.yaml      intrinsics, distortion (OpenCV order), image size, mount, time offset
    frames.csv       t_s, file [, t_recv_s, seq, index]        frames/ PNG or JPEG
    imu.csv          t_s, ax_mps2, ay_mps2, az_mps2, gx_radps, gy_radps, gz_radps
    attitude.csv     t_s, roll_rad, pitch_rad, yaw_rad
    baro.csv         t_s, altitude_m
    magnetometer.csv t_s, heading_rad
    range.csv        t_s, range_m, sensor [, beam_offset_rad]   (t_s in order per sensor)
    gps.csv          t_s, n_m, e_m, d_m, vn_mps, ve_mps, vd_mps [, sigma_m]
    airspeed.csv     t_s, airspeed_mps                          (CONDOR: pitot)
    camera_attitude.csv  t_s, roll_rad, tilt_rad                (CONDOR: the gimbal camera's AHRS)
    pan.csv          t_s, pan_rad                               (CONDOR: gimbal pan potentiometer)
    click.csv        t_s, u_px, v_px                            (CONDOR: the operator's click on the target)
    link.csv         t_s [, t_recv_s, seq]                      (CONDOR: uplink deliveries of the navigator's fixes)
    telemetry.csv    t_s, n_m, e_m, d_m, heading_rad, height_m, ground_speed_mps   (geo-location: the downlink)
    truth.csv        t_s, n_m, e_m, d_m [, roll_rad, pitch_rad, yaw_rad]   (where a reference exists)
    mag_field.csv, optical_flow.csv, camera_trigger.csv   (from flight logs; kept, not delivered to navigators)
    commands.csv     t_s, seq, method, args  (simulated recordings: what the mission asked the navigator)
    scenario.toml    (simulated recordings: the resolved scenario)

Every sensor CSV may carry ``t_recv_s`` (when the sample reached the navigator; default ``t_s``) and
``seq`` (the global delivery order, written by ``visnav record`` so that a replay feeds the samples in
exactly the order of the closed loop). The reader yields the typed measurements of
``visnav.measurements`` in delivery order (by ``t_recv_s``, then ``seq``). Floats are written with 17
significant digits (``%.17g``), so a replay reads back the very numbers the navigator saw.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.measurements import (AirspeedSample, AttitudeSample, BaroSample, Frame, GpsSample, HeadingSample,
                                 ImuSample, OperatorClick, PanSample, RangeSample, TargetRangeSample, TelemetrySample)
import csv
from visnav.io.streams import gps_stream, heading_stream


class RecordingError(ValueError):
    """A recording that cannot be read; the message names the file and what is wrong."""


@dataclass(frozen=True)
class Stream:
    file: str
    required: tuple[str, ...]
    optional: tuple[str, ...] = ()
    text: tuple[str, ...] = ()  # columns that stay strings
    alternatives: tuple[tuple[str, ...], ...] = ()  # other column sets accepted instead of ``required``
    written: tuple[str, ...] = ()  # what ``RecordingWriter`` writes (before t_recv_s, seq); default all
    consumed: bool = True  # False: read and kept (a log's other sensors), never delivered to a navigator
    per: str = ""  # a text column whose values are separate sensors: ``t_s`` non-decreasing within each

    @property
    def columns(self) -> tuple[str, ...]:
        return self.written or self.required + self.optional


#: stream name -> its CSV; the order is the tie-break of samples delivered at the same instant
#: without a ``seq`` column (the IMU first, as the simulated IMU emits its rates before its attitude)
STREAMS: dict[str, Stream] = {
    "imu": Stream("imu.csv", ("t_s", "ax_mps2", "ay_mps2", "az_mps2", "gx_radps", "gy_radps", "gz_radps")),
    "attitude": Stream("attitude.csv", ("t_s", "roll_rad", "pitch_rad", "yaw_rad")),
    "gps": Stream("gps.csv", ("t_s", "n_m", "e_m", "d_m", "vn_mps", "ve_mps", "vd_mps"), ("sigma_m",),
                  alternatives=(("t_s", "n_m", "e_m", "d_m"), ("t_s", "lat_deg", "lon_deg", "alt_m"))),
    # two range finders (laser, sonar) share a file and a link message: each sensor's stamps in order, not the file's
    # (the bridge's clock mapping put a sonar sample 2 us before the laser's just written, palace SIL)
    "range": Stream("range.csv", ("t_s", "range_m", "sensor"), ("beam_offset_rad",), text=("sensor",), per="sensor"),
    "baro": Stream("baro.csv", ("t_s", "altitude_m")),
    "magnetometer": Stream("magnetometer.csv", ("t_s", "heading_rad"), alternatives=(("t_s", "mx", "my", "mz"),)),
    "frames": Stream("frames.csv", ("t_s", "file"), ("index", "video_frame"), text=("file",),
                     written=("t_s", "file", "index")),
    # CONDOR (seed 004): the gimbal camera's own AHRS, its pan potentiometer, the pitot, the operator's
    # click on the target, and the telemetry uplink that carries the ground station's range fixes
    "camera_attitude": Stream("camera_attitude.csv", ("t_s", "roll_rad", "tilt_rad")),
    "pan": Stream("pan.csv", ("t_s", "pan_rad")),
    "airspeed": Stream("airspeed.csv", ("t_s", "airspeed_mps")),
    "click": Stream("click.csv", ("t_s", "u_px", "v_px")),
    "link": Stream("link.csv", ("t_s",)),
    # MAV geo-location (seed 002 ch. 7): the autopilot's telemetry as the ground station receives it
    "telemetry": Stream("telemetry.csv", ("t_s", "n_m", "e_m", "d_m", "heading_rad", "height_m", "ground_speed_mps")),
    # read from flight logs (io/logs.py) and kept for analysis; no navigator consumes them (never delivered)
    "mag_field": Stream("mag_field.csv", ("t_s", "mx_ga", "my_ga", "mz_ga"), consumed=False),  # body FRD [gauss]
    "optical_flow": Stream("optical_flow.csv", ("t_s", "flow_x_radps", "flow_y_radps", "body_x_radps", "body_y_radps",
                                                "quality"), ("distance_m",), consumed=False),
    "camera_trigger": Stream("camera_trigger.csv", ("t_s", "seq"), ("lat_deg", "lon_deg", "alt_m"), consumed=False),
}
TRUTH = Stream("truth.csv", ("t_s", "n_m", "e_m", "d_m"), ("vn_mps", "ve_mps", "vd_mps", "roll_rad", "pitch_rad",
                                                          "yaw_rad"))
COMMANDS = Stream("commands.csv", ("t_s", "method"), ("seq", "args"), text=("method", "args"))
DELIVERY = ("t_recv_s", "seq")
_TYPE_STREAM = {ImuSample: "imu", AttitudeSample: "attitude", GpsSample: "gps", RangeSample: "range",
                BaroSample: "baro", HeadingSample: "magnetometer", Frame: "frames", PanSample: "pan",
                AirspeedSample: "airspeed", OperatorClick: "click", TargetRangeSample: "link", TelemetrySample: "telemetry"}


def stream_of(m) -> str | None:
    """The recording stream a measurement belongs to (a camera's own AHRS: ``camera_attitude``)."""
    if isinstance(m, AttitudeSample) and m.sensor == "camera":
        return "camera_attitude"
    return _TYPE_STREAM.get(type(m))


# ---------------------------------------------------------------------------------------------- CSV
def _short_row(path: Path, n: int) -> tuple[int, int] | None:
    """(line number, its column count) of the first data row of ``path`` whose column count is not ``n``."""

    with open(path, newline="") as fh:
        for i, r in enumerate(csv.reader(fh)):
            if i and r and len(r) != n:
                return i + 1, len(r)
    return None


def read_csv(path: Path, spec: Stream, allow_truncated: bool = False, notes: list | None = None) -> dict[str, np.ndarray]:
    """Columns of a CSV with a header line (vectorised parse); checks the required columns, finite
    non-decreasing ``t_s`` and, where present, ``t_recv_s``. A row with another column count than the header
    (a file cut while written) is an error naming its line, or with ``allow_truncated`` the rows before it
    are read (said in ``notes``)."""
    try:
        with open(path, newline="") as fh:
            header = fh.readline().strip()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read ({exc.strerror or exc})") from None
    names = [c.strip() for c in header.split(",")]
    missing = [c for c in spec.required if c not in names]
    if missing and not any(all(c in names for c in alt) for alt in spec.alternatives):
        alts = "".join(f" or {', '.join(a)}" for a in spec.alternatives)
        raise RecordingError(f"{path}: missing column(s) {', '.join(missing)} (header: {header!r}; "
                             f"needed: {', '.join(spec.required)}{alts})")
    def load(max_rows=None):
        with warnings.catch_warnings():  # no rows: numpy's UserWarning (an empty stream is allowed)
            warnings.simplefilter("ignore", UserWarning)
            return np.loadtxt(path, delimiter=",", skiprows=1, dtype=str, ndmin=2, quotechar='"', comments=None,
                              max_rows=max_rows)

    try:
        raw = load()
    except ValueError as exc:
        bad = _short_row(path, len(names))
        if bad is None:
            raise RecordingError(f"{path}: {exc}") from None
        what = f"line {bad[0]} has {bad[1]} columns, {len(names)} expected (truncated file?)"
        if not allow_truncated:
            raise RecordingError(f"{path}: {what}; --allow-truncated reads the rows before it") from None
        raw = load(bad[0] - 2) if bad[0] > 2 else np.empty((0, len(names)), dtype=str)
        if notes is not None:
            notes.append(f"{path.name}: {what}: read the {bad[0] - 2} rows before it")
    if raw.size == 0:
        raw = np.empty((0, len(names)), dtype=str)
    if raw.shape[1] != len(names):
        raise RecordingError(f"{path}: {raw.shape[1]} values per row, the header names {len(names)}")
    out: dict[str, np.ndarray] = {}
    for j, name in enumerate(names):
        col = np.char.strip(raw[:, j])
        if name in spec.text:
            out[name] = col
            continue
        try:
            out[name] = col.astype(float)
        except ValueError:
            bad = next(i for i, v in enumerate(col) if not _is_float(v))
            raise RecordingError(f"{path}: line {bad + 2}: column {name} holds {str(col[bad])!r}, "
                                 "not a number") from None
    for name in ("t_s", "t_recv_s"):
        if name not in out:
            continue
        t = out[name]
        if not np.all(np.isfinite(t)):
            bad = int(np.flatnonzero(~np.isfinite(t))[0])
            raise RecordingError(f"{path}: line {bad + 2}: {name} is not finite")
        groups = [np.arange(len(t))] if not (spec.per and name == "t_s" and spec.per in out) else \
            [np.flatnonzero(out[spec.per] == g) for g in np.unique(out[spec.per])]
        for rows in groups:
            back = np.flatnonzero(np.diff(t[rows]) < 0)
            if back.size:
                i, j = int(rows[back[0] + 1]), int(rows[back[0]])
                raise RecordingError(f"{path}: line {i + 2}: timestamps out of order ({name} {float(t[i])!r} after "
                                     f"{float(t[j])!r})")
    return out


def _is_float(v: str) -> bool:
    try:
        float(v)
        return True
    except ValueError:
        return False


def write_csv(path: Path, columns: dict[str, np.ndarray | list]) -> None:
    """A CSV with a header line; floats with 17 significant digits (exact round trip)."""
    names = list(columns)
    n = len(next(iter(columns.values()))) if columns else 0
    cols = []
    for k in names:
        v = np.asarray(columns[k])
        if v.dtype.kind in "fiub":
            cols.append(np.char.mod("%.17g", v.astype(float)) if v.dtype.kind == "f" else v.astype(str))
        else:
            cols.append(np.array([_quote(str(x)) for x in v], dtype=object).astype(str))
    with open(path, "w", newline="") as fh:
        fh.write(",".join(names) + "\n")
        if n:
            rows = np.column_stack(cols) if cols else np.empty((0, 0))
            fh.write("\n".join(",".join(r) for r in rows) + "\n")


def _quote(s: str) -> str:
    return '"' + s.replace('"', '""') + '"' if ("," in s or '"' in s) else s


# ------------------------------------------------------------------------------------------ camera
@dataclass(frozen=True)
class CameraInfo:
    camera: PinholeCamera
    mount: FixedMount | None  # None: a gimbal (``gimbal: true``), its attitude comes from the recording's streams
    time_offset_s: float = 0.0  # t_imu = t_camera + time_offset_s


def write_camera_yaml(path: Path, camera: PinholeCamera, mount: FixedMount | None, time_offset_s: float = 0.0) -> None:
    """``mount`` None: a camera on a gimbal (``gimbal: true``; camera_attitude.csv and pan.csv say where it looks)."""
    import yaml

    doc = {
        "image_size": [camera.width, camera.height],
        "intrinsics": {"fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy},
        "distortion": [float(c) for c in camera.dist],
    }
    if mount is None:
        doc["gimbal"] = True
    else:
        doc |= {"R_cam_to_body": [[float(x) for x in row] for row in mount.R_cam_to_body],
                "lever_arm_m": [float(x) for x in mount.lever_arm]}
    doc["time_offset_s"] = float(time_offset_s)
    head = ("# visnav recording camera (docs/recordings.md): OpenCV pinhole, distortion in OpenCV order\n"
            "# (k1, k2, p1, p2[, k3[, k4, k5, k6]]), R_cam_to_body maps camera (x right, y down, z optical axis)\n"
            "# vectors to body FRD, lever arm = camera centre in body FRD, t_imu = t_camera + time_offset_s\n"
            "# (gimbal: true instead of a mount: the camera's attitude is in camera_attitude.csv and pan.csv)\n")
    path.write_text(head + yaml.safe_dump(doc, sort_keys=False))


def read_camera_yaml(path: Path, default_mount: FixedMount | None = None) -> CameraInfo:
    """``default_mount``: the mount of a camera.yaml that names none (a photo survey's: nadir), else one is needed."""
    import yaml

    if not path.is_file():
        raise RecordingError(f"{path}: missing (the camera's intrinsics, image size and mount)")
    try:
        doc = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise RecordingError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise RecordingError(f"{path}: expected a mapping of keys")
    intr = doc.get("intrinsics")
    if not isinstance(intr, dict) or any(k not in intr for k in ("fx", "fy", "cx", "cy")):
        raise RecordingError(f"{path}: no intrinsics (need 'intrinsics: {{fx, fy, cx, cy}}' in pixels)")
    size = doc.get("image_size")
    if not (isinstance(size, (list, tuple)) and len(size) == 2):
        raise RecordingError(f"{path}: no image_size (need '[width, height]' in pixels)")
    dist = list(doc.get("distortion") or [])
    if len(dist) not in (0, 4, 5, 8):
        raise RecordingError(f"{path}: distortion has {len(dist)} coefficients; OpenCV's order takes 4, 5 or 8")
    dist = dist + [0.0] * (8 - len(dist))
    try:
        cam = PinholeCamera(size[0], size[1], intr["fx"], intr["fy"], intr["cx"], intr["cy"], tuple(dist))
        if "R_cam_to_body" in doc:
            mount = FixedMount(np.array(doc["R_cam_to_body"], float), np.array(doc.get("lever_arm_m", [0, 0, 0]),
                                                                                float))
        elif "depression_deg" in doc:
            mount = FixedMount.depressed(float(doc["depression_deg"]), tuple(doc.get("lever_arm_m", (0, 0, 0))))
        elif doc.get("gimbal") is True:
            mount = None
        elif default_mount is not None:
            mount = default_mount
        else:
            raise ValueError("no mount: give R_cam_to_body (3x3, camera -> body FRD), depression_deg, or "
                             "gimbal: true (attitude from camera_attitude.csv and pan.csv)")
        offset = float(doc.get("time_offset_s", 0.0))
        if not math.isfinite(offset):
            raise ValueError("time_offset_s is not finite")
    except (ValueError, TypeError) as exc:
        raise RecordingError(f"{path}: {exc}") from None
    return CameraInfo(cam, mount, offset)


# ------------------------------------------------------------------------------------------ reader
@dataclass
class Recording:
    """An opened, validated recording folder (``Recording.open``); ``measurements()`` replays it."""

    path: Path
    camera: CameraInfo | None
    streams: dict[str, dict[str, np.ndarray]]
    truth: dict[str, np.ndarray] | None = None
    commands: dict[str, np.ndarray] | None = None
    scenario_toml: str | None = None
    skipped: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    time_offset_s: float = 0.0  # added to frame stamps (camera clock -> IMU clock); camera.yaml's by default
    images: list | None = None  # decoded frames held in memory (logs: rosbag images), else files
    color: bool = False  # frames decoded to RGB (a navigator that uses colour: CONDOR), else 8-bit gray
    summary: str = ""  # a log's one line: what was read, to the end or to the damage (io/logs.py)
    _video: dict = field(default_factory=dict, repr=False)  # file -> [cv2.VideoCapture, next frame number]

    @classmethod
    def open(cls, path: str | Path, allow_truncated: bool = False) -> "Recording":
        """``allow_truncated``: a CSV cut while written is read up to its first short row (said in ``notes``)."""
        d = Path(path)
        if not d.is_dir():
            raise RecordingError(f"{d}: not a recording folder (no such directory)")
        cut: list[str] = []
        streams = {k: read_csv(d / s.file, s, allow_truncated, cut) for k, s in STREAMS.items() if (d / s.file).is_file()}
        if not streams:
            raise RecordingError(f"{d}: no sensor CSV ({', '.join(s.file for s in STREAMS.values())})")
        cam = read_camera_yaml(d / "camera.yaml") if ("frames" in streams or (d / "camera.yaml").exists()) else None
        if "frames" in streams:
            files = streams["frames"]["file"]
            missing = [f for f in files if not (d / f).is_file()]
            if missing:
                raise RecordingError(f"{d / missing[0]}: frame file missing (listed in frames.csv; "
                                     f"{len(missing)} of {len(files)} missing)")
            for v in {f for f in files if Path(f).suffix.lower() in VIDEO_SUFFIXES}:
                import cv2

                if not cv2.VideoCapture(str(d / v)).isOpened():
                    raise RecordingError(f"{d / v}: cannot open the video (format or codec not supported by OpenCV)")
        _convert(streams, d)
        truth = read_csv(d / TRUTH.file, TRUTH, allow_truncated, cut) if (d / TRUTH.file).is_file() else None
        cmds = read_csv(d / COMMANDS.file, COMMANDS, allow_truncated, cut) if (d / COMMANDS.file).is_file() else None
        sc = (d / "scenario.toml").read_text() if (d / "scenario.toml").is_file() else None
        return cls(d, cam, streams, truth, cmds, sc, notes=cut, time_offset_s=cam.time_offset_s if cam else 0.0)

    def require(self, names, who: str) -> None:
        """Raise a ``RecordingError`` naming what ``who`` needs and the folder lacks."""
        missing = [n for n in names if n not in self.streams or len(self.streams[n]["t_s"]) == 0]
        if missing:
            files = ", ".join(STREAMS[n].file for n in missing)
            raise RecordingError(f"{self.path}: the {who} navigator needs {files}; not in the recording")

    def count(self, name: str) -> int:
        return len(self.streams[name]["t_s"]) if name in self.streams else 0

    def delivery(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(t_recv, seq, stream index, row) of every sample, sorted in delivery order."""
        names = [n for n in self.streams if n not in STREAMS or STREAMS[n].consumed]
        tr, sq, si, ri = [], [], [], []
        for j, n in enumerate(names):
            s = self.streams[n]
            t = s["t_s"] + (self.time_offset_s if n in ("frames", "link") else 0.0)
            tr.append(s.get("t_recv_s", t))
            sq.append(s.get("seq", np.full(len(t), -1.0)))
            si.append(np.full(len(t), STREAM_ORDER[n]))
            ri.append(np.arange(len(t)))
        tr, sq, si, ri = (np.concatenate(a) for a in (tr, sq, si, ri))
        o = np.lexsort((ri, si, sq, tr))
        return tr[o], sq[o], si[o], ri[o]

    def sample(self, stream: str, i: int):
        """The typed measurement of row ``i`` of ``stream`` (``None`` for a frame that cannot be decoded,
        counted in ``skipped``); a frame's time is moved to the IMU clock by ``time_offset_s``."""
        s = self.streams[stream]
        t = float(s["t_s"][i])
        if stream == "imu":
            return ImuSample(t, np.array([s["ax_mps2"][i], s["ay_mps2"][i], s["az_mps2"][i]]),
                             np.array([s["gx_radps"][i], s["gy_radps"][i], s["gz_radps"][i]]))
        if stream == "attitude":
            return AttitudeSample(t, np.array([s["roll_rad"][i], s["pitch_rad"][i], s["yaw_rad"][i]]))
        if stream == "gps":
            sig = float(s["sigma_m"][i]) if "sigma_m" in s else GpsSample.__dataclass_fields__["sigma"].default
            return GpsSample(t, np.array([s["n_m"][i], s["e_m"][i], s["d_m"][i]]),
                             np.array([s["vn_mps"][i], s["ve_mps"][i], s["vd_mps"][i]]), sig)
        if stream == "range":
            return RangeSample(t, float(s["range_m"][i]), str(s["sensor"][i]),
                               float(s["beam_offset_rad"][i]) if "beam_offset_rad" in s else 0.0)
        if stream == "baro":
            return BaroSample(t, float(s["altitude_m"][i]))
        if stream == "magnetometer":
            return HeadingSample(t, float(s["heading_rad"][i]))
        if stream == "camera_attitude":
            return AttitudeSample(t, np.array([s["roll_rad"][i], s["tilt_rad"][i], np.nan]), sensor="camera")
        if stream == "pan":
            return PanSample(t, float(s["pan_rad"][i]))
        if stream == "airspeed":
            return AirspeedSample(t, float(s["airspeed_mps"][i]))
        if stream == "click":
            return OperatorClick(t, np.array([s["u_px"][i], s["v_px"][i]]))
        if stream == "telemetry":
            return TelemetrySample(t, np.array([s["n_m"][i], s["e_m"][i], s["d_m"][i]]), float(s["heading_rad"][i]),
                                   float(s["height_m"][i]), float(s["ground_speed_mps"][i]))
        if stream == "link":
            raise ValueError("link.csv rows are deliveries of the navigator's own fixes, not measurements")
        return self._frame(t + self.time_offset_s, s, i)

    def image(self, i: int) -> tuple[np.ndarray | None, str | None]:
        """Frame ``i`` decoded to 8-bit gray, or (None, why it cannot be used)."""
        import cv2

        f = self.path / str(self.streams["frames"]["file"][i])
        if self.images is not None:
            img = self.images[i]
        elif f.suffix.lower() in VIDEO_SUFFIXES:
            img = self._video_frame(f, i)
        else:
            img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
        if img is not None and img.ndim == 2 and self.color:
            img = cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
        elif img is not None and img.ndim == 3 and self.color:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB if img.shape[2] == 3 else cv2.COLOR_BGRA2RGB)
        elif img is not None and img.ndim == 3:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
        cam = self.camera.camera if self.camera else None
        why = ("cannot be decoded" if img is None else f"is {img.dtype}, not 8-bit" if img.dtype != np.uint8 else
               f"is {img.shape[1]}x{img.shape[0]}, camera.yaml says {cam.width}x{cam.height}"
               if cam is not None and img.shape[:2] != (cam.height, cam.width) else None)
        return (img, None) if why is None else (None, f"{f}: {why}")

    def _video_frame(self, f: Path, i: int):
        """Frame ``video_frame[i]`` (default: the row's rank among the rows of this file) of a video file,
        read sequentially (a seek only when going back)."""
        import cv2

        fr = self.streams["frames"]
        if "video_frame" in fr:
            n = int(fr["video_frame"][i])
        else:
            n = int(np.count_nonzero(fr["file"][:i] == fr["file"][i]))
        cap, nxt = self._video.get(str(f), (None, 0))
        if cap is None or n < nxt:
            cap = cv2.VideoCapture(str(f))
            if n:
                cap.set(cv2.CAP_PROP_POS_FRAMES, n)
            nxt = n
        while nxt < n and cap.grab():
            nxt += 1
        ok, img = cap.read()
        self._video[str(f)] = (cap, nxt + 1)
        return img if ok else None

    def _frame(self, t: float, s, i: int):
        img, why = self.image(i)
        if img is None:
            self.skipped["frames"] = self.skipped.get("frames", 0) + 1
            if len(self.notes) < 20:
                self.notes.append(f"{why}; frame skipped")
            return None
        idx = int(s["index"][i]) if "index" in s else i
        return Frame(t, img, idx)


def _convert(streams: dict, d: Path) -> None:
    """Alternative columns into the canonical ones: GPS in latitude / longitude (NED about the first fix;
    velocity by central differences when absent), magnetometer field vectors (tilt-compensated heading
    with attitude.csv)."""

    g = streams.get("gps")
    if g is not None and "n_m" not in g:
        vel = np.column_stack([g[k] for k in ("vn_mps", "ve_mps", "vd_mps")]) if "vn_mps" in g else None
        keep = {k: v for k, v in g.items() if k in ("sigma_m", "t_recv_s", "seq")}
        streams["gps"] = gps_stream(g["t_s"], g["lat_deg"], g["lon_deg"], g["alt_m"], vel) | keep
    elif g is not None and "vn_mps" not in g:
        ned = np.column_stack([g["n_m"], g["e_m"], g["d_m"]])
        v = np.column_stack([np.gradient(ned[:, j], g["t_s"]) for j in range(3)]) if len(ned) > 1 else 0 * ned
        g.update(vn_mps=v[:, 0], ve_mps=v[:, 1], vd_mps=v[:, 2])
    m = streams.get("magnetometer")
    if m is not None and "heading_rad" not in m:
        if "attitude" not in streams:
            raise RecordingError(f"{d / 'magnetometer.csv'}: field vectors (mx, my, mz) need attitude.csv for the "
                                 "tilt compensation; or give heading_rad")
        keep = {k: v for k, v in m.items() if k in ("t_recv_s", "seq")}
        streams["magnetometer"] = heading_stream(m["t_s"], np.column_stack([m["mx"], m["my"], m["mz"]]),
                                                 streams["attitude"]) | keep


VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov", ".m4v")
STREAM_ORDER = {n: j for j, n in enumerate(STREAMS)}
STREAM_NAMES = list(STREAMS)
