"""A procedural rural orthophoto (the WITAS homing world): fields, hedges, roads, buildings, trees, a pond.

Everything is drawn vectorised or with one OpenCV call per object (a few hundred objects), never per
pixel: fields are a label image (jittered quadrilaterals of a recursive split of the area) whose
grey level, crop-row direction, period and contrast are looked up per pixel from per-field tables;
roads are smooth random polylines; buildings are rotated boxes with a roof ridge and a shadow; trees
are dark discs in clumps and along hedges; the pond is a smooth low-texture ellipse (no registration
over it, as over the thesis' pond, §5.9.1). Seeded: the same ``rng`` state gives the same map.
"""

from __future__ import annotations


import cv2
import numpy as np

from visnav.world.maps import GeoImage

__all__ = ["rural_map"]


def _smooth_noise(shape, cell_px: float, rng) -> np.ndarray:
    h, w = shape
    k = (max(2, int(h / cell_px) + 3), max(2, int(w / cell_px) + 3))
    n = rng.standard_normal(k).astype(np.float32)
    return cv2.resize(n, (w, h), interpolation=cv2.INTER_CUBIC)


def _split(box, min_m, rng, out):
    n0, e0, n1, e1 = box
    hn, he = n1 - n0, e1 - e0
    if max(hn, he) < 2 * min_m or (max(hn, he) < 3.5 * min_m and rng.random() < 0.35):
        out.append(box)
        return
    if hn > he:
        c = n0 + hn * rng.uniform(0.35, 0.65)
        _split((n0, e0, c, e1), min_m, rng, out)
        _split((c, e0, n1, e1), min_m, rng, out)
    else:
        c = e0 + he * rng.uniform(0.35, 0.65)
        _split((n0, e0, n1, c), min_m, rng, out)
        _split((n0, c, n1, e1), min_m, rng, out)


