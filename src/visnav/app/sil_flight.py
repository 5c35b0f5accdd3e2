"""A software-in-the-loop flight of a visnav navigator behind the bridge, over UDP on 127.0.0.1.

The SIL autopilot stand-in (io/mavlink_sil.py) circles over the navigator's scenario world at the
scenario's height and streams its MAVLink; the SIL camera renders that world at the vehicle's true
pose at the navigator's camera rate; GPS stops after ``gps_s`` so that a vision navigator engages.
The bridge runs in this process (threads) exactly as ``visnav bridge`` runs it; the stand-in fuses
what comes back and measures it against its truth. Used by benchmarks/bench_bridge.py and the tests.
"""

from __future__ import annotations

import numpy as np

from visnav.geometry.rotations import euler_to_dcm
from visnav.app.bridge import Bridge, BridgeConfig
from visnav.app.bridge_navigators import build_navigator
from visnav.io.camera_source import CallableSource
from visnav.io.mavlink_link import MavlinkLink
from visnav.io.mavlink_sil import CircleTruth, SilAutopilot
from visnav.app.missions import make_simulation
import socket

CASES = {  # navigator -> SIL circle (radius m, speed m/s, height m) inside the scenario's world
    "witas": (80.0, 8.0, 60.0),
    "palace": (15.0, 2.0, 30.0),
}


def _free_port() -> int:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def fly(name: str, seconds: float, gps_s: float = 4.0, output: str = "odometry") -> dict:
    """Fly ``name`` (witas / palace / a scenario in CASES) for ``seconds`` of wall time; the figures."""
    built = build_navigator(name)
    sim = make_simulation(built.sc)  # its world and camera renderer serve the SIL camera
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
    br = Bridge(link, cam, built.navigator, BridgeConfig(output=output), notify=notes.append)
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


