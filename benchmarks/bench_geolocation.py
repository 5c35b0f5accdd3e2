"""Seed 002 ch. 7 (issue #16): registration ms per frame at 360x288, with and without the Hough
alignment of Algorithm 1, with the refinements beyond the thesis, and the registrability map."""

from __future__ import annotations

import math
import time

import numpy as np


def _per_call(fn, n: int) -> float:
    fn()
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n


def main(n: int = 20) -> dict:
    from visnav.analysis.registrability import registrability_map
    from visnav.geometry.camera import PinholeCamera
    from visnav.sensors.camera import CameraRenderer
    from visnav.vision.geolocation_registration import GeoRegistration, nadir_dcm
    from visnav.world.maps import degrade_reference
    from visnav.world.rural import rural_map
    from visnav.world.scene import World
    from visnav.world.wind import SteadyWind, Wind

    geo = rural_map(400.0, 0.25, np.random.default_rng(11))
    ref = degrade_reference(geo, 0.25, 0.85, 20.0, 1.15, 0.3)
    f = 360.0 / math.tan(math.radians(26.5))
    cam = PinholeCamera(720, 576, f, f, 359.5, 287.5, (-0.22, 0.06, 0, 0, 0, 0, 0, 0))
    img = CameraRenderer(cam, 4.0, np.random.default_rng(1)).render(np.array([10.0, -5.0, -70.0]), nadir_dcm(0.7),
                                                                    World(ground=geo, surface="map",
                                                                          wind=Wind(SteadyWind(0.0, 0.0))))
    rows = {}
    for name, kw in (("telemetry heading only (no Hough)", dict(hough=False)),
                     ("Hough alignment (Algorithm 1)", dict(hough=True)),
                     ("Hough + scale and rotation refinement (mission default)",
                      dict(hough=True, scale_search=0.06, rot_step_deg=0.75))):
        reg = GeoRegistration(ref, cam, search_radius_m=25.0, **kw)
        ms = 1e3 * _per_call(lambda: reg.register(img, 72.0, 0.7 + math.radians(15), [12.0, -8.0], [300, 200]), n)
        rows[f"register one 720x576 frame at 360x288, {name}"] = ms
    # beyond the thesis: the correlation search over headings (+-45 deg, 7.5 deg steps + 2 half steps),
    # run only on the frames where Algorithm 1 is not applied (no corresponding lines)
    reg = GeoRegistration(ref, cam, search_radius_m=25.0, hough=True, rotation_search_deg=45.0,
                          rotation_search_step_deg=7.5)
    e = reg.preprocess(img)
    (gc, gr), = ref.ned_to_pixel(np.array([[12.0, -8.0]]))
    rows["rotation search alone (15 matches), a frame Algorithm 1 leaves alone"] = 1e3 * _per_call(
        lambda: reg._rotation_search(e, 72.0, 0.7 + math.radians(15), gc, gr), max(3, n // 4))
    t0 = time.perf_counter()
    rq = registrability_map(geo, 70.0)
    rows[f"registrability map, 400 x 400 m at 70 m ({rq.score.size} cells), ms"] = 1e3 * (time.perf_counter() - t0)
    print("| operation | ms |\n|---|---:|")
    for k, v in rows.items():
        print(f"| {k} | {v:.1f} |")
    return rows


if __name__ == "__main__":
    main()
