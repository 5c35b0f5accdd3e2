"""FlightLog: every stream of a run (truth, measurements, estimates, commands, modes), one HDF5 group each."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np


class FlightLog:
    def __init__(self) -> None:
        self._streams: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
        self._cache: dict[str, dict[str, np.ndarray]] = {}

    def record(self, stream: str, t: float, **fields) -> None:
        s = self._streams[stream]
        s["t"].append(float(t))
        for k, v in fields.items():
            s[k].append(v)
        self._cache.pop(stream, None)

    def streams(self) -> list[str]:
        return sorted(self._streams)

    def __contains__(self, stream: str) -> bool:
        return stream in self._streams and len(self._streams[stream]["t"]) > 0

    def get(self, stream: str) -> dict[str, np.ndarray]:
        """Arrays of one stream (empty dict when it never recorded)."""
        if stream not in self._streams:
            return {}
        if stream not in self._cache:
            out = {}
            for k, v in self._streams[stream].items():
                if v and isinstance(v[0], str):
                    out[k] = np.array(v, dtype=object)
                else:
                    out[k] = np.asarray(v)
            self._cache[stream] = out
        return self._cache[stream]

    def to_hdf5(self, path: str | Path, attrs: dict | None = None) -> None:
        import h5py

        with h5py.File(path, "w") as f:
            for name in self.streams():
                g = f.create_group(name)
                for k, v in self.get(name).items():
                    if v.dtype == object:
                        g.create_dataset(k, data=np.array([str(x) for x in v], dtype=h5py.string_dtype()))
                    else:
                        g.create_dataset(k, data=v, compression="gzip" if v.size > 1000 else None)
            for k, v in (attrs or {}).items():
                f.attrs[k] = v

    @classmethod
    def from_hdf5(cls, path: str | Path) -> "FlightLog":
        import h5py

        log = cls()
        with h5py.File(path, "r") as f:
            for name, g in f.items():
                s = log._streams[name]
                for k, d in g.items():
                    data = d[()]
                    if d.dtype.kind in "OS":
                        data = [x.decode() if isinstance(x, bytes) else str(x) for x in data]
                    s[k] = list(data)
        return log
