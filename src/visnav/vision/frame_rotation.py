"""The camera's rotation between consecutive frames from feature tracks (the image half of the
camera/gyro calibration of ``estimation/timesync.py``).

KLT tracks (``vision/klt.py``) are undistorted with the calibration (``cv2.undistortPoints``: the
radial-tangential model of the camera) into normalised image coordinates; the relative pose comes from
the essential matrix (five-point RANSAC, ``cv2.findEssentialMat`` / ``cv2.recoverPose``, Nistér 2004)
when the pair has parallax, and from the rotation-only model ``b2 = R b1`` on unit bearings
(orthogonal Procrustes / Kabsch inside RANSAC) when it has none (the essential matrix is degenerate for
a pure rotation); for a camera looking down on flat ground, from the plane's homography decomposed
into rotation, translation and normal (the solution whose normal is nearest the expected ground). The result is the camera's *motion*: the rotation vector ``phi`` (camera frame of
the earlier frame) with ``C_c1_c2 = exp([phi x])``, the same quantity as the integrated gyro of a
rigidly attached IMU, up to the camera-to-IMU rotation (``R_imu_cam phi``).

``frame_rotations`` also keeps, per pair, the inlier bearings (``tracks``) for the focal-length check.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from visnav.geometry.rotations import kabsch
from visnav.vision.klt import KltTracker

__all__ = ["FrameRotations", "frame_rotations", "frame_rotation_angles"]


@dataclass
class FrameRotations:
    t_pairs: np.ndarray  # (N-1, 2) stamps of the two frames of each pair (camera clock)
    rotvec: np.ndarray  # (N-1, 3) camera motion, camera frame of the earlier frame [rad]; NaN: no estimate
    inliers: np.ndarray  # (N-1,) inlier tracks per pair
    method: np.ndarray  # (N-1,) "essential", "rotation", "homography" or ""
    tracks: list  # per pair: (uv1, uv2) inlier pixel positions (distorted, as tracked) or None


def _bearings(xy: np.ndarray) -> np.ndarray:
    v = np.column_stack([xy, np.ones(len(xy))])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _rotation_ransac(b1, b2, thr_rad: float, rng, iters: int = 200):
    """b2 = R b1 by RANSAC on 2-point Kabsch samples, refined on the inliers."""
    best = np.zeros(len(b1), bool)
    for _ in range(iters):
        s = rng.choice(len(b1), 2, replace=False)
        R = kabsch(b1[s], b2[s])
        inl = np.linalg.norm(b2 - b1 @ R.T, axis=1) < thr_rad
        if inl.sum() > best.sum():
            best = inl
    if best.sum() < 3:
        return None, best
    R = kabsch(b1[best], b2[best])
    best = np.linalg.norm(b2 - b1 @ R.T, axis=1) < thr_rad
    return kabsch(b1[best], b2[best]), best


def _plane_rotation(x1, x2, normal, thr):
    """Rotation from the plane-induced homography H = R + t n^T / d (normalised coordinates; Faugeras &
    Lustman 1988, ``cv2.decomposeHomographyMat``), the solution whose normal is closest to ``normal``."""
    H, m = cv2.findHomography(x1, x2, cv2.RANSAC, thr)
    if H is None:
        return None, np.zeros(len(x1), bool)
    _, Rs, _, ns = cv2.decomposeHomographyMat(H / H[2, 2], np.eye(3))
    best = int(np.argmax([abs(float(n.ravel() @ normal)) for n in ns]))
    return Rs[best], m.ravel() > 0


def frame_rotations(times, images, camera, min_inliers: int = 15, max_features: int = 200,
                    sigma_px: float = 1.0, min_parallax_px: float = 1.0, plane_normal_cam=None,
                    rng: np.random.Generator | None = None) -> FrameRotations:
    """Rotation of the camera between consecutive frames (module docstring). ``camera``: a
    ``PinholeCamera`` (K and OpenCV distortion) or a 3x3 K without distortion. ``plane_normal_cam``: the
    expected normal of a ground plane in the camera frame (a camera looking down on flat ground, far
    away): the rotation then comes from the plane's homography, which keeps the translation out of it
    (a translation over a distant plane otherwise looks like a rotation)."""
    rng = rng if rng is not None else np.random.default_rng(0)
    if isinstance(camera, np.ndarray):
        K, dist, f = np.asarray(camera, float), np.zeros(5), float(camera[0, 0])
    else:
        K, dist, f = camera.K, np.asarray(camera.dist, float), float(camera.fx)
    t = np.asarray(times, float)
    n = max(len(t) - 1, 0)
    out = FrameRotations(np.column_stack([t[:-1], t[1:]]) if n else np.zeros((0, 2)), np.full((n, 3), np.nan),
                         np.zeros(n, int), np.array([""] * n, dtype=object), [None] * n)
    klt = KltTracker(max_features=max_features, min_distance_px=10.0)
    thr = sigma_px / f
    for i, img in enumerate(images):
        pairs = klt.track(img)
        if i == 0 or len(pairs.prev) < min_inliers:
            continue
        uv1, uv2 = np.asarray(pairs.prev, float), np.asarray(pairs.curr, float)
        x1 = cv2.undistortPoints(uv1.reshape(-1, 1, 2), K, dist).reshape(-1, 2)
        x2 = cv2.undistortPoints(uv2.reshape(-1, 1, 2), K, dist).reshape(-1, 2)
        b1, b2 = _bearings(x1), _bearings(x2)
        # points in the second camera's frame: p2 = R p1 + t (R = C_c2_c1); the camera's motion is R^T
        if plane_normal_cam is not None:
            R, inl = _plane_rotation(x1, x2, np.asarray(plane_normal_cam, float), 2 * thr)
            method = "homography"
        else:
            R, inl = _rotation_ransac(b1, b2, 3 * thr, rng)
            method = "rotation"
        if R is not None and plane_normal_cam is None:
            # parallax left after removing the best rotation: worth an essential matrix?
            resid = np.linalg.norm(b2 - b1 @ R.T, axis=1)
            if np.median(resid) * f > min_parallax_px:
                E, m = cv2.findEssentialMat(x1, x2, np.eye(3), cv2.RANSAC, 0.999, 2 * thr)
                if E is not None and E.shape == (3, 3):
                    ok, Re, _, m2 = cv2.recoverPose(E, x1, x2, np.eye(3), mask=m.copy())
                    if ok >= min_inliers:
                        R, inl, method = Re, m2.ravel() > 0, "essential"
        if R is None or inl.sum() < min_inliers:
            continue
        out.rotvec[i - 1] = cv2.Rodrigues(R.T)[0].ravel()
        out.inliers[i - 1] = int(inl.sum())
        out.method[i - 1] = method
        out.tracks[i - 1] = (uv1[inl], uv2[inl])
    return out


def frame_rotation_angles(times, images, K, ground_dir_cam=None, min_inliers: int = 12, rng=None):
    """The rotation angle per frame interval: ``(t_pairs, angles)`` (NaN where no estimate); kept for
    callers of the magnitude-only clock offset (``ground_dir_cam`` is no longer needed)."""
    r = frame_rotations(times, images, np.asarray(K, float), min_inliers=min_inliers, rng=rng)
    return r.t_pairs, np.linalg.norm(r.rotvec, axis=1)
