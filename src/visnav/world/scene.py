"""The simulated world: a flat textured ground plane (z = 0), its surface type, and the wind."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from visnav.world.maps import GeoImage
from visnav.world.textures import detail_tile, landing_field
from visnav.world.wind import DrydenTurbulence, SteadyWind, Wind


@dataclass
class World:
    ground: GeoImage | None  # None: a mission that renders no ground (wind only)
    surface: str
    wind: Wind
    detail: np.ndarray | None = None  # high-passed fine texture tile (wraps around), uint8
    detail_resolution_m: float = 0.002
    sky_level: int = 200


def build_world(cfg, rng: np.random.Generator, heading_rad: float = 0.0) -> World:
    """Build the world of a scenario's ``[world]`` section (``cfg`` is a ``WorldConfig``)."""
    if cfg.map_file:
        path = Path(cfg.map_file)
        if not path.exists():
            raise FileNotFoundError(f"world.map_file not found: {path}")
        ground = GeoImage.load(path)
    else:
        ground = landing_field(cfg.surface, size_m=cfg.field_size_m, resolution_m=cfg.map_resolution_m, rng=rng)
    tile, tres = (None, 0.002)
    if cfg.detail_texture and not cfg.map_file:
        tile, tres = detail_tile(cfg.surface, rng=rng)
    return World(ground=ground, surface=cfg.surface, wind=build_wind(cfg, rng, heading_rad), detail=tile,
                 detail_resolution_m=tres)


def build_wind(cfg, rng: np.random.Generator, heading_rad: float = 0.0) -> Wind:
    """The wind of a ``WorldConfig``: steady (from ``wind_from_deg`` relative to the heading) + Dryden gusts."""
    from_deg = np.rad2deg(heading_rad) + cfg.wind_from_deg
    steady = SteadyWind(cfg.wind_speed_mps, from_deg)
    turb = None if cfg.turbulence == "none" else DrydenTurbulence(cfg.turbulence, rng)
    return Wind(steady, turb)
