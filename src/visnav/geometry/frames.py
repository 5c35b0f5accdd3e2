"""Local NED tangent plane <-> WGS84 geodetic coordinates (thin wrapper over pymap3d).

Geodetic coordinates appear only at the edges (scenario files, logs, map georeferences);
everything inside works in the local NED frame whose origin is the scenario's home.
"""

from __future__ import annotations

import numpy as np
import pymap3d

__all__ = ["LocalTangentPlane"]


class LocalTangentPlane:
    """NED tangent plane at geodetic origin (``lat0_deg``, ``lon0_deg``, ``h0_m``) on WGS84."""

    def __init__(self, lat0_deg: float, lon0_deg: float, h0_m: float = 0.0) -> None:
        lat0, lon0, h0 = float(lat0_deg), float(lon0_deg), float(h0_m)
        if not (np.isfinite(lat0) and -90.0 <= lat0 <= 90.0):
            raise ValueError(f"lat0_deg must be in [-90, 90], got {lat0_deg}")
        if not (np.isfinite(lon0) and -180.0 <= lon0 <= 360.0):
            raise ValueError(f"lon0_deg must be in [-180, 360], got {lon0_deg}")
        if not np.isfinite(h0):
            raise ValueError(f"h0_m must be finite, got {h0_m}")
        self.lat0_deg = lat0
        self.lon0_deg = lon0
        self.h0_m = h0

    def __repr__(self) -> str:
        return (
            f"LocalTangentPlane(lat0_deg={self.lat0_deg!r}, lon0_deg={self.lon0_deg!r}, "
            f"h0_m={self.h0_m!r})"
        )

    def geodetic_to_ned(self, lat_deg, lon_deg, h_m) -> np.ndarray:
        """NED position(s) [m] of geodetic point(s); inputs broadcast, result shape (..., 3)."""
        lat, lon, h = np.broadcast_arrays(
            np.asarray(lat_deg, dtype=float),
            np.asarray(lon_deg, dtype=float),
            np.asarray(h_m, dtype=float),
        )
        if np.any(np.abs(lat) > 90.0):
            raise ValueError(f"lat_deg must be in [-90, 90], got {lat_deg}")
        n, e, d = pymap3d.geodetic2ned(lat, lon, h, self.lat0_deg, self.lon0_deg, self.h0_m)
        return np.stack([np.asarray(n), np.asarray(e), np.asarray(d)], axis=-1)

    def ned_to_geodetic(self, ned) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lat_deg, lon_deg, h_m) of NED position(s) of shape (..., 3)."""
        p = np.asarray(ned, dtype=float)
        if p.ndim < 1 or p.shape[-1] != 3:
            raise ValueError(f"ned must have shape (..., 3), got shape {p.shape}")
        lat, lon, h = pymap3d.ned2geodetic(
            p[..., 0], p[..., 1], p[..., 2], self.lat0_deg, self.lon0_deg, self.h0_m
        )
        return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float), np.asarray(h, dtype=float)
