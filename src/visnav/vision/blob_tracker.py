"""Colour-blob tracker of the CONDOR tent (stands in for the ILF tracker of seed 004 §2.4).

Started on the target by the operator (an initial pixel), it follows the blue blob inside a search
window around the last position: a blueness score ``B - max(R, G)`` above a threshold, the centroid
weighted by the score (the anti-aliased edges then count by their coverage). Lost when too few
pixels pass; it then searches the whole frame (the operator re-selecting the target).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TrackResult:
    ok: bool
    u: float = 0.0
    v: float = 0.0
    pixels: int = 0


class BlobTracker:
    def __init__(self, window_px: int = 60, threshold: int = 40, min_pixels: int = 4) -> None:
        if window_px < 4 or threshold < 1 or min_pixels < 1:
            raise ValueError("window_px >= 4, threshold >= 1 and min_pixels >= 1 required")
        self.window, self.threshold, self.min_pixels = window_px, threshold, min_pixels
        self.last: tuple[float, float] | None = None

    def start(self, u: float, v: float) -> None:
        self.last = (float(u), float(v))

    def _search(self, img: np.ndarray, u0: int, v0: int, u1: int, v1: int) -> TrackResult:
        roi = img[v0:v1, u0:u1].astype(np.int16)
        score = roi[..., 2] - np.maximum(roi[..., 0], roi[..., 1])
        w = np.where(score > self.threshold, score.astype(float), 0.0)
        n = int(np.count_nonzero(w))
        if n < self.min_pixels:
            return TrackResult(False, pixels=n)
        total = w.sum()
        vv, uu = np.nonzero(w)
        u = u0 + float((uu * w[vv, uu]).sum() / total)
        v = v0 + float((vv * w[vv, uu]).sum() / total)
        return TrackResult(True, u, v, n)

    def track(self, img: np.ndarray) -> TrackResult:
        h, w = img.shape[:2]
        if self.last is not None:
            cu, cv = int(round(self.last[0])), int(round(self.last[1]))
            r = self.window
            res = self._search(img, max(cu - r, 0), max(cv - r, 0), min(cu + r + 1, w), min(cv + r + 1, h))
        else:
            res = TrackResult(False)
        if not res.ok:
            res = self._search(img, 0, 0, w, h)  # re-acquire over the whole frame
        self.last = (res.u, res.v) if res.ok else None
        return res
