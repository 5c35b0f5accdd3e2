"""The CONDOR navigator built from a scenario's ``mission`` block: used by the loop (``sim/condor_loop.py``) and
the navigator registry (``io/navigators.py``, replay and bridge). A leaf of ``sim``: it imports no loop."""

from __future__ import annotations

import math

from visnav.navigation.condor import CondorNavigator, RadiusFilter
from visnav.vision.condor_pipeline import VisionRange


def build_navigator(cfg, camera) -> CondorNavigator:
    """The navigator of the scenario's ``mission`` block (its own tuning, ``mission.navigation``)."""
    c, v, a, n = cfg.camera, cfg.vision, cfg.altimeter, cfg.navigation
    vision = VisionRange(camera, math.radians(c.hfov_deg), v.method, v.lut, v.board_distance_m, v.board_spacing_m)
    return CondorNavigator(vision, camera, (a.t_measured_c, a.c0, a.c1),
                           radius_filter=RadiusFilter(n.radius_alpha, n.radius_beta, n.radius_stale_s),
                           gps_gain=n.gps_gain, radius_sigma_pct=n.radius_sigma_pct,
                           heading_sigma_deg=n.heading_sigma_deg, gps_sigma_m=cfg.gps_noise_m)
