"""Live frame sources for the bridge: anything ``cv2.VideoCapture`` opens, a folder of images, or a callable.

``vnframes://HOST:PORT`` is a frame stream over TCP with the sender's exposure stamps (the SIL camera).
Every frame is stamped in our monotonic clock at capture: ``t = monotonic() + time_offset_s`` (the
camera.yaml ``time_offset_s`` of the recorded-flight format: t_imu = t_camera + time_offset_s; a
negative value says the frame describes an instant before it reached us). ``capture_t`` (the instant
the frame reached us) is kept separately: the latency budget is measured from it.
"""

from __future__ import annotations

import math
import struct
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import socket
import queue
import threading

IMAGE_EXT = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm")


class CameraSourceError(RuntimeError):
    """A camera that cannot be opened; one line naming it."""


@dataclass(frozen=True)
class Captured:
    image: np.ndarray  # uint8 HxW
    t: float  # the instant the frame describes (exposure), our clock [s]
    capture_t: float  # when it reached us [s]
    index: int


def read_time_offset(camera_yaml: str | Path | None) -> float:
    """``time_offset_s`` of a camera.yaml (recorded-flight format); 0 without a file.
    (Only the time offset is used live: the navigator's camera model comes from its scenario.)"""
    if camera_yaml is None:
        return 0.0
    import yaml

    p = Path(camera_yaml)
    if not p.is_file():
        raise CameraSourceError(f"{p}: camera.yaml not found")
    try:
        doc = yaml.safe_load(p.read_text()) or {}
        off = float(doc.get("time_offset_s", 0.0)) if isinstance(doc, dict) else float("nan")
    except (yaml.YAMLError, TypeError, ValueError):
        raise CameraSourceError(f"{p}: not a camera.yaml mapping with a numeric time_offset_s") from None
    if not math.isfinite(off):
        raise CameraSourceError(f"{p}: time_offset_s must be a finite number of seconds")
    return off


def _gray(img: np.ndarray) -> np.ndarray:
    import cv2

    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return img.astype(np.uint8, copy=False)


class FrameSource:
    """Base: ``read()`` blocks until the next frame and returns a Captured, or None at the end."""

    def __init__(self, time_offset_s: float = 0.0, clock: Callable[[], float] = time.monotonic):
        self.time_offset_s, self.clock, self.index = float(time_offset_s), clock, 0

    def _stamp(self, image: np.ndarray, exposed: float | None = None) -> Captured:
        now = self.clock()
        c = Captured(_gray(image), (now if exposed is None else exposed) + self.time_offset_s, now, self.index)
        self.index += 1
        return c

    def read(self) -> Captured | None:  # pragma: no cover - interface
        raise NotImplementedError

    def close(self) -> None:
        pass


class VideoSource(FrameSource):
    """``cv2.VideoCapture(source)``: a device index ("0"), a file, an RTSP or GStreamer URL. OpenCV's own log
    is silenced while it tries (its WARN lines for a missing device reach stderr from C++); a source that does
    not open raises CameraSourceError with one line."""

    def __init__(self, source: str, **kw):
        super().__init__(**kw)
        import cv2

        log = getattr(getattr(cv2, "utils", None), "logging", None)
        level = log.getLogLevel() if log is not None else None
        if log is not None:
            log.setLogLevel(log.LOG_LEVEL_SILENT)
        try:
            self.cap = cv2.VideoCapture(int(source) if source.isdigit() else source)
            ok = self.cap.isOpened()
        finally:
            if log is not None:
                log.setLogLevel(level)
        if not ok:
            self.cap.release()
            if source.isdigit():
                raise CameraSourceError(f"camera {source}: no video device answers at index {source} (is a camera "
                                        "connected?); on a desk give a folder of images: --camera FOLDER")
            raise CameraSourceError(f"camera {source!r}: cv2.VideoCapture cannot open it")

    def read(self) -> Captured | None:
        ok, img = self.cap.read()
        return self._stamp(img) if ok else None

    def close(self) -> None:
        self.cap.release()


class FolderSource(FrameSource):
    """Images of a folder in name order, paced at ``fps`` (a camera stand-in for bench tests)."""

    def __init__(self, folder: str | Path, fps: float = 10.0, **kw):
        super().__init__(**kw)
        import cv2

        self.files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in IMAGE_EXT)
        if not self.files:
            raise CameraSourceError(f"camera folder {folder}: no images ({', '.join(IMAGE_EXT)})")
        self._imread = cv2.imread
        self.period = 1.0 / fps
        self._next = None

    def read(self) -> Captured | None:
        if self.index >= len(self.files):
            return None
        now = self.clock()
        self._next = now if self._next is None else self._next
        if self._next > now:
            time.sleep(self._next - now)
        self._next += self.period
        img = self._imread(str(self.files[self.index]), 0)
        if img is None:
            raise CameraSourceError(f"{self.files[self.index]}: not a readable image")
        return self._stamp(img)


class CallableSource(FrameSource):
    """Frames from ``make(index, t) -> image or None`` showing our instant ``t`` (the exposure), paced at
    ``fps`` (the SIL camera renders the scene at ``t``; the frame arrives when the rendering is done)."""

    def __init__(self, make: Callable[[int], np.ndarray | None], fps: float = 20.0, **kw):
        super().__init__(**kw)
        self.make, self.period, self._next = make, 1.0 / fps, None

    def read(self) -> Captured | None:
        now = self.clock()
        self._next = now if self._next is None else self._next
        if self._next > now:
            time.sleep(self._next - now)
        self._next = max(self._next + self.period, self.clock() - self.period)
        exposed = self.clock()
        img = self.make(self.index, exposed)
        return None if img is None else self._stamp(img, exposed)


