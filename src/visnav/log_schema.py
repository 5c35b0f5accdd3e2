"""What every logged field means: ``Field(unit, frame, description)`` and the registry of the streams that
components record through a recorder callback (navigators, mission managers, controllers, sensors).

A leaf module (it imports nothing of visnav), so that any layer may document the streams it records
without importing the simulation; ``flightlog.py`` writes these as HDF5 attributes (``docs/log-format.md``).
"""

from __future__ import annotations

from typing import NamedTuple


class Field(NamedTuple):
    unit: str
    frame: str = ""
    description: str = ""


#: stream -> field -> Field, from the components that record through a recorder (``register_stream``)
STREAMS: dict[str, dict[str, Field]] = {}
#: every stream's ``t`` (DESIGN §3: the instant a row describes)
T_FIELD = Field("s", "simulation time", "the instant the row describes")
UNDOCUMENTED = Field("", "", "")


def register_stream(stream: str, **fields) -> None:
    """Document the fields of a stream recorded through a recorder callback: ``name=(unit, frame, description)``."""
    STREAMS.setdefault(stream, {}).update({k: Field(*v) for k, v in fields.items()})


register_stream("mode", mode=("text", "", "mission mode entered at t"), previous=("text", "", "the mode it left"),
                reason=("text", "", "why"))
register_stream("error", message=("text", "", "what stopped the run early"))
