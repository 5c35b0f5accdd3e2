"""The geo-location mission's map, reference image, camera and navigator built from a scenario's ``mission``
block, and the navigator's samples as the log holds them: used by the loop (``sim/geoloc_loop.py``) and the
navigator registry (``io/navigators.py``, replay). A leaf of ``sim``: it imports no loop."""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.navigation.geolocation import GeolocationNavigator
from visnav.world.maps import GeoImage, degrade_reference


def mission_map(cfg) -> GeoImage:
    """The map of ``mission.map``: a geo-referenced file, or the procedural rural world."""
    if cfg.map.file:
        return GeoImage.load(cfg.map.file)
    from visnav.world.rural import rural_map

    return rural_map(cfg.map.rural_size_m, 0.25, np.random.default_rng(cfg.map.rural_seed))


def map_centre(geo: GeoImage) -> np.ndarray:
    n0, n1, e0, e1 = geo.extent_ned()
    return np.array([(n0 + n1) / 2, (e0 + e1) / 2])


def mav_camera(c) -> PinholeCamera:
    """1/4 inch CCD, f = 3.6 mm: 53 deg across the grabbed width; radial distortion k1, k2."""
    f = (c.width_px / 2) / math.tan(math.radians(c.hfov_deg) / 2)
    return PinholeCamera(c.width_px, c.height_px, f, f, (c.width_px - 1) / 2, (c.height_px - 1) / 2,
                         (c.k1, c.k2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))


def mission_reference(cfg, geo: GeoImage) -> GeoImage:
    """The reference image the navigator registers to: the mission's map, degraded (``mission.map.ref_*``)."""
    m = cfg.map
    return degrade_reference(geo, geo.resolution_m, m.ref_gain, m.ref_offset, m.ref_gamma, m.ref_blur_m)


def build_navigator(cfg, reference: GeoImage, camera: PinholeCamera) -> GeolocationNavigator:
    """The navigator of the scenario's ``mission`` block (``mission.registration``, the camera's processing size)."""
    r, c = cfg.registration, cfg.camera
    return GeolocationNavigator(reference, camera, hough=r.hough, median_px=r.median_px,
                                search_radius_m=r.search_radius_m, min_quality=r.min_quality,
                                registration_sigma_m=r.sigma_m, map_sigma_m=r.map_sigma_m,
                                gate_prob=r.gate_prob or None, process_size=(c.process_width_px, c.process_height_px),
                                check_rotation=r.check_rotation, scale_search=r.scale_search,
                                rotation_refine_deg=r.rotation_refine_deg, quality_ref=r.quality_ref,
                                rotation_search_deg=r.rotation_search_deg,
                                rotation_search_step_deg=r.rotation_search_step_deg)


def log_samples(log, nav) -> None:
    """The navigator's samples and the RLS estimates after each (stream ``sample``)."""
    for s in nav.samples:
        log.record("sample", s["t"], reg=s["reg"], map=s["map"], est_reg=s["est_reg"], est_map=s["est_map"],
                   ok=s["ok"], reg_used=s["reg_used"], quality=s["quality"], peak=s["peak"],
                   hough=s["hough_applied"], heading_tel=s["heading_tel"], heading_used=s["heading_used"],
                   height_used=s["height_used"], gps=s["gps"], uv=s["uv"])
