"""Rendering cost per 640x480 frame of the default landing field at several heights (DESIGN §5)."""

from __future__ import annotations

import time

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.scenarios.schema import WorldConfig
from visnav.sensors.camera import CameraRenderer
from visnav.world.scene import build_world


def main(repeats: int = 60) -> dict:
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    world = build_world(WorldConfig(), rng)
    build_s = time.perf_counter() - t0
    cam = PinholeCamera.ideal()
    mount = FixedMount.depressed(60.0)
    r = CameraRenderer(cam, noise_sigma=2.0, rng=rng)
    rows = {}
    for h in (30.0, 12.0, 2.0):
        pos = np.array([-h / np.tan(np.deg2rad(60)), 0.0, -h])
        cp, C = mount.camera_pose(pos, euler_to_dcm(np.array([0.01, -0.02, 0.1])))
        r.render(cp, C, world)
        ts = []
        for _ in range(repeats):
            a = time.perf_counter()
            r.render(cp, C, world)
            ts.append(time.perf_counter() - a)
        rows[f"render_ms_{int(h)}m"] = 1e3 * float(np.median(ts))
    rows["world_build_s"] = build_s
    print("| case | value |\n|---|---|")
    for k, v in rows.items():
        print(f"| {k} | {v:.2f} |")
    return rows


if __name__ == "__main__":
    main()
