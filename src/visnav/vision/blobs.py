"""Bright-blob features: centroids, undistorted bearings, bearing rates (seed 003 §5.1.3, §3.1.2).

The deck lights are found by intensity segmentation, connected components and intensity-weighted
centroids. Centroids are undistorted with the camera model (eq. 5.3-5.7) and turned into the two
bearings of eq. 2.25 (our OpenCV axes: ``atan(x/z)``, ``atan(y/z)`` = ``atan`` of the undistorted
normalised coordinates). Bearing rates come from matching each blob to the previous frame's blobs
(nearest in pixels, one to one); a blob without a match is new and has no rate (NaN), as §3.1.2.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment


@dataclass(frozen=True)
class BearingFrame:
    """Bearings (M, 2) [rad] of the blobs of the frame taken at ``t``, and their rates (M, 2) [rad/s], NaN if new."""

    t: float
    bearings: np.ndarray
    rates: np.ndarray
    pixels: np.ndarray


def find_blobs(image: np.ndarray, threshold: int = 150, min_area: int = 2, max_area: int = 2000) -> np.ndarray:
    """Intensity-weighted centroids (M, 2) [px, (u, v)] of the connected regions brighter than ``threshold``."""
    img = np.asarray(image)
    if img.ndim != 2 or img.size == 0:
        raise ValueError(f"find_blobs needs a non-empty grayscale image, got shape {img.shape}")
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    # label only the box around the bright pixels (the rows, then the columns of that band, with a pixel
    # above the threshold: one pass over the image instead of thresholding all of it and boxing the mask)
    thr = np.floor(threshold)  # (cv2.threshold of a byte image compares with floor(threshold))
    rows = np.flatnonzero(img.max(axis=1) > thr)
    if rows.size == 0:
        return np.zeros((0, 2))
    v0, v1 = int(rows[0]), int(rows[-1]) + 1
    cols = np.flatnonzero(img[v0:v1].max(axis=0) > thr)
    u0, u1 = int(cols[0]), int(cols[-1]) + 1
    sub = img[v0:v1, u0:u1]
    _, sub_mask = cv2.threshold(sub, threshold, 1, cv2.THRESH_BINARY)
    # (labels alone: connectedComponentsWithStats gives the same labels but costs ~5x more; the areas are
    # the label counts)
    n, labels = cv2.connectedComponents(sub_mask, connectivity=8)
    vs, us = np.nonzero(labels)
    lab = labels[vs, us]
    wgt = sub[vs, us].astype(float) - threshold
    sw = np.bincount(lab, weights=wgt, minlength=n)
    cu = np.bincount(lab, weights=wgt * (us + u0), minlength=n)
    cv = np.bincount(lab, weights=wgt * (vs + v0), minlength=n)
    area = np.bincount(lab, minlength=n)
    keep = np.arange(n)[1:]
    keep = keep[(area[keep] >= min_area) & (area[keep] <= max_area) & (sw[keep] > 0)]
    return np.stack([cu[keep] / sw[keep], cv[keep] / sw[keep]], axis=-1)


def pixels_to_bearings(uv: np.ndarray, camera) -> np.ndarray:
    """Bearings (eq. 2.25) of distorted pixel positions: undistort (eq. 5.3-5.7), then atan of x', y'."""
    uv = np.asarray(uv, float).reshape(-1, 2)
    if uv.shape[0] == 0:
        return np.zeros((0, 2))
    xy = camera.pixel_to_normalized(uv)  # (removes the lens distortion, eq. 5.3-5.7, once)
    return np.arctan(xy)


class BearingTracker:
    """Frame-to-frame matching of blobs, giving bearing rates by finite differences."""

    def __init__(self, camera, max_jump_px: float = 20.0, threshold: int = 150):
        self.camera = camera
        self.max_jump_px = max_jump_px
        self.threshold = threshold
        self._prev: tuple[float, np.ndarray, np.ndarray] | None = None

    @property
    def previous_time(self) -> float | None:
        """The time of the frame the next frame's rates will be differenced against (None before the first)."""
        return None if self._prev is None else self._prev[0]

    def process(self, t: float, image: np.ndarray) -> BearingFrame:
        uv = find_blobs(image, self.threshold)
        return self.from_pixels(t, uv)

    def from_pixels(self, t: float, uv: np.ndarray) -> BearingFrame:
        uv = np.asarray(uv, float).reshape(-1, 2)
        uv = uv[np.isfinite(uv).all(axis=1)]
        bear = pixels_to_bearings(uv, self.camera)
        ok = np.isfinite(bear).all(axis=1)
        uv, bear = uv[ok], bear[ok]
        rates = np.full_like(bear, np.nan)
        if self._prev is not None and len(uv) and len(self._prev[1]):
            t0, uv0, b0 = self._prev
            dt = t - t0
            if dt > 0:
                dd = uv[:, None, :] - uv0[None, :, :]
                d = np.sqrt((dd * dd).sum(axis=-1))  # (np.linalg.norm's own steps along the last axis)
                rows, cols = linear_sum_assignment(d)
                near = d[rows, cols] <= self.max_jump_px  # (each row once: the matches' rates at once)
                rows, cols = rows[near], cols[near]
                rates[rows] = (bear[rows] - b0[cols]) / dt
        self._prev = (t, uv, bear)
        return BearingFrame(t=t, bearings=bear, rates=rates, pixels=uv)
