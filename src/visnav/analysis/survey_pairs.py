"""The WITAS map registration and the geo-location registration on real survey photos registered to each other.

There is no orthophoto of the Seneca survey, so the reference map of each pair is made of the earlier photo
itself: photo a, orthorectified north-up onto the ground plane with its pose (GPS position, the VO's
attitude and height above the ground, ``VONavigator.photo_pose``). Photo b is then registered to that map
by ``vision/registration.MapRegistration`` (WITAS, seed 002 §5.7: NCC of the north-up template) and by
``vision/geolocation_registration.GeoRegistration`` (seed 002 §7.3: Sobel edges, Hough alignment,
correlation), and the position each gives is compared with b's GPS fix (the nadir point for WITAS, the
ground point of the image centre for the geo-location registration; its offset from the nadir point comes
from the VO's tilt). Both errors hold the GPS noise of both photos (EXIF fixes: metres) besides the
registration's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from visnav.geometry.rotations import dcm_to_euler
from visnav.world.maps import GeoImage
from visnav.vision.geolocation_registration import GeoRegistration
from visnav.vision.registration import MapRegistration


@dataclass
class PairResult:
    a: int
    b: int
    gps_offset_m: float  # |GPS b - GPS a| horizontally
    witas_error_m: float  # |WITAS vehicle position - GPS b|
    witas_peak: float
    geo_error_m: float  # |geo-location frame centre - (GPS b + view-angle offset)|
    geo_quality: float
    feature_error_m: float = float("nan")  # |the VO's own displacement a -> b (feature homography) - GPS offset|


def ortho_map(image: np.ndarray, K: np.ndarray, R_cn: np.ndarray, C_ned: np.ndarray, height: float,
              res_m: float, half_m: float):
    """Photo ``image`` orthorectified north-up onto the ground (down = C_ned[2] + height), ``half_m`` around its
    nadir point at ``res_m`` per pixel, as a ``GeoImage``: map pixel (c, r) -> ground point P -> image pixel
    K R_cn^T (P - C)."""

    n = int(round(2 * half_m / res_m))
    north0, east0 = C_ned[0] + half_m, C_ned[1] - half_m
    A = np.array([[0.0, -res_m, north0 - C_ned[0]], [res_m, 0.0, east0 - C_ned[1]], [0.0, 0.0, height]])
    H = K @ R_cn.T @ A  # map pixel -> image pixel
    img = cv2.warpPerspective(image, H, (n, n), flags=cv2.INTER_AREA | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_REFLECT)
    return GeoImage(img, north0, east0, res_m, name="ortho of the earlier photo")


def measure_pairs(images, camera, mount, poses, gps_ne, pairs, res_m: float = 0.25,
                  search_m: float = 15.0, predict_offset_m=(6.0, -4.0), vo_offsets=None) -> list[PairResult]:
    """For each (a, b): photo a as the map, photo b registered to it by both methods, searched ``search_m``
    around b's GPS fix moved by ``predict_offset_m`` (a prediction error to recover). ``vo_offsets``:
    {(a, b): NE displacement from the VO chain}, scored the same way (the feature homography's own error)."""

    K = camera.K
    out = []
    for a, b in pairs:
        Ra, Ca, ha = poses[a]
        Rb, Cb, hb = poses[b]
        half = 1.6 * max(ha, hb) * max(camera.width, camera.height) / (2 * camera.fx) + search_m
        ref = ortho_map(images[a], K, Ra, np.r_[gps_ne[a], Ca[2]], ha, res_m, half)
        C_bn = Rb @ np.asarray(mount.R_cam_to_body, float).T
        euler = dcm_to_euler(C_bn)
        pred = np.asarray(gps_ne[b], float) + predict_offset_m
        wr = MapRegistration(ref, K, mount).register(images[b], euler, hb, pred, search_m)
        w_err = float(np.linalg.norm(wr.peak_ne - gps_ne[b])) if wr.ok else float("nan")
        geo = GeoRegistration(ref, camera, process_size=(camera.width // 2, camera.height // 2),
                              search_radius_m=search_m)
        gm = geo.register(images[b], hb, float(euler[2]), pred)
        ray = Rb[:, 2]  # where b's optical axis meets the ground, from its nadir point
        centre_true = np.asarray(gps_ne[b], float) + ray[:2] * hb / max(ray[2], 0.2)
        g_err = float(np.linalg.norm(gm.frame_centre_ne - centre_true)) if gm.ok else float("nan")
        d_gps = np.subtract(gps_ne[b], gps_ne[a])
        f_err = float(np.linalg.norm(np.asarray(vo_offsets[(a, b)]) - d_gps)) if vo_offsets and (a, b) in vo_offsets \
            else float("nan")
        out.append(PairResult(a, b, float(np.linalg.norm(d_gps)), w_err, float(wr.peak), g_err,
                              float(gm.quality) if gm.ok else float("nan"), f_err))
    return out


def summary(results: list[PairResult]) -> dict:
    w = np.array([r.witas_error_m for r in results])
    g = np.array([r.geo_error_m for r in results])
    med = lambda x: float(np.nanmedian(x)) if np.isfinite(x).any() else float("nan")  # noqa: E731
    return {"pairs": len(results), "witas_registered": int(np.isfinite(w).sum()), "witas_median_error_m": med(w),
            "witas_max_error_m": float(np.nanmax(w)) if np.isfinite(w).any() else math.nan,
            "geo_registered": int(np.isfinite(g).sum()), "geo_median_error_m": med(g),
            "geo_max_error_m": float(np.nanmax(g)) if np.isfinite(g).any() else math.nan,
            "feature_median_error_m": med(np.array([r.feature_error_m for r in results]))}
