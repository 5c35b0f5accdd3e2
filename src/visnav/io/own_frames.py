"""Frames on their own clock beside a flight log: a frame folder or a video (MP4 via OpenCV) attached to an
opened recording as its ``frames`` stream (``visnav check / replay --frames``).

Frame times, on the frames' own clock, start at 0 at the first frame:
* a video: frame number / the container's frame rate (``--fps`` overrides it);
* a folder of images (PNG, JPEG) sorted by name: file names that are integer stamps are read as
  nanoseconds (16 digits or more) or microseconds (13 to 15 digits), names like ``12.345.png`` as
  seconds; other names need ``--fps``.

The offset to the log's clock (t_imu = t_frame + offset) is then found by ``--time-offset auto``
(``estimation/timesync.wide_offset`` over every lag, then ``calibrate_camera_imu``) or given in seconds.
The camera is the recording's (``camera.yaml`` / EuRoC ``sensor.yaml``) or ``--camera-yaml``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from visnav.io.recording import VIDEO_SUFFIXES, Recording, RecordingError, read_camera_yaml

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".pgm", ".bmp", ".tif", ".tiff")


def _stem_times(stems: list[str]) -> np.ndarray | None:
    if all(re.fullmatch(r"\d+\.\d+", s) for s in stems):
        return np.array([float(s) for s in stems])
    if all(re.fullmatch(r"\d{13,}", s) for s in stems):
        v = np.array([int(s) for s in stems], dtype=np.int64)
        scale = 1e-9 if min(len(s) for s in stems) >= 16 else 1e-6
        return (v - v[0]) * scale
    return None


def attach_frames(rec: Recording, path: str | Path, fps: float | None = None, camera_yaml: str | Path | None = None
                  ) -> Recording:
    """``rec`` with its frames replaced by those of ``path`` (module docstring); marks them as on their own clock."""
    import cv2

    p = Path(path)
    if camera_yaml is not None:
        cam = read_camera_yaml(Path(camera_yaml))
        rec.camera = cam
    if rec.camera is None:
        raise RecordingError(f"{p}: frames need a camera (intrinsics, mount): give --camera-yaml")
    if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES:
        cap = cv2.VideoCapture(str(p))
        if not cap.isOpened():
            raise RecordingError(f"{p}: cannot open the video (format or codec not supported by OpenCV)")
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        rate = fps or float(cap.get(cv2.CAP_PROP_FPS))
        cap.release()
        if n < 2 or not rate or rate <= 0:
            raise RecordingError(f"{p}: {n} frames at {rate} fps; give --fps")
        t = np.arange(n) / rate
        files = np.array([str(p.resolve())] * n)
        frames = {"t_s": t, "file": files, "index": np.arange(n, dtype=float), "video_frame": np.arange(n, dtype=float)}
    elif p.is_dir():
        imgs = sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES)
        if len(imgs) < 2:
            raise RecordingError(f"{p}: {len(imgs)} images ({', '.join(IMAGE_SUFFIXES)})")
        t = _stem_times([f.stem for f in imgs])
        if fps:
            t = np.arange(len(imgs)) / fps
        elif t is None:
            raise RecordingError(f"{p}: the file names are not time stamps (ns, us or seconds): give --fps")
        o = np.argsort(t, kind="stable")
        frames = {"t_s": (t - t[o[0]])[o], "file": np.array([str(imgs[i].resolve()) for i in o]),
                  "index": np.arange(len(o), dtype=float)}
    else:
        raise RecordingError(f"{p}: not a frame folder or a video ({', '.join(VIDEO_SUFFIXES)})")
    rec.streams["frames"] = frames
    rec.images = None
    rec._video = {}
    rec.frames_own_clock = True  # the check and --time-offset auto search every lag
    rec.notes.append(f"{len(frames['t_s'])} frames from {p} on their own clock (t = 0 at the first frame)")
    return rec
