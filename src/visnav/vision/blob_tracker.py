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
        roi = img[v0:v1, u0:u1]
        if roi.dtype == np.uint8 and roi.ndim == 3 and roi.shape[2] >= 3 and roi.shape[0] * roi.shape[1] <= 1 << 24:
            return self._search_u8(roi, u0, v0)
        roi = roi.astype(np.int16)
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

    def _search_u8(self, roi: np.ndarray, u0: int, v0: int) -> TrackResult:
        """``_search`` of a byte image in integers: the weights (scores 1..255), their sum and their sums
        weighted by the column and the row are integers below 2^53 (at most 2^24 pixels x 255 x 2^24), so
        the float sums of the general path are exact in any order and equal these; the two quotients are
        then the same correctly rounded divisions (tests/vision/test_blob_tracker.py checks it against
        the general path). ~3x cheaper: no float copy, no ``nonzero`` / fancy indexing."""
        r16 = roi.astype(np.int16)
        score = r16[..., 2] - np.maximum(r16[..., 0], r16[..., 1])
        mask = score > self.threshold
        n = int(np.count_nonzero(mask))
        if n < self.min_pixels:
            return TrackResult(False, pixels=n)
        w = score * mask  # int16: the score where it passes, 0 elsewhere
        cols = w.sum(axis=0, dtype=np.int64)
        rows = w.sum(axis=1, dtype=np.int64)
        total = int(cols.sum())
        su = int(cols @ np.arange(cols.shape[0], dtype=np.int64))
        sv = int(rows @ np.arange(rows.shape[0], dtype=np.int64))
        return TrackResult(True, u0 + float(su) / float(total), v0 + float(sv) / float(total), n)

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
