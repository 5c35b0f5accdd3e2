"""visnav.world: the synthetic world the simulator renders and flies in.

Ground rasters (:class:`GeoImage`), landing-field textures from real photographs, and wind
(steady + Dryden turbulence). Algorithms never import this package (DESIGN.md section 1).
"""

from __future__ import annotations

from visnav.world.maps import GeoImage
from visnav.world.textures import SURFACES, detail_tile, landing_field
from visnav.world.wind import DrydenTurbulence, SteadyWind, Wind, to_ned

__all__ = [
    "GeoImage",
    "SURFACES",
    "landing_field",
    "detail_tile",
    "SteadyWind",
    "DrydenTurbulence",
    "Wind",
    "to_ned",
]
