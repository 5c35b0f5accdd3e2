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

import numpy as np

from visnav.geometry.rotations import euler_to_dcm
from visnav.io.bridge import Bridge, BridgeConfig
from visnav.io.bridge_navigators import build_navigator
from visnav.io.camera_source import CallableSource
from visnav.io.mavlink_link import MavlinkLink
from visnav.io.mavlink_sil import CircleTruth, SilAutopilot

CASES = {  # navigator -> SIL circle (radius m, speed m/s, height m) inside the scenario's world
    "witas": (80.0, 8.0, 60.0),
    "palace": (15.0, 2.0, 30.0),
}


def _free_port() -> int:
    import socket

    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def run_case(name: str, seconds: float, gps_s: float = 4.0) -> dict:
    built = build_navigator(name)
    sim = built.sim
    port = _free_port()
    notes: list[str] = []
    link = MavlinkLink(f"udpin:127.0.0.1:{port}", notify=notes.append)
    sil = SilAutopilot(f"udpout:127.0.0.1:{port}", truth=CircleTruth(*CASES[name]), gps_until_s=gps_s)

    def render(index: int, t: float):
        p, _, e, _ = sil.truth.at(sil.sim_t(t))
        cam_pos, C_cn = sim.mount.camera_pose(p, euler_to_dcm(e))
        return sim.camera.renderer.render(cam_pos, C_cn, sim.world)

    cam = CallableSource(render, fps=built.camera_hz)
    sil.start(seconds + 2.0)
    br = Bridge(link, cam, built.navigator, BridgeConfig(), notify=notes.append)
    try:
        m = br.run(duration_s=seconds)
    finally:
        sil.stop()
        link.close()
    stamps = np.array([usec - sil.boot_ns(t) / 1000.0 for t, usec in br.sent_stamps])
    ext = np.array(sil.stats.ext_errors_m) if sil.stats.ext_errors_m else np.array([np.nan])
    return {
        "navigator": built.scenario, "camera_hz": built.camera_hz, "seconds": seconds,
        "frames": m.get("frames", 0), "estimates_out": m.get("estimates_out", 0),
        "processing_ms": m["processing_ms"], "latency_capture_to_send_ms": m["latency_capture_to_send_ms"],
        "stamp_error_ms_max": float(np.max(np.abs(stamps)) / 1000.0) if len(stamps) else float("nan"),
        "stamp_error_ms_median": float(np.median(np.abs(stamps)) / 1000.0) if len(stamps) else float("nan"),
        "timesync_rtt_ms": m["timesync_rtt_ms"], "reset_counter": m["reset_counter"],
        "source_at_end": getattr(built.navigator.health(0.0), "source", "?"),
        "ext_error_m_median": float(np.median(ext)), "ext_error_m_p95": float(np.percentile(ext, 95)),
        "rate_in_hz": m["rate_in_hz"], "notes": notes[:12],
    }


def main(seconds: float = 15.0) -> dict:
    rows = {name: run_case(name, seconds) for name in CASES}
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