def rural_map(size_m: float = 700.0, resolution_m: float = 0.25, rng: np.random.Generator | None = None,
              pond_ne: tuple[float, float] | None = (0.0, 150.0), pond_radii_m: tuple[float, float] = (45.0, 30.0),
              roads: int = 3, buildings: int = 40) -> GeoImage:
    """A north-up ``size_m`` square map centred on NED (0, 0); the pond centred at ``pond_ne``."""
    rng = rng if rng is not None else np.random.default_rng(0)
    n = int(round(size_m / resolution_m))
    if not 64 <= n <= 12000:
        raise ValueError(f"rural map of {size_m} m at {resolution_m} m/px is {n} px a side (allowed 64..12000)")
    r = resolution_m
    half = (n - 1) / 2.0

    def px(ne):  # NED (north, east) -> pixel (col, row)
        ne = np.asarray(ne, float)
        return np.stack([ne[..., 1] / r + half, -ne[..., 0] / r + half], -1)

    # ---- fields: label image
    boxes: list = []
    _split((-size_m / 2, -size_m / 2, size_m / 2, size_m / 2), 40.0, rng, boxes)
    labels = np.zeros((n, n), np.int32)
    for i, (n0, e0, n1, e1) in enumerate(boxes):
        j = rng.normal(0, 2.0, (4, 2))
        quad = np.array([[n0, e0], [n0, e1], [n1, e1], [n1, e0]]) + j
        cv2.fillPoly(labels, [np.round(px(quad)).astype(np.int32)], i)
    m = len(boxes)
    level = rng.uniform(70, 190, m).astype(np.float32)
    theta = rng.uniform(0, np.pi, m).astype(np.float32)
    period = (rng.uniform(1.5, 5.0, m) / r).astype(np.float32)
    amp = rng.choice([0.0, 6.0, 12.0, 20.0], m).astype(np.float32)
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
    phase = (xx * np.cos(theta)[labels] + yy * np.sin(theta)[labels]) / period[labels]
    img = level[labels] + amp[labels] * np.sin(2 * np.pi * phase)
    del phase, xx, yy
    img += 14.0 * _smooth_noise((n, n), 12.0 / r, rng) + 8.0 * _smooth_noise((n, n), 3.0 / r, rng)
    img += rng.normal(0, 4.0, (n, n)).astype(np.float32)
    # ---- hedges and tree lines on some field edges
    for (n0, e0, n1, e1) in boxes:
        for a, b in (((n0, e0), (n0, e1)), ((n0, e0), (n1, e0))):
            if rng.random() < 0.4:
                p = np.round(px(np.array([a, b]))).astype(np.int32)
                cv2.line(img, tuple(p[0]), tuple(p[1]), float(rng.uniform(30, 60)), max(1, int(3.0 / r)))
    # ---- tree clumps
    for _ in range(60):
        c = rng.uniform(-size_m / 2, size_m / 2, 2)
        k = rng.integers(5, 30)
        pts = c + rng.normal(0, 8.0, (k, 2))
        for p, rad in zip(np.round(px(pts)).astype(int), rng.uniform(1.5, 4.0, k) / r):
            cv2.circle(img, (int(p[0]), int(p[1])), int(rad), float(rng.uniform(25, 60)), -1)
    # ---- roads: smooth random polylines across the map
    road_pts = []
    for i in range(roads):
        t = np.linspace(-0.6, 0.6, 60) * size_m
        heading = rng.uniform(0, np.pi)
        wob = np.cumsum(rng.normal(0, 0.03, 60))
        d = np.stack([np.cos(heading + wob), np.sin(heading + wob)], -1)
        start = rng.uniform(-0.2, 0.2, 2) * size_m
        pts = start + np.cumsum(d * (t[1] - t[0]), axis=0) - 0.5 * (t[-1] - t[0]) * np.array([np.cos(heading), np.sin(heading)])
        road_pts.append(pts)
        p = np.round(px(pts)).astype(np.int32)
        cv2.polylines(img, [p], False, 60.0, int(7.0 / r))
        cv2.polylines(img, [p], False, float(rng.uniform(150, 185)), int(5.0 / r))
    # ---- buildings near the roads: rotated boxes, roof ridge, shadow to the north-west
    for _ in range(buildings):
        pts = road_pts[rng.integers(len(road_pts))]
        k = rng.integers(len(pts))
        c = pts[k] + rng.normal(0, 1, 2) * 6 + np.sign(rng.normal(size=2)) * 12
        L, W = rng.uniform(8, 22), rng.uniform(6, 12)
        ang = rng.uniform(0, 180)
        ctr = tuple(float(v) for v in px(c))
        box = cv2.boxPoints((ctr, (L / r, W / r), ang)).astype(np.int32)
        shadow = box + np.array([int(-2.5 / r), int(-2.5 / r)], np.int32)
        cv2.fillPoly(img, [shadow], 25.0)
        roof = float(rng.choice([60.0, 200.0, 230.0, 110.0]))
        cv2.fillPoly(img, [box], roof)
        mid = box.astype(float)
        a, b = (mid[0] + mid[1]) / 2, (mid[2] + mid[3]) / 2
        cv2.line(img, tuple(np.round(a).astype(int)), tuple(np.round(b).astype(int)), roof * 0.7, max(1, int(0.6 / r)))
    # ---- pond: flat water, slight smooth shading, no texture
    if pond_ne is not None:
        c = tuple(int(v) for v in np.round(px(np.array(pond_ne))))
        mask = np.zeros((n, n), np.uint8)
        cv2.ellipse(mask, c, (int(pond_radii_m[1] / r), int(pond_radii_m[0] / r)), 15.0, 0, 360, 255, -1)
        shore = cv2.dilate(mask, np.ones((int(3 / r) | 1, int(3 / r) | 1), np.uint8)) > 0
        img[shore & (mask == 0)] = 95.0
        water = 62.0 + 3.0 * _smooth_noise((n, n), 40.0 / r, rng)
        img[mask > 0] = water[mask > 0]
    out = GeoImage(np.clip(np.rint(img), 0, 255).astype(np.uint8), half * r, -half * r, r, name="rural")
    return out


def mission_map(m) -> GeoImage:
    """The map of ``world.geo_map`` (``m``): a geo-referenced file, or the procedural rural world."""
    if m.file:
        return GeoImage.load(m.file)
    return rural_map(m.rural_size_m, 0.25, np.random.default_rng(m.rural_seed))