# ----------------------------------------------------------------------------- frames over a local socket
FRAME_STREAM_SCHEME = "vnframes://"
FRAME_HEADER = struct.Struct("<4sIdHH")  # magic b"VNF1", index, exposure [s, the host's CLOCK_MONOTONIC], w, h
FRAME_MAGIC = b"VNF1"


class FrameStreamSource(FrameSource):
    """``vnframes://HOST:PORT``: a camera that serves its frames over TCP (the SIL camera, ``FrameStreamServer``):
    per frame a header (``FRAME_HEADER``: magic, index, exposure instant in the host's CLOCK_MONOTONIC
    seconds, width, height) and width x height 8-bit gray pixels. The exposure stamp is the sender's:
    CLOCK_MONOTONIC is the same clock in every process of one machine, so this is for a camera process on the
    same computer (a hardware-stamped camera driver, the simulator). Connects with retries for
    ``connect_s``; CameraSourceError (one line) when nothing listens."""

    def __init__(self, spec: str, connect_s: float = 10.0, **kw):
        super().__init__(**kw)

        host, _, port = spec[len(FRAME_STREAM_SCHEME):].rpartition(":")
        try:
            addr = (host or "127.0.0.1", int(port))
        except ValueError:
            raise CameraSourceError(f"camera {spec!r}: expected {FRAME_STREAM_SCHEME}HOST:PORT") from None
        t_end = time.monotonic() + connect_s
        while True:
            try:
                self.sock = socket.create_connection(addr, timeout=1.0)
                break
            except OSError as e:
                if time.monotonic() >= t_end:
                    raise CameraSourceError(f"camera {spec!r}: cannot connect ({e.strerror or e})") from None
                time.sleep(0.1)
        self.sock.settimeout(None)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.spec = spec

    def _recv(self, n: int) -> bytes | None:
        buf = bytearray()
        while len(buf) < n:
            try:
                chunk = self.sock.recv(n - len(buf))
            except OSError:
                return None
            if not chunk:
                return None
            buf += chunk
        return bytes(buf)

    def read(self) -> Captured | None:
        head = self._recv(FRAME_HEADER.size)
        if head is None:
            return None
        magic, index, exposed, w, h = FRAME_HEADER.unpack(head)
        if magic != FRAME_MAGIC:
            raise CameraSourceError(f"camera {self.spec!r}: not a visnav frame stream (magic {magic!r})")
        px = self._recv(w * h)
        if px is None:
            return None
        now = self.clock()
        self.index = index + 1
        return Captured(np.frombuffer(px, np.uint8).reshape(h, w), exposed + self.time_offset_s, now, int(index))

    def close(self) -> None:
        try:
            self.sock.close()
        except OSError:
            pass


class FrameStreamServer:
    """The sending side of ``FrameStreamSource`` (the SIL camera): listens on ``host:port`` (0: a free port),
    accepts one reader, sends frames from a bounded queue on its own thread (a slow reader drops frames,
    counted in ``dropped``, instead of stalling the sender)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, queue_size: int = 8):
        self.srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.srv.bind((host, port))
        self.srv.listen(1)
        self.port = self.srv.getsockname()[1]
        self.url = f"{FRAME_STREAM_SCHEME}{host}:{self.port}"
        self.q: queue.Queue = queue.Queue(maxsize=queue_size)
        self.dropped = self.sent = 0
        self.conn = None
        self._stop = threading.Event()
        self._th = threading.Thread(target=self._serve, daemon=True, name="frame-stream")
        self._th.start()

    def send(self, image: np.ndarray, exposed_monotonic: float, index: int) -> None:
        try:
            self.q.put_nowait((np.ascontiguousarray(image, np.uint8), float(exposed_monotonic), int(index)))
        except queue.Full:
            self.dropped += 1

    def _serve(self) -> None:
        self.srv.settimeout(0.2)
        while not self._stop.is_set() and self.conn is None:
            try:
                self.conn, _ = self.srv.accept()
                self.conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            except socket.timeout:
                continue
            except OSError:
                return
        while not self._stop.is_set():
            try:
                img, t, i = self.q.get(timeout=0.1)
            except queue.Empty:
                continue
            h, w = img.shape[:2]
            try:
                self.conn.sendall(FRAME_HEADER.pack(FRAME_MAGIC, i, t, w, h) + img.tobytes())
                self.sent += 1
            except OSError:
                return

    def close(self) -> None:
        self._stop.set()
        self._th.join(timeout=1.0)
        for s in (self.conn, self.srv):
            if s is not None:
                try:
                    s.close()
                except OSError:
                    pass


def open_source(spec: str, fps: float = 10.0, time_offset_s: float = 0.0) -> FrameSource:
    """``vnframes://HOST:PORT`` -> FrameStreamSource, a folder -> FolderSource, anything else -> VideoSource."""
    if spec.startswith(FRAME_STREAM_SCHEME):
        return FrameStreamSource(spec, time_offset_s=time_offset_s)
    p = Path(spec)
    if p.is_dir():
        return FolderSource(p, fps=fps, time_offset_s=time_offset_s)
    if not spec.isdigit() and "://" not in spec and "!" not in spec and not p.exists():
        raise CameraSourceError(f"camera {spec!r}: no such file, folder or device index")
    return VideoSource(spec, time_offset_s=time_offset_s)
