"""A ground target pasted into a geo-referenced map: the truck of seed 002 §7.5 (about 2.5 x 7 m).

The target is drawn at the map's own resolution with sub-pixel corners (``cv2.fillPoly`` with shift
bits): a shadow offset to the north-west, a dark cab, a light cargo box with a darker rim and roof
ribs, so that it has a texture of its own and a clear orientation. Only the frames are rendered from
the map with the target; the reference map used for registration does not hold it (the truck was not
in the Google Earth image either).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from visnav.world.maps import GeoImage

__all__ = ["paste_truck", "truck_outline"]

_SHIFT = 4  # fillPoly sub-pixel bits


def truck_outline(centre_ne, length_m: float, width_m: float, heading: float, along=(-0.5, 0.5),
                  across=(-0.5, 0.5)) -> np.ndarray:
    """(4, 2) NE corners of the part of the truck between fractions ``along`` x ``across``."""
    c, s = math.cos(heading), math.sin(heading)
    fwd, right = np.array([c, s]), np.array([-s, c])
    pts = [np.asarray(centre_ne, float) + a * length_m * fwd + b * width_m * right
           for a, b in ((along[0], across[0]), (along[1], across[0]), (along[1], across[1]), (along[0], across[1]))]
    return np.array(pts)


def paste_truck(geo: GeoImage, centre_ne, length_m: float = 7.0, width_m: float = 2.5, heading: float = 0.0,
                cab: int = 45, box: int = 225) -> GeoImage:
    """A copy of ``geo`` with the truck drawn in (``heading``: the cab's direction from north)."""
    img = geo.image.copy()

    def fill(ne, value):
        cr = geo.ned_to_pixel(ne) * (1 << _SHIFT)
        cv2.fillPoly(img, [np.round(cr).astype(np.int32)], int(value), lineType=cv2.LINE_AA, shift=_SHIFT)

    c = np.asarray(centre_ne, float)[:2]
    fill(truck_outline(c + np.array([-0.8, -0.8]), length_m, width_m, heading), 20)  # shadow (sun in the SE)
    fill(truck_outline(c, length_m, width_m, heading, along=(0.3, 0.5)), cab)
    fill(truck_outline(c, length_m, width_m, heading, along=(-0.5, 0.28)), box * 0.75)
    fill(truck_outline(c, length_m, width_m, heading, along=(-0.45, 0.23), across=(-0.38, 0.38)), box)
    for f in (-0.25, -0.05, 0.15):  # roof ribs
        fill(truck_outline(c, length_m, width_m, heading, along=(f, f + 0.04), across=(-0.38, 0.38)), box * 0.6)
    out = GeoImage(img, geo.north0, geo.east0, geo.resolution_m, name=geo.name + "+target")
    out.origin_geodetic = geo.origin_geodetic
    return out
