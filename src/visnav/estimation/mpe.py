"""Monocular Position Estimation (seed 000 §2.2.3, Algorithms 3 and 4, eq. 2.5).

One tracked ground point, the laser range and the attitude at the image's time stamp give the
camera position:

* Algorithm 3 (ground reference):  R = G0 + M0 P0
* Algorithm 4 (position update):   E  = R  - MN PN
* eq. 2.5: P = (R_N (x - W/2) / f, R_N (y - H/2) / f, R_N) in camera axes.

The thesis' camera axes (x right, y down, z along the axis) are OpenCV's, so M (camera -> world)
is our ``C_cn``; W/2, H/2 become the principal point (cx, cy) and lens distortion is removed
before the pinhole inversion.

Two range models:

``thesis``  eq. 2.5 as written: the laser range is taken as the depth P_Z of the tracked point.
            Exact when the tracked point lies on the laser beam.
``plane``   the laser range along the beam fixes the camera's height over a flat, level ground;
            the tracked pixel's ray is intersected with that plane. Exact on flat ground for any
            pixel (our default: the tracked point drifts away from the image centre).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount


@dataclass(frozen=True)
class MpeFix:
    t: float
    camera_position: np.ndarray  # NED of the camera centre
    position: np.ndarray  # NED of the vehicle reference point
    ground_offset: np.ndarray  # camera -> tracked ground point, NED
    sigma_px_m: float  # pixel quantisation noise at this range, R / (f sqrt 12) (eq. 3.3)


class MonocularPositionEstimator:
    def __init__(self, camera: PinholeCamera, mount: FixedMount, model: str = "plane"):
        if model not in ("thesis", "plane"):
            raise ValueError(f"MPE model must be 'thesis' or 'plane', got {model!r}")
        self.camera = camera
        self.mount = mount
        self.model = model
        self.ground_reference: np.ndarray | None = None

    # ------------------------------------------------------------------------------------
    def camera_offset(self, uv, range_m: float, C_bn: np.ndarray, beam_offset: float = 0.0) -> np.ndarray:
        """NED vector from the camera centre to the ground point seen at pixel ``uv``: M P."""
        if not np.isfinite(range_m) or range_m <= 0:
            raise ValueError(f"MPE needs a positive finite range, got {range_m!r}")
        C_cn = C_bn @ self.mount.R_cam_to_body
        xy = self.camera.pixel_to_normalized(np.asarray(uv, dtype=float).reshape(1, 2))[0]
        ray_c = np.array([xy[0], xy[1], 1.0])
        if self.model == "thesis":
            return C_cn @ (range_m * ray_c)  # eq. 2.5: P_Z = R_N
        beam_c = np.array([0.0, np.sin(beam_offset), np.cos(beam_offset)])
        height = range_m * float(C_cn[2] @ beam_c)  # camera height over the ground plane
        ray_n = C_cn @ ray_c
        if ray_n[2] <= 1e-6 or height <= 0:
            raise ValueError("MPE: the tracked ray or the laser beam does not point at the ground")
        return ray_n * (height / ray_n[2])

    def initialize(self, uv, range_m: float, C_bn: np.ndarray, vehicle_position: np.ndarray,
                   beam_offset: float = 0.0) -> np.ndarray:
        """Algorithm 3: save the ground reference R = G0 + M0 P0 from a known vehicle position."""
        cam = np.asarray(vehicle_position, float) + C_bn @ self.mount.lever_arm
        self.ground_reference = cam + self.camera_offset(uv, range_m, C_bn, beam_offset)
        return self.ground_reference

    def estimate(self, t: float, uv, range_m: float, C_bn: np.ndarray, beam_offset: float = 0.0) -> MpeFix:
        """Algorithm 4: E = R - MN PN, then the vehicle reference point from the lever arm."""
        if self.ground_reference is None:
            raise RuntimeError("MPE has no ground reference: call initialize() first")
        off = self.camera_offset(uv, range_m, C_bn, beam_offset)
        cam = self.ground_reference - off
        pos = cam - C_bn @ self.mount.lever_arm
        sigma = float(np.linalg.norm(off)) / (self.camera.fx * np.sqrt(12.0))
        return MpeFix(t=t, camera_position=cam, position=pos, ground_offset=off, sigma_px_m=sigma)


def quantisation_sigma(range_m, focal_px: float):
    """Seed 000 eq. 3.3: sigma = R / (f sqrt 12) of a position from a pixel-quantised point."""
    return np.asarray(range_m, dtype=float) / (focal_px * np.sqrt(12.0))
