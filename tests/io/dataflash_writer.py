"""A DataFlash (ArduPilot ``.bin``) writer for the reader's tests. The format describes itself: every message
is 0xA3 0x95, a type id, then the fields packed little-endian; FMT messages (type 128, length 89: Type,
Length, Name[4], Format[16], Columns[64]) define each type's format chars and column names. Newer logs add
UNIT / MULT / FMTU messages (the unit and the multiplier of every column)."""

from __future__ import annotations

import struct

# DataFlash format char -> struct char (c, C: int16 / uint16 x100; e, E: int32 / uint32 x100; L: lat/lon 1e-7)
_STRUCT = {"b": "b", "B": "B", "h": "h", "H": "H", "i": "i", "I": "I", "f": "f", "d": "d", "n": "4s", "N": "16s",
           "Z": "64s", "c": "h", "C": "H", "e": "i", "E": "I", "L": "i", "M": "B", "q": "q", "Q": "Q"}
HEAD = b"\xa3\x95"
FMT_TYPE = 128


class DataFlashWriter:
    """``fmt(name, format, columns)`` defines a type; ``msg(name, *values)`` writes one message;
    ``fmtu(name, units, mults)`` with ``mult(id, factor)`` describe the multipliers (newer logs)."""

    def __init__(self):
        self.types: dict[str, tuple[int, str]] = {}
        self.out = bytearray()
        self._fmt_row(FMT_TYPE, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns")

    def _fmt_row(self, tid: int, name: str, fmt: str, cols: str) -> None:
        length = 3 + struct.calcsize("<" + "".join(_STRUCT[c] for c in fmt))
        self.out += HEAD + bytes([FMT_TYPE]) + struct.pack("<BB4s16s64s", tid, length, name.encode(), fmt.encode(),
                                                            cols.encode())
        self.types[name] = (tid, fmt)

    def fmt(self, name: str, fmt: str, cols: str) -> None:
        self._fmt_row(FMT_TYPE + 1 + len(self.types), name, fmt, cols)

    def msg(self, name: str, *values) -> None:
        tid, fmt = self.types[name]
        vals = [v.encode() if isinstance(v, str) else v for v in values]
        self.out += HEAD + bytes([tid]) + struct.pack("<" + "".join(_STRUCT[c] for c in fmt), *vals)

    def mult(self, ident: str, factor: float) -> None:
        if "MULT" not in self.types:
            self.fmt("MULT", "Qbd", "TimeUS,Id,Mult")
        self.msg("MULT", 0, ord(ident), factor)

    def fmtu(self, name: str, units: str, mults: str) -> None:
        if "FMTU" not in self.types:
            self.fmt("FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds")
        self.msg("FMTU", 0, self.types[name][0], units, mults)

    def bytes(self) -> bytes:
        return bytes(self.out)
