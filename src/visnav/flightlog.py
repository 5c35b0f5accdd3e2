"""FlightLog: every stream of a run (truth, measurements, estimates, commands, modes), one HDF5 group each.

A leaf beside ``log_schema.py`` (it imports nothing of visnav but the stream documentation): the loop
(``app/loop.py``) writes it, ``analysis`` scores it, ``app/replay.py`` and the command line read it back, and
a test feeds any component's recorder with one, without importing the simulation.

Every field of a stream is documented by a ``Field(unit, frame, description)``, written as the ``units``,
``frame`` and ``description`` attributes of its HDF5 dataset (layout: ``docs/log-format.md``). A
simulation passes the streams it records itself as ``FlightLog(schema=...)`` (the same stream name can
mean another frame in another simulation: ``truth`` is the relative deck state in a deck run); a
component that records through a recorder callback (navigator, mission manager, controller) registers its
streams once with ``register_stream`` next to its record calls. A field documented nowhere gets units "".
Units: SI; "1" for dimensionless numbers and counts, "bool" for flags, "text" for strings.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from visnav.log_schema import STREAMS, T_FIELD, UNDOCUMENTED, Field, register_stream  # noqa: F401  (re-exported)


class FlightLog:
    def __init__(self, schema: dict[str, dict[str, tuple]] | None = None) -> None:
        self._streams: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
        self._cache: dict[str, dict[str, np.ndarray]] = {}
        #: this log's own stream -> field -> Field (before the registered ``STREAMS``)
        self.schema: dict[str, dict[str, Field]] = {
            s: {k: Field(*v) for k, v in f.items()} for s, f in (schema or {}).items()}

    def set_schema(self, schema: dict[str, dict[str, tuple]]) -> None:
        """This log's own streams (a simulation knows them once its builder said which system flies)."""
        self.schema = {s: {k: Field(*v) for k, v in f.items()} for s, f in schema.items()}

    def field(self, stream: str, name: str) -> Field:
        """Unit, frame and description of one field (``UNDOCUMENTED``: units "" when nobody documented it)."""
        own = self.schema.get(stream, {}).get(name) or STREAMS.get(stream, {}).get(name)
        if own is not None:
            return own
        return T_FIELD if name == "t" else UNDOCUMENTED

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
                        d = g.create_dataset(k, data=np.array([str(x) for x in v], dtype=h5py.string_dtype()))
                    else:
                        d = g.create_dataset(k, data=v, compression="gzip" if v.size > 1000 else None)
                    unit, frame, desc = self.field(name, k)
                    d.attrs["units"], d.attrs["frame"], d.attrs["description"] = unit, frame, desc
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
                    if "units" in d.attrs:
                        log.schema.setdefault(name, {})[k] = Field(*(str(d.attrs.get(a, "")) for a in (
                            "units", "frame", "description")))
                    data = d[()]
                    if d.dtype.kind in "OS":
                        data = [x.decode() if isinstance(x, bytes) else str(x) for x in data]
                    s[k] = list(data)
        return log
