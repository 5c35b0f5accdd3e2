"""The landing pad as a ground texture at true scale (seed 002 Fig. 6.1; layout in geometry/pad.py).

``pad_board`` draws the white board with its nested ring configurations into a north-up
``GeoImage`` centred on the pad centre (anti-aliased: each pixel's grey is the ring coverage of
its area, to 1/2 px). The camera (``sensors/pad_camera.py``) warps it on top of the world's ground
texture, so the pad lies in the landing field at every ground sample distance (its own pyramid).

Options (``PadWorldConfig``): a partial shadow (a half-plane across the board, soft-edged, the
board's grey multiplied by ``shadow_gain`` there) and a lighting change (the whole frame's grey
scaled by ``lighting_gain`` from ``lighting_change_s`` on: a cloud, or exposure that lags).
"""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.pad import PadLayout
from visnav.world.maps import GeoImage

BOARD_GREY = 215.0
RING_GREY = 35.0


def pad_board(layout: PadLayout, resolution_m: float = 0.002, rng: np.random.Generator | None = None,
              shadow: tuple[float, float, float] | None = None, centre_ne=(0.0, 0.0)) -> GeoImage:
    """The board raster. ``shadow`` = (direction_deg, offset_m, gain): pixels whose pad-frame
    position p has  p . (cos d, sin d) > offset  are darkened by ``gain`` (5 cm soft edge)."""
    res = float(resolution_m)
    if not (0.0005 <= res <= 0.05):
        raise ValueError(f"pad resolution_m must be in [0.0005, 0.05], got {resolution_m}")
    half = layout.board_half_m
    n = int(math.ceil(2 * half / res))
    if n > 8000:
        raise ValueError(f"pad board of {2 * half:.1f} m at {res} m/px is {n} px a side (max 8000)")
    # pixel centres: north = north0 - row res, east = east0 + col res
    north0 = centre_ne[0] + (n - 1) / 2.0 * res
    east0 = centre_ne[1] - (n - 1) / 2.0 * res
    img = np.full((n, n), BOARD_GREY, np.float32)
    if rng is not None:  # a faint low-frequency albedo (a printed board is not perfectly even)
        coarse = rng.normal(0.0, 3.0, (9, 9)).astype(np.float32)
        import cv2

        img += cv2.resize(coarse, (n, n), interpolation=cv2.INTER_CUBIC)
    for cfg in layout.configurations():
        for c in cfg.centres:
            _draw_ring(img, north0, east0, res, centre_ne[0] + c[0], centre_ne[1] + c[1], cfg.r_outer, cfg.r_inner)
    if shadow is not None:
        d, off, gain = math.radians(shadow[0]), float(shadow[1]), float(shadow[2])
        rows = north0 - np.arange(n, dtype=np.float32) * res - centre_ne[0]
        cols = east0 + np.arange(n, dtype=np.float32) * res - centre_ne[1]
        s = rows[:, None] * math.cos(d) + cols[None, :] * math.sin(d) - off
        w = np.clip(s / 0.05 + 0.5, 0.0, 1.0)
        img *= 1.0 - (1.0 - gain) * w
    return GeoImage(np.clip(np.rint(img), 0, 255).astype(np.uint8), north0, east0, res, name="landing_pad")


def _draw_ring(img, north0, east0, res, cn, ce, r_out, r_in) -> None:
    """Blend a dark annulus into ``img`` (anti-aliased coverage, local window only)."""
    n = img.shape[0]
    c0 = int(math.floor((ce - r_out - east0) / res)) - 2
    c1 = int(math.ceil((ce + r_out - east0) / res)) + 2
    r0 = int(math.floor((north0 - (cn + r_out)) / res)) - 2
    r1 = int(math.ceil((north0 - (cn - r_out)) / res)) + 2
    c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1, n - 1), min(r1, n - 1)
    rows = np.arange(r0, r1 + 1, dtype=np.float64)
    cols = np.arange(c0, c1 + 1, dtype=np.float64)
    dn = (north0 - rows * res - cn)[:, None]
    de = (east0 + cols * res - ce)[None, :]
    d = np.hypot(dn, de) / res  # distance in pixels
    cover = np.clip(r_out / res - d + 0.5, 0.0, 1.0) - np.clip(r_in / res - d + 0.5, 0.0, 1.0)
    win = img[r0:r1 + 1, c0:c1 + 1]
    win += (RING_GREY - win) * cover.astype(np.float32)
