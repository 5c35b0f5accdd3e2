"""Feature matching between two survey photos (OpenCV SIFT / ORB / AKAZE) and a robust homography.

Survey photos are far apart in time (a photo every 2-5 s, 50-70 % overlap) and may turn between two
shots, so a tracker (KLT) does not bridge them; scale- and rotation-invariant local features do.
``FeatureMatcher`` detects on a grey image scaled to ``work_width`` pixels (the photo's features are
computed once and kept), matches descriptors with Lowe's ratio test (a repetitive pattern such as crop
rows gives a second-best match nearly as good as the best: the ratio test drops it) and a mutual
(cross) check, then fits the homography with OpenCV's USAC (MAGSAC++). A fit is accepted when it has
enough inliers, a large enough inlier share, a plausible scale change and little perspective
(a nadir camera over flat ground between two nearby views: near a similarity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Features", "PairMatch", "FeatureMatcher", "similarity_of"]


@dataclass(frozen=True)
class Features:
    keypoints: np.ndarray  # (n, 2) pixel positions in the FULL-size image
    descriptors: np.ndarray
    scale: float  # work image pixels per full image pixel


@dataclass(frozen=True)
class PairMatch:
    """The homography that maps pixels of image ``b`` (the later) into image ``a`` (the earlier)."""

    H: np.ndarray | None  # 3x3 full-size pixels b -> a, None when the pair is not registered
    matches: int  # ratio-test matches
    inliers: int
    why: str = ""  # why it was not accepted

    @property
    def ok(self) -> bool:
        return self.H is not None


def similarity_of(H: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The image-plane motion of ``H`` (pixels b -> a) at b's principal point, in normalized coordinates:
    (t, theta, s): where b's optical axis lands in a (K^-1 H c_b, a 2-vector), the in-plane rotation of b
    relative to a [rad] and the scale (det of the Jacobian ^ 1/2) from the local Jacobian of the map."""
    Hn = np.linalg.inv(K) @ H @ K  # normalized b -> normalized a
    w = Hn[2, 2]
    t = Hn[:2, 2] / w
    # Jacobian of x -> (Hn[:2,:2] x + Hn[:2,2]) / (Hn[2,:2] x + Hn[2,2]) at x = 0
    J = (Hn[:2, :2] * w - np.outer(Hn[:2, 2], Hn[2, :2])) / (w * w)
    theta = math.atan2(J[1, 0] - J[0, 1], J[0, 0] + J[1, 1])
    s = math.sqrt(abs(np.linalg.det(J)))
    return t, theta, s


class FeatureMatcher:
    """Detect, describe and match features; ``match(a, b)`` registers image b into image a."""

    def __init__(self, method: str = "sift", work_width: int = 600, n_features: int = 2500, ratio: float = 0.8,
                 ransac_px: float = 3.0, min_inliers: int = 25, min_inlier_share: float = 0.15,
                 scale_range: tuple[float, float] = (0.6, 1.6), max_perspective: float = 0.6, clahe: float = 3.0,
                 contrast_threshold: float = 0.02) -> None:
        import cv2

        method = method.lower()
        # CLAHE (contrast-limited adaptive histogram equalisation) lifts the faint texture of bare fields
        self._clahe = cv2.createCLAHE(clipLimit=clahe, tileGridSize=(8, 8)) if clahe > 0 else None
        if method == "sift":
            self._det = cv2.SIFT_create(nfeatures=n_features, contrastThreshold=contrast_threshold)
            self._norm = cv2.NORM_L2
        elif method == "orb":
            self._det = cv2.ORB_create(nfeatures=n_features)
            self._norm = cv2.NORM_HAMMING
        elif method == "akaze" and hasattr(cv2, "AKAZE_create"):  # not in every OpenCV build (5.x: contrib)
            self._det = cv2.AKAZE_create()
            self._norm = cv2.NORM_HAMMING
        else:
            raise ValueError(f"feature method {method!r}: sift, orb or akaze (where this OpenCV has it)")
        self.method, self.work_width, self.ratio = method, int(work_width), float(ratio)
        self.ransac_px, self.min_inliers, self.min_inlier_share = float(ransac_px), int(min_inliers), min_inlier_share
        self.scale_range, self.max_perspective = scale_range, float(max_perspective)
        # SIFT: approximate nearest neighbours (FLANN k-d trees); binary descriptors: brute force, Hamming
        flann = self._norm == cv2.NORM_L2
        self._matcher = cv2.FlannBasedMatcher({"algorithm": 1, "trees": 4}, {"checks": 64}) if flann \
            else cv2.BFMatcher(self._norm)

    def detect(self, image: np.ndarray) -> Features:
        import cv2

        h, w = image.shape[:2]
        s = min(1.0, self.work_width / w)
        img = cv2.resize(image, (round(w * s), round(h * s)), interpolation=cv2.INTER_AREA) if s < 1 else image
        if img.ndim == 3:
            img = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
        if self._clahe is not None:
            img = self._clahe.apply(img)
        kp, des = self._det.detectAndCompute(img, None)
        pts = np.array([k.pt for k in kp], float).reshape(-1, 2) / s
        return Features(pts, des if des is not None else np.zeros((0, 32), np.uint8), s)

    def _ratio_matches(self, da: np.ndarray, db: np.ndarray) -> np.ndarray:
        """(i_a, i_b) pairs passing the ratio test both ways (b -> a best, and a's best back is b)."""
        if len(da) < 2 or len(db) < 2:
            return np.zeros((0, 2), int)
        fwd = self._matcher.knnMatch(db, da, k=2)
        back = self._matcher.knnMatch(da, db, k=1)
        best_back = {m[0].queryIdx: m[0].trainIdx for m in back if m}
        out = [(m[0].trainIdx, m[0].queryIdx) for m in fwd
               if len(m) == 2 and m[0].distance < self.ratio * m[1].distance
               and best_back.get(m[0].trainIdx) == m[0].queryIdx]
        return np.array(out, int).reshape(-1, 2)

    def match(self, fa: Features, fb: Features, K: np.ndarray | None = None) -> PairMatch:
        """Register b into a: H maps b's full-size pixels to a's."""
        import cv2

        m = self._ratio_matches(fa.descriptors, fb.descriptors)
        if len(m) < self.min_inliers:
            return PairMatch(None, len(m), 0, f"{len(m)} matches")
        pa, pb = fa.keypoints[m[:, 0]], fb.keypoints[m[:, 1]]
        H, mask = cv2.findHomography(pb, pa, cv2.USAC_MAGSAC, self.ransac_px / fa.scale, maxIters=5000,
                                     confidence=0.999)
        if H is None:
            return PairMatch(None, len(m), 0, "no homography")
        n_in = int(mask.sum())
        if n_in < self.min_inliers or n_in < self.min_inlier_share * len(m):
            return PairMatch(None, len(m), n_in, f"{n_in} inliers of {len(m)}")
        if K is not None:
            _, _, s = similarity_of(H, K)
            Hn = np.linalg.inv(K) @ H @ K
            persp = float(math.hypot(Hn[2, 0], Hn[2, 1]) / abs(Hn[2, 2]))  # ~ tan of the relative tilt
            if not (self.scale_range[0] <= s <= self.scale_range[1]):
                return PairMatch(None, len(m), n_in, f"scale {s:.2f}")
            if abs(persp) > self.max_perspective:
                return PairMatch(None, len(m), n_in, f"perspective {persp:.2f}")
        return PairMatch(H, len(m), n_in)
