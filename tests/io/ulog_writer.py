"""A minimal PX4 ULog writer for the reader's tests (the format of docs.px4.io "ULog File Format").

File header: ``ULog`` magic ``55 4c 6f 67 01 12 35``, version byte, uint64 start time [us]. Then
messages: uint16 payload size, uint8 type, payload. Definitions: ``B`` flag bits (compat[8],
incompat[8], appended_offsets[3] uint64), ``F`` format ("name:type field;type[n] field;"), ``P``
parameter (uint8 key length, "type name", value). Data: ``A`` add logged message (uint8 multi_id,
uint16 msg_id, name), ``D`` data (uint16 msg_id, the fields packed little-endian, no padding).
"""

from __future__ import annotations

import struct

_PACK = {"uint64_t": "Q", "int64_t": "q", "uint32_t": "I", "int32_t": "i", "uint16_t": "H", "int16_t": "h",
         "uint8_t": "B", "int8_t": "b", "float": "f", "double": "d", "bool": "?"}


def _msg(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


class ULogWriter:
    """``topic(name, [(type, field), ...])`` -> msg id; ``data(msg_id, timestamp_us, *values)``;
    ``bytes(appended_at=k)``: the k-th data message unfinished, then appended data (a fault log)."""

    def __init__(self, t0_us: int = 1_000_000):
        self.t0 = t0_us
        self.formats: list[bytes] = []
        self.params: list[bytes] = []
        self.adds: list[bytes] = []
        self.data_msgs: list[bytes] = []
        self._structs: dict[int, str] = {}

    def topic(self, name: str, fields: list[tuple[str, str]], multi_id: int = 0) -> int:
        """Fields after the leading ``uint64_t timestamp``; an array field is ``("float", "q[4]")``."""
        spec = f"{name}:uint64_t timestamp;" + "".join(  # an array: "float[3] gyro_rad"
            f"{t}{f[f.index('['):]} {f[:f.index('[')]};" if "[" in f else f"{t} {f};" for t, f in fields)
        if spec.encode() not in self.formats:
            self.formats.append(spec.encode())
        fmt = "<Q"
        for t, f in fields:
            count = int(f[f.index("[") + 1:-1]) if "[" in f else 1
            fmt += _PACK[t] * count
        msg_id = len(self.adds)
        self.adds.append(_msg(b"A", struct.pack("<BH", multi_id, msg_id) + name.encode()))
        self._structs[msg_id] = fmt
        return msg_id

    def param(self, name: str, value: float) -> None:
        key = f"float {name}".encode()
        self.params.append(_msg(b"P", struct.pack("<B", len(key)) + key + struct.pack("<f", value)))

    def data(self, msg_id: int, timestamp_us: int, *values) -> None:
        self.data_msgs.append((int(timestamp_us), _msg(b"D", struct.pack("<H", msg_id)
                                   + struct.pack(self._structs[msg_id], int(timestamp_us), *values))))

    def bytes(self, appended_at: int | None = None) -> bytes:
        """The file, data messages in time order (as the logger writes them)."""
        msgs = [m for _, m in sorted(self.data_msgs, key=lambda x: x[0])]
        head = b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", self.t0)
        defs = b"".join(_msg(b"F", f) for f in self.formats) + b"".join(self.params)
        body = b"".join(self.adds) + b"".join(msgs[:appended_at])
        if appended_at is None:
            flags = _msg(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
            return head + flags + defs + body
        # appended data as PX4 writes it after a hard fault: the logger's last message was never finished
        # (half of it is in the file), then at the appended offset an info-multiple 'M' message (the fault log)
        partial = msgs[appended_at][: len(msgs[appended_at]) // 2]
        offset = len(head) + 43 + len(defs) + len(body) + len(partial)
        flags = _msg(b"B", bytes(8) + bytes([1]) + bytes(7) + struct.pack("<3Q", offset, 0, 0))  # incompat bit 0
        text = b"-- hardfault log --"
        key = f"char[{len(text)}] hardfault_plain".encode()
        fault = _msg(b"M", struct.pack("<BB", 0, len(key)) + key + text)
        return head + flags + defs + body + partial + fault
