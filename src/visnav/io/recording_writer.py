"""``RecordingWriter``: what ``visnav record`` uses to write the folder of ``io/recording.py``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.io.recording import (COMMANDS, DELIVERY, STREAMS, TRUTH, RecordingError, stream_of, write_camera_yaml,
                                 write_csv)


class RecordingWriter:
    """Collects measurements in delivery order and writes the folder (frames as lossless PNG)."""

    def __init__(self, out_dir: str | Path, image_writer=None):
        """``image_writer(path, image) -> bool``: how a frame is written (default ``cv2.imwrite`` now; the
        bridge passes one that writes on a background thread)."""
        self.dir = Path(out_dir)
        self.image_writer = image_writer
        try:
            (self.dir / "frames").mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise RecordingError(f"{out_dir}: cannot create the recording folder ({exc.strerror or exc})") from None
        self.rows: dict[str, list] = {k: [] for k in STREAMS}
        self.commands: list = []
        self.seq = 0

    def next_seq(self) -> int:
        self.seq += 1
        return self.seq

    def add(self, m, t_recv: float, seq: int) -> None:
        import cv2

        kind = stream_of(m)
        if kind is None:
            raise RecordingError(f"cannot record a {type(m).__name__}")
        if kind == "frames":
            name = f"frames/{len(self.rows['frames']):06d}.png"
            img = np.asarray(m.image)
            if img.ndim == 3:  # colour frames are RGB in memory; a PNG holds BGR for cv2
                img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
            if not (self.image_writer or cv2.imwrite)(str(self.dir / name), img):
                raise RecordingError(f"{self.dir / name}: cannot write the frame")
            row = (m.t, name, m.index)
        elif kind == "imu":
            row = (m.t, *m.accel, *m.gyro)
        elif kind == "attitude":
            row = (m.t, *m.euler)
        elif kind == "gps":
            row = (m.t, *m.position, *m.velocity, m.sigma)
        elif kind == "range":
            row = (m.t, m.range, m.sensor, m.beam_offset)
        elif kind == "baro":
            row = (m.t, m.altitude)
        elif kind == "magnetometer":
            row = (m.t, m.heading)
        elif kind == "camera_attitude":
            row = (m.t, m.euler[0], m.euler[1])
        elif kind == "pan":
            row = (m.t, m.pan)
        elif kind == "airspeed":
            row = (m.t, m.airspeed)
        elif kind == "click":
            row = (m.t, *m.pixel)
        elif kind == "telemetry":
            row = (m.t, *m.position, m.heading, m.height, m.ground_speed)
        else:  # link: a fix the navigator made, delivered back to it; the replay's navigator makes its own
            row = (m.t,)
        self.rows[kind].append((*row, t_recv, seq))

    def add_command(self, t: float, seq: int, method: str, args=(), kwargs=None) -> None:
        text = json.dumps({"args": _plain(args), "kwargs": _plain(kwargs or {})}) if (args or kwargs) else ""
        self.commands.append((t, seq, method, text))

    def close(self, camera: PinholeCamera, mount: FixedMount | None, time_offset_s: float = 0.0, truth: dict | None = None,
              scenario_toml: str | None = None) -> Path:
        write_camera_yaml(self.dir / "camera.yaml", camera, mount, time_offset_s)
        for kind, spec in STREAMS.items():
            rows = self.rows[kind]
            if not rows:
                continue
            names = list(spec.columns) + list(DELIVERY)
            cols = list(zip(*rows))
            data = {}
            for n, c in zip(names, cols):
                data[n] = np.array(c, dtype=object if n in spec.text else float)
                if n in ("seq", "index"):
                    data[n] = np.array(c, dtype=np.int64)
            write_csv(self.dir / spec.file, data)
        if self.commands:
            t, seq, meth, args = zip(*self.commands)
            write_csv(self.dir / COMMANDS.file, {"t_s": np.array(t, float), "seq": np.array(seq, np.int64),
                                                 "method": np.array(meth, object), "args": np.array(args, object)})
        if truth:
            write_csv(self.dir / TRUTH.file, {k: np.asarray(v, float) for k, v in truth.items()})
        if scenario_toml is not None:
            (self.dir / "scenario.toml").write_text(scenario_toml)
        return self.dir


def _plain(x):
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    return x
