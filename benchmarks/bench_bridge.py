"""`visnav bridge` (issue #17): per-frame processing time and capture-to-send latency, software in the loop.

For each navigator (built from its scenario, as `visnav bridge --navigator` does) the SIL autopilot
stand-in (io/mavlink_sil.py) circles over the scenario's world at the scenario's height and streams
its MAVLink over UDP on 127.0.0.1; the SIL camera renders the scenario's world at the vehicle's true
pose at the navigator's camera rate; GPS stops after ``gps_s`` so that a vision navigator engages.
The bridge runs in this process (threads), exactly as the CLI runs it.

Reported: per-frame processing (navigator.update(Frame) + estimate), capture-to-send latency (the
instant the frame shows -> ODOMETRY written to the socket), output stamps against the truth instant
(the stand-in's boot clock runs 50 ppm fast from an offset), and the stand-in's view: external
position error at time_usec. Run: PYTHONPATH=src python benchmarks/bench_bridge.py [seconds]
"""

from __future__ import annotations

import json
import sys

from visnav.app.sil_flight import CASES, fly


def main(seconds: float = 15.0) -> dict:
    rows = {name: fly(name, seconds) for name in CASES}
    for name, r in rows.items():
        p, lat = r["processing_ms"], r["latency_capture_to_send_ms"]
        print(f"{name:7s} {r['camera_hz']:4.1f} Hz  frames {r['frames']:4d}  proc {p['median']:7.2f} / {p['p95']:7.2f} ms"
              f"  latency {lat['median']:7.2f} / {lat['p95']:7.2f} ms  stamp err max {r['stamp_error_ms_max']:.3f} ms"
              f"  ext err {r['ext_error_m_median']:.2f} / {r['ext_error_m_p95']:.2f} m  source {r['source_at_end']}"
              f"  resets {r['reset_counter']}")
    return rows


if __name__ == "__main__":
    out = main(float(sys.argv[1]) if len(sys.argv) > 1 else 15.0)
    if len(sys.argv) > 2:
        with open(sys.argv[2], "w") as f:
            json.dump(out, f, indent=2, default=float)
