"""KLT feature tracking (seed 002 §5.6): Shi-Tomasi corners (``cv2.goodFeaturesToTrack``) re-associated
frame to frame by the pyramidal Lucas-Kanade tracker (``cv2.calcOpticalFlowPyrLK``), at most
``max_features`` (50 in the thesis, Fig. 5.20). Lost features are replaced from the new frame,
away from the ones still tracked, so the set stays spread over the image.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["KltTracker", "KltPairs"]


@dataclass
class KltPairs:
    """Correspondences between the previous and the current frame."""

    prev: np.ndarray  # (N, 2) pixel positions in the previous frame
    curr: np.ndarray  # (N, 2) in the current frame
    n_detected: int  # features that were searched for


class KltTracker:
    def __init__(self, max_features: int = 50, quality: float = 0.01, min_distance_px: float = 12.0,
                 window_px: int = 21, levels: int = 3, fb_max_px: float = 1.0, min_eigenvalue: float = 1.5e-4):
        if not 4 <= max_features <= 2000:
            raise ValueError(f"max_features must be in [4, 2000], got {max_features}")
        self.max_features = int(max_features)
        self.quality = quality
        self.min_distance = min_distance_px
        self.lk = dict(winSize=(window_px, window_px), maxLevel=levels,
                       criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03))
        self.fb_max = fb_max_px  # forward-backward check: drop a track that does not come back
        # absolute corner strength (cv2.cornerMinEigenVal, block 7): goodFeaturesToTrack's quality is
        # relative to the frame's best corner, so over water it would pick sensor noise
        self.min_eig = min_eigenvalue
        self.refill_below = 0.8
        self.prev_img: np.ndarray | None = None
        self._pts: np.ndarray | _TopUp = np.zeros((0, 2), np.float32)  # the features of prev_img
        self._ready: dict[int, tuple] = {}  # id(image) -> (image, state it started from, result): ``prework``

    @property
    def pts(self) -> np.ndarray:
        """The features of the previous frame (its top-up detection done, here if not yet)."""
        return _features(self._pts)

    @pts.setter
    def pts(self, value) -> None:
        self._pts = value

    def reset(self) -> None:
        self.prev_img = None
        self._pts = np.zeros((0, 2), np.float32)

    def _detect(self, img: np.ndarray, keep: np.ndarray) -> np.ndarray:
        need = self.max_features - len(keep)
        if need <= 0 or (len(keep) >= self.refill_below * self.max_features):
            return keep  # top up only when a fifth of the set is lost (detection is the costly part)
        mask = np.full(img.shape, 255, np.uint8)
        for x, y in keep.astype(int):  # at most max_features small discs
            cv2.circle(mask, (int(x), int(y)), int(self.min_distance), 0, -1)
        new = cv2.goodFeaturesToTrack(img, need, self.quality, self.min_distance, mask=mask, blockSize=7)
        if new is None:
            return keep
        new = new.reshape(-1, 2).astype(np.float32)
        if self.min_eig > 0:
            ev = cv2.cornerMinEigenVal(img, 7)
            new = new[ev[new[:, 1].astype(int), new[:, 0].astype(int)] >= self.min_eig]
        return np.vstack([keep, new])

    def track(self, img: np.ndarray) -> KltPairs:
        """Track the features of the previous frame into ``img``; then top the set up from ``img`` (the top-up
        detection runs when the features are next needed: it serves the next frame only)."""
        if img.ndim != 2 or img.dtype != np.uint8:
            raise ValueError(f"KltTracker needs a uint8 grey image, got {img.dtype} {img.shape}")
        ready = self._ready.pop(id(img), None)
        if len(self._ready) > 8:  # frames worked on but never tracked (a fault changed them)
            self._ready.clear()
        if ready is not None and ready[0] is img and ready[1] is self.prev_img and ready[2] is self._pts:
            pairs, topup = ready[3], ready[4]  # worked out by ``prework`` from this very state and image
        else:
            pairs, kept = self._flow(self.prev_img, self._pts, img)
            topup = _TopUp(self, img, kept)
        self.prev_img, self._pts = img, topup
        return pairs

    def prework(self):
        """A function of the next image that tracks into it from the tracker's state now, off the caller's
        thread (the render thread, right after the frame is rendered); ``track`` takes its result when it is
        given that image while the state is still the one it started from, and otherwise works it out
        itself (the same function of the same inputs: the result never depends on which thread did it).
        It returns the frame's top-up detection, for the same thread to run after the frame is delivered."""
        prev, pts, ready = self.prev_img, self._pts, self._ready

        def work(img: np.ndarray):
            if img.ndim == 2 and img.dtype == np.uint8:
                pairs, kept = self._flow(prev, pts, img)
                topup = _TopUp(self, img, kept)
                ready[id(img)] = (img, prev, pts, pairs, topup)  # (one atomic store)
                return topup.resolve
            return None

        return work

    def _flow(self, prev_img: np.ndarray | None, pts, img: np.ndarray) -> tuple[KltPairs, np.ndarray]:
        """(pairs, the features kept) from a state (previous image, its features) and a new image; pure."""
        empty = np.zeros((0, 2))
        pts = _features(pts)
        if prev_img is None or len(pts) == 0:
            return KltPairs(empty, empty, 0), np.zeros((0, 2), np.float32)
        p0 = pts.reshape(-1, 1, 2)
        p1, st, _ = cv2.calcOpticalFlowPyrLK(prev_img, img, p0, None, **self.lk)
        ok = st.ravel() == 1
        if self.fb_max > 0 and ok.any():
            pb, stb, _ = cv2.calcOpticalFlowPyrLK(img, prev_img, p1, None, **self.lk)
            fb = np.linalg.norm((pb - p0).reshape(-1, 2), axis=1)
            ok &= (stb.ravel() == 1) & (fb < self.fb_max)
        h, w = img.shape
        q = p1.reshape(-1, 2)
        ok &= (q[:, 0] >= 0) & (q[:, 0] < w) & (q[:, 1] >= 0) & (q[:, 1] < h)
        prev, curr = pts[ok].astype(float), q[ok].astype(float)
        return KltPairs(prev, curr, len(pts)), q[ok].astype(np.float32)


class _TopUp:
    """A frame's feature set: the features kept plus the top-up detection on that frame, worked out once, by
    whoever needs it first (the render thread after the delivery, or the next ``track``)."""

    def __init__(self, tracker: KltTracker, img: np.ndarray, kept: np.ndarray):
        self._tracker, self._img, self._kept = tracker, img, kept
        self._lock = threading.Lock()
        self._pts: np.ndarray | None = None

    def resolve(self) -> np.ndarray:
        with self._lock:
            if self._pts is None:
                self._pts = self._tracker._detect(self._img, self._kept)
                self._img = self._kept = None
            return self._pts


def _features(pts) -> np.ndarray:
    return pts.resolve() if isinstance(pts, _TopUp) else pts
