"""Template tracker of the operator-selected target (seed 002 §7.4.3).

The thesis used NI Vision's colour pattern matcher (coarse-to-fine search, then hill climbing). Here:
normalised cross-correlation (``cv2.matchTemplate``, TM_CCOEFF_NORMED) over the whole frame at half
resolution, with the template of the operator's click turned by the heading change since the click
(a nadir camera turns with the aircraft) and by +-``angle_span`` around it (the heading is the GPS
course, tens of degrees off in wind); the best angle wins, then a parabola gives the sub-pixel peak.
The initial template is kept (no drift); a peak below ``min_score`` means the target is not in view.
While the target is in view the search is limited to ``window_px`` around its last position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["RotatingTemplateTracker", "TargetTrack"]


@dataclass(frozen=True)
class TargetTrack:
    ok: bool
    uv: np.ndarray  # (u, v) in the full frame
    score: float
    angle: float = 0.0  # rad, template rotation that matched


class RotatingTemplateTracker:
    def __init__(self, template_px: int = 41, scale: float = 0.5, min_score: float = 0.75,
                 angle_span_deg: float = 20.0, angle_step_deg: float = 10.0, window_px: int = 60) -> None:
        self.size, self.scale, self.min_score = int(template_px) | 1, float(scale), float(min_score)
        self.angles = np.radians(np.arange(-angle_span_deg, angle_span_deg + 1e-9, angle_step_deg))
        self.patch: np.ndarray | None = None
        self.heading0 = 0.0
        self.window = int(window_px)  # search half-size around the last position (reduced pixels)
        self.last: np.ndarray | None = None  # last found position (reduced pixels), None: search all

    @property
    def started(self) -> bool:
        return self.patch is not None

    def _small(self, image: np.ndarray) -> np.ndarray:
        h, w = image.shape[:2]
        return cv2.resize(image, (int(round(w * self.scale)), int(round(h * self.scale))), interpolation=cv2.INTER_AREA)

    def start(self, image: np.ndarray, uv, heading: float) -> bool:
        """Cut the template (a patch twice its size, so that it can turn) around the click ``uv``."""
        img = self._small(image)
        u, v = (np.asarray(uv, float) + 0.5) * self.scale - 0.5
        big = 2 * self.size
        patch = cv2.getRectSubPix(img, (big, big), (float(u), float(v)))
        self.patch, self.heading0 = patch, float(heading)
        return True

    def _templates(self, heading: float):
        big = self.patch.shape[0]
        c = ((big - 1) / 2.0, (big - 1) / 2.0)
        a = (big - self.size) // 2
        base = heading - self.heading0
        for da in self.angles:
            R = cv2.getRotationMatrix2D(c, math.degrees(base + da), 1.0)  # heading up: content turns ccw
            rot = cv2.warpAffine(self.patch, R, (big, big), flags=cv2.INTER_LINEAR)
            yield base + da, rot[a : a + self.size, a : a + self.size]

    def track(self, image: np.ndarray, heading: float) -> TargetTrack:
        if self.patch is None:
            return TargetTrack(False, np.full(2, np.nan), float("nan"))
        full = self._small(image)
        x0 = y0 = 0
        img = full
        if self.last is not None:  # the previous frame had it: search around there first
            h, w = full.shape
            half = self.size // 2 + self.window
            x0 = int(np.clip(round(self.last[0]) - half, 0, max(w - 2 * half, 0)))
            y0 = int(np.clip(round(self.last[1]) - half, 0, max(h - 2 * half, 0)))
            img = full[y0 : y0 + 2 * half, x0 : x0 + 2 * half]
        best = (-2.0, None, None, 0.0)
        for ang, tpl in self._templates(heading):
            c = cv2.matchTemplate(img, tpl, cv2.TM_CCOEFF_NORMED)
            _, mx, _, loc = cv2.minMaxLoc(c)
            if mx > best[0]:
                best = (mx, c, loc, ang)
        score, c, (j, i), ang = best
        di = dj = 0.0
        if 0 < i < c.shape[0] - 1:
            den = c[i - 1, j] - 2 * c[i, j] + c[i + 1, j]
            di = 0.0 if abs(den) < 1e-12 else float(np.clip(0.5 * (c[i - 1, j] - c[i + 1, j]) / den, -0.5, 0.5))
        if 0 < j < c.shape[1] - 1:
            den = c[i, j - 1] - 2 * c[i, j] + c[i, j + 1]
            dj = 0.0 if abs(den) < 1e-12 else float(np.clip(0.5 * (c[i, j - 1] - c[i, j + 1]) / den, -0.5, 0.5))
        half = (self.size - 1) / 2.0
        uv_small = np.array([x0 + j + dj + half, y0 + i + di + half])
        uv = (uv_small + 0.5) / self.scale - 0.5
        ok = bool(score >= self.min_score)
        if not ok and self.last is not None:  # lost near the last position: search the whole frame
            self.last = None
            return self.track(image, heading)
        self.last = uv_small if ok else None
        return TargetTrack(ok, uv, float(score), float(ang))
