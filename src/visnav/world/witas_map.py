"""The WITAS homing world: the ground raster (procedural rural map or ``world.witas_map.file``) with the loop
fitted on it, and the navigator's degraded reference map. Deterministic in the run seed: the simulation
(``app/witas_parts.py``), the replay (``app/replay.py``) and the report (``analysis/witas_metrics.py``)
rebuild the same one.
"""

from __future__ import annotations

import numpy as np
from visnav.world.maps import GeoImage, degrade_reference
from visnav.world.rural import rural_map


def fit_loop(cfg_path, extent, footprint_m: float) -> tuple[float, float, float, tuple[float, float]]:
    """Loop sizes and centre that keep the loop ``margin_m`` + half a camera footprint inside a map."""
    n0, n1, e0, e1 = extent
    m = cfg_path.margin_m + 0.5 * footprint_m
    avail_n, avail_e = (n1 - n0) - 2 * m, (e1 - e0) - 2 * m
    if avail_n < 20 or avail_e < 20:
        raise ValueError(f"map of {n1 - n0:.0f} m x {e1 - e0:.0f} m is too small for a loop with "
                         f"{cfg_path.margin_m} m margin and a {footprint_m:.0f} m camera footprint")
    sn, se = min(cfg_path.size_north_m, avail_n), min(cfg_path.size_east_m, avail_e)
    r = min(cfg_path.corner_radius_m, 0.45 * min(sn, se))
    return sn, se, r, (0.5 * (n0 + n1), 0.5 * (e0 + e1))


def make_ground(path, map_cfg, seed: int, camera):
    """The world raster of ``map_cfg`` (``world.witas_map``) and the loop of ``path`` (``mission.path``) fitted on
    it (sizes, radius, centre); ``camera``: the scenario's ``sensors.camera`` (its footprint keeps the loop's view on
    the map).
    Deterministic in ``seed`` (the report rebuilds it to draw the tracks on the map)."""

    pc, cc, mc = path, camera, map_cfg
    footprint = cc.height * pc.altitude_m / cc.focal_px
    if mc.file:
        ground = GeoImage.load(mc.file)
        return ground, fit_loop(pc, ground.extent_ned(), footprint)
    sn, se = pc.size_north_m, pc.size_east_m
    r = min(pc.corner_radius_m, 0.45 * min(sn, se))
    size = max(sn, se) + 2 * (pc.margin_m + footprint) + 100.0
    pond = (0.0, se / 2.0) if mc.pond else None  # under the east leg (the thesis' leg 3-4)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 5]).spawn(6)[0])
    return rural_map(size, mc.resolution_m, rng, pond_ne=pond), (sn, se, r, (0.0, 0.0))


def mission_rngs(seed: int) -> list[np.random.Generator]:
    """The mission's generators (ground, camera, baro, compass, navigator, spare) from the run seed; the
    replay rebuilds the navigator's (index 4) from the recorded scenario."""
    return [np.random.default_rng(s) for s in np.random.SeedSequence([seed, 5]).spawn(6)]


def reference_map(mc, ground):
    """The navigator's degraded reference map of the world raster ``ground`` (``mc``: ``world.witas_map``)."""

    return degrade_reference(ground, mc.reference_resolution_m, mc.reference_gain, mc.reference_offset,
                             mc.reference_gamma, mc.reference_blur_m)
