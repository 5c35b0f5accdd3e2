"""A folder of geotagged photos (a photo survey) read as a ``Recording``.

The folder holds JPEG (or TIFF) photos, directly or in ``images/``, and optionally a ``camera.yaml``
(``docs/recordings.md``; a camera.yaml without a mount is taken as a nadir camera, image top = forward).
From each photo's EXIF (Pillow):

* time: ``DateTimeOriginal`` (+ ``SubSecTimeOriginal``), else the GPS time stamp, else ``DateTime``;
  ``t_s`` counts from the first photo;
* GPS: latitude, longitude, altitude (MSL; ``GPSAltitudeRef`` 1 = below sea level) -> the ``gps``
  stream (NED about the first fix, velocity by central differences);
* ``Orientation``: applied when the photo is decoded (OpenCV honours the EXIF orientation);
* DJI XMP (``drone-dji:GimbalRollDegree`` / ``GimbalPitchDegree`` / ``GimbalYawDegree``, ``FlightRollDegree``
  ...): the vehicle's attitude (``attitude`` stream) and the gimbal's roll and depression
  (``camera_attitude``) when present;
* the focal length when there is no camera.yaml: ``FocalLengthIn35mmFilm`` (35 mm film diagonal 43.27 mm
  against the image diagonal), else ``FocalLength`` x ``FocalPlaneXResolution`` (scaled by the stored
  width over ``PixelXDimension``); principal point at the centre, no distortion: approximate.

Photos of another size than the camera's (a camera that stored one photo at another resolution) are
scaled to it when the aspect ratio agrees; another aspect ratio makes that frame unusable (skipped with a note).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.io.recording import CameraInfo, Recording, RecordingError, read_camera_yaml
from visnav.io.streams import gps_stream

PHOTO_SUFFIXES = (".jpg", ".jpeg", ".tif", ".tiff")
NADIR = FixedMount.depressed(90.0)  # optical axis = body down, image top = body forward
_DIAG_35MM = math.hypot(36.0, 24.0)  # 43.27 mm
_UNIT_MM = {2: 25.4, 3: 10.0, 4: 1.0, 5: 1e-3}  # FocalPlaneResolutionUnit -> mm per unit (1: none, taken as inch)
_DJI = re.compile(rb'drone-dji:(\w+)(?:="([^"]*)"|>([^<]*)<)')


@dataclass
class PhotoInfo:
    """What the EXIF of one photo says (NaN where absent)."""

    file: str
    time: datetime | None
    lat_deg: float = float("nan")
    lon_deg: float = float("nan")
    alt_m: float = float("nan")
    orientation: int = 1
    width: int = 0  # as stored (before the EXIF orientation)
    height: int = 0
    focal_mm: float = float("nan")
    focal_35mm: float = float("nan")
    focal_plane_px_per_mm: float = float("nan")
    pixel_x_dimension: int = 0
    dji: dict[str, float] = field(default_factory=dict)

    @property
    def has_gps(self) -> bool:
        return math.isfinite(self.lat_deg) and math.isfinite(self.lon_deg) and math.isfinite(self.alt_m)


def photo_files(folder: Path) -> list[Path]:
    """The photos of a survey folder (directly in it, else in ``images/``), sorted by name."""
    for d in (folder, folder / "images"):
        if d.is_dir():
            fs = sorted(f for f in d.iterdir() if f.suffix.lower() in PHOTO_SUFFIXES and f.is_file())
            if fs:
                return fs
    return []


def is_photo_folder(folder: Path) -> bool:
    """A folder of photos without the recording CSVs (no ``frames.csv``)."""
    return folder.is_dir() and not (folder / "frames.csv").is_file() and bool(photo_files(folder))


def _ratio(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError, ZeroDivisionError):
        return float("nan")


def _dms(v, ref) -> float:
    """Degrees, minutes, seconds (EXIF rationals) with N/S/E/W."""
    try:
        d, m, s = (_ratio(x) for x in v)
    except (TypeError, ValueError):
        return float("nan")
    deg = d + m / 60.0 + s / 3600.0
    return -deg if str(ref).strip().upper() in ("S", "W") else deg


def _exif_time(s, subsec=None, offset=None) -> datetime | None:
    if not isinstance(s, str):
        return None
    try:
        t = datetime.strptime(s.strip().rstrip("\x00")[:19], "%Y:%m:%d %H:%M:%S")
    except ValueError:
        return None
    if isinstance(subsec, str) and subsec.strip().rstrip("\x00").isdigit():
        digits = subsec.strip().rstrip("\x00")
        t += timedelta(seconds=int(digits) / 10 ** len(digits))
    m = re.fullmatch(r"([+-])(\d\d):(\d\d)", str(offset or "").strip().rstrip("\x00"))
    if m:  # to UTC
        sign = 1 if m.group(1) == "+" else -1
        t -= sign * timedelta(hours=int(m.group(2)), minutes=int(m.group(3)))
    return t.replace(tzinfo=timezone.utc)


def _gps_time(g) -> datetime | None:
    date, hms = g.get(29), g.get(7)
    if not isinstance(date, str) or hms is None:
        return None
    try:
        h, mi, s = (_ratio(x) for x in hms)
        d = datetime.strptime(date.strip().rstrip("\x00"), "%Y:%m:%d").replace(tzinfo=timezone.utc)
    except (TypeError, ValueError):
        return None
    return d + timedelta(hours=h, minutes=mi, seconds=s) if all(map(math.isfinite, (h, mi, s))) else None


def read_exif(path: Path) -> PhotoInfo:
    """The EXIF of one photo (``RecordingError`` when Pillow cannot open it)."""
    from PIL import Image, UnidentifiedImageError
    from PIL.ExifTags import IFD

    try:
        with Image.open(path) as im:
            w, h = im.size
            ex = im.getexif()
            g, e = ex.get_ifd(IFD.GPSInfo), ex.get_ifd(IFD.Exif)
    except (OSError, UnidentifiedImageError, SyntaxError) as exc:
        raise RecordingError(f"{path}: cannot read the photo ({exc})") from None
    t = (_exif_time(e.get(36867), e.get(37521), e.get(36881)) or _gps_time(g)
         or _exif_time(ex.get(306), e.get(37520), e.get(36880)))
    info = PhotoInfo(str(path), t, orientation=int(ex.get(274, 1) or 1), width=w, height=h)
    if 2 in g and 4 in g:
        info.lat_deg, info.lon_deg = _dms(g[2], g.get(1, "N")), _dms(g[4], g.get(3, "E"))
        alt = _ratio(g.get(6))
        info.alt_m = -alt if g.get(5) in (1, b"\x01") else alt
    info.focal_mm = _ratio(e.get(37386))
    info.focal_35mm = _ratio(e.get(41989)) if e.get(41989) else float("nan")
    res, unit = _ratio(e.get(41486)), _UNIT_MM.get(int(e.get(41488, 2) or 2), 25.4)
    info.focal_plane_px_per_mm = res / unit
    info.pixel_x_dimension = int(e.get(40962, 0) or 0)
    with open(path, "rb") as fh:  # DJI's XMP packet sits in the first APP1 segments
        head = fh.read(1 << 17)
    for m in _DJI.finditer(head):
        v = _ratio((m.group(2) or m.group(3) or b"").decode("ascii", "replace"))
        if math.isfinite(v):
            info.dji[m.group(1).decode()] = v
    return info


def exif_camera(info: PhotoInfo, width: int, height: int) -> tuple[PinholeCamera, str]:
    """The pinhole camera of a photo ``width`` x ``height`` (as decoded) from its EXIF focal length, and how."""
    if math.isfinite(info.focal_35mm) and info.focal_35mm > 0:
        f = info.focal_35mm / _DIAG_35MM * math.hypot(width, height)
        how = f"FocalLengthIn35mmFilm {info.focal_35mm:g} mm"
    elif math.isfinite(info.focal_mm) and math.isfinite(info.focal_plane_px_per_mm) and info.focal_plane_px_per_mm > 0:
        stored_w = max(info.width, info.height) if width >= height else min(info.width, info.height)
        scale = stored_w / info.pixel_x_dimension if info.pixel_x_dimension else 1.0
        f = info.focal_mm * info.focal_plane_px_per_mm * scale * width / stored_w
        how = f"FocalLength {info.focal_mm:g} mm x FocalPlaneXResolution"
    else:
        raise RecordingError(f"{info.file}: no camera.yaml beside the photos and no focal length in the EXIF "
                             "(FocalLengthIn35mmFilm, or FocalLength with FocalPlaneXResolution)")
    return PinholeCamera.ideal(width, height, f), how


class PhotoRecording(Recording):
    """A ``Recording`` whose frames are photos decoded with their EXIF orientation and scaled to the camera."""

    def image(self, i: int):
        import cv2

        f = self.path / str(self.streams["frames"]["file"][i])
        img = cv2.imread(str(f), cv2.IMREAD_COLOR if self.color else cv2.IMREAD_GRAYSCALE)  # honours EXIF orientation
        if img is None:
            return None, f"{f}: cannot be decoded"
        if self.color:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
        cam = self.camera.camera
        h, w = img.shape[:2]
        if (w, h) != (cam.width, cam.height):
            if abs(w / h - cam.width / cam.height) > 0.01 * cam.width / cam.height:
                return None, f"{f}: is {w}x{h}, camera {cam.width}x{cam.height} (another aspect ratio)"
            img = cv2.resize(img, (cam.width, cam.height), interpolation=cv2.INTER_AREA if w > cam.width
                             else cv2.INTER_LINEAR)
        return img, None


def read_photos(folder: str | Path) -> PhotoRecording:
    """A folder of geotagged photos as a ``Recording`` (frames, gps; attitude / camera_attitude from DJI XMP)."""

    d = Path(folder)
    files = photo_files(d)
    if not files:
        raise RecordingError(f"{d}: no photos ({', '.join(PHOTO_SUFFIXES)}) in the folder or in images/")
    notes: list[str] = []
    infos = []
    for f in files:
        try:
            info = read_exif(f)
        except RecordingError as exc:
            notes.append(f"{exc}; photo skipped")
            continue
        if info.time is None:
            notes.append(f"{f}: no time in the EXIF (DateTimeOriginal, GPS time or DateTime); photo skipped")
            continue
        infos.append(info)
    if not infos:
        raise RecordingError(f"{d}: none of the {len(files)} photos has a readable EXIF time"
                             + (f" ({notes[0]})" if notes else ""))
    infos.sort(key=lambda p: (p.time, p.file))
    t0 = infos[0].time
    t = np.array([(p.time - t0).total_seconds() for p in infos])
    rel = [str(Path(p.file).relative_to(d)) for p in infos]
    streams: dict[str, dict[str, np.ndarray]] = {
        "frames": {"t_s": t, "file": np.array(rel), "index": np.arange(len(infos), dtype=float)}}
    gi = [i for i, p in enumerate(infos) if p.has_gps]
    if gi:
        lat, lon, alt = (np.array([getattr(infos[i], k) for i in gi]) for k in ("lat_deg", "lon_deg", "alt_m"))
        streams["gps"] = gps_stream(t[gi], lat, lon, alt) | {"sigma_m": np.full(len(gi), 3.0)}
        if len(gi) < len(infos):
            notes.append(f"{len(infos) - len(gi)} of {len(infos)} photos carry no GPS position")
    ai = [i for i, p in enumerate(infos) if {"FlightRollDegree", "FlightPitchDegree", "FlightYawDegree"} <= set(p.dji)]
    if ai:
        att = np.radians([[infos[i].dji[k] for k in ("FlightRollDegree", "FlightPitchDegree", "FlightYawDegree")]
                          for i in ai])
        streams["attitude"] = {"t_s": t[ai], "roll_rad": att[:, 0], "pitch_rad": att[:, 1], "yaw_rad": att[:, 2]}
    ci = [i for i, p in enumerate(infos) if {"GimbalRollDegree", "GimbalPitchDegree"} <= set(p.dji)]
    if ci:  # depression = -gimbal pitch (DJI: -90 = nadir)
        streams["camera_attitude"] = {"t_s": t[ci],
                                      "roll_rad": np.radians([infos[i].dji["GimbalRollDegree"] for i in ci]),
                                      "tilt_rad": -np.radians([infos[i].dji["GimbalPitchDegree"] for i in ci])}
    if (d / "camera.yaml").is_file():
        cam = read_camera_yaml(d / "camera.yaml", default_mount=NADIR)
    else:
        import cv2

        first = cv2.imread(infos[0].file, cv2.IMREAD_GRAYSCALE)  # as decoded (EXIF orientation applied)
        if first is None:
            raise RecordingError(f"{infos[0].file}: cannot be decoded")
        pc, how = exif_camera(infos[0], first.shape[1], first.shape[0])
        cam = CameraInfo(pc, NADIR)
        notes.append(f"no camera.yaml: focal length {pc.fx:.1f} px from the EXIF ({how}), principal point at the "
                     "centre, no distortion, nadir mount (approximate)")
    rec = PhotoRecording(d, cam, streams, notes=notes)
    rec.photos = infos
    return rec
