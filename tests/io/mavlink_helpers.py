"""Helpers for the MAVLink tests: free loopback ports, a pymavlink peer, bounded receive loops."""

from __future__ import annotations

import socket
import time


def free_udp_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def receive(conn, types, n: int, timeout_s: float = 3.0) -> list:
    """Up to ``n`` messages of ``types`` from a pymavlink connection, within ``timeout_s`` (bounded)."""
    out, t_end = [], time.monotonic() + timeout_s
    while len(out) < n:
        m = conn.recv_match(type=types, blocking=timeout_s > 0, timeout=0.05)
        if m is not None:
            out.append(m)
        elif time.monotonic() >= t_end:
            break
    return out
