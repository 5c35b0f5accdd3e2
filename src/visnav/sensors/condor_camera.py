"""CONDOR camera and target (seed 004 §2.1, §7.1, Fig. 2.5, 7.2): a wide-angle camera with radial
distortion whose capture card crops the frame asymmetrically (the image centre is not the optical
centre), looking at a flat blue tent-sized rectangle on a yellow-green field.

Rendering is cheap: a noisy field image made once, and the target's outline (its edges subdivided so
that they bend with the lens distortion) projected through the camera model and filled
anti-aliased with sub-pixel vertices.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.measurements import Frame
from visnav.sensors.gimbal import camera_dcm

FIELD_RGB = (150, 170, 70)  # yellow-green grass
TARGET_RGB = (40, 70, 190)  # blue tent


def condor_camera(width: int, height: int, hfov_deg: float, k1: float, k2: float, crop_dx_px: float,
                  crop_dy_px: float) -> PinholeCamera:
    """Mobius-like camera: ``hfov_deg`` across the processed frame, radial distortion (k1, k2), and
    the optical centre ``crop_dx_px``, ``crop_dy_px`` off the image centre (asymmetric crop)."""
    f = width / (2.0 * math.tan(math.radians(hfov_deg) / 2.0))
    return PinholeCamera(width, height, f, f, (width - 1) / 2.0 + crop_dx_px, (height - 1) / 2.0 + crop_dy_px,
                         (k1, k2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))


def target_outline(centre_ne, length_m: float, width_m: float, heading: float, per_edge: int = 6) -> np.ndarray:
    """(4 * per_edge, 3) NED points along the rectangle's edges, on the ground (down = 0)."""
    hl, hw = length_m / 2, width_m / 2
    corners = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
    s = np.linspace(0, 1, per_edge, endpoint=False)
    pts = np.concatenate([a + s[:, None] * (b - a) for a, b in zip(corners[:-1], corners[1:])])
    c, sn = math.cos(heading), math.sin(heading)
    ne = pts @ np.array([[c, sn], [-sn, c]]) + np.asarray(centre_ne, float)
    return np.column_stack([ne, np.zeros(len(ne))])


class TargetCamera:
    def __init__(self, camera: PinholeCamera, rng: np.random.Generator, noise_sigma: float = 4.0) -> None:
        self.camera = camera
        h, w = camera.height, camera.width
        base = np.array(FIELD_RGB, np.int16)[None, None, :] + rng.normal(0, 12, (h, w, 1)).astype(np.int16)
        self.background = np.clip(base + rng.normal(0, noise_sigma, (h, w, 3)), 0, 255).astype(np.uint8)

    def project(self, cam_pos, pan: float, tilt: float, roll: float, points_ned) -> np.ndarray:
        p = (np.asarray(points_ned, float) - np.asarray(cam_pos, float)) @ camera_dcm(pan, tilt, roll).T
        return self.camera.project(p)

    def render(self, cam_pos, pan: float, tilt: float, roll: float, outline_ned) -> np.ndarray:
        """RGB frame (H, W, 3) uint8 with the target filled in where it is in view."""
        img = self.background.copy()
        uv = self.project(cam_pos, pan, tilt, roll, outline_ned)
        lim = 4.0 * max(self.camera.width, self.camera.height)
        if (np.abs(uv) < lim).all():  # (NaN and inf compare False: every vertex finite and within the limit)
            poly = np.round(uv * 16.0).astype(np.int32)[None]
            cv2.fillPoly(img, poly, TARGET_RGB, lineType=cv2.LINE_AA, shift=4)
        return img


class GimbalCamera:
    """The camera on CONDOR's gimbal as a sensor: renders the tent (``world.outline``) from the true
    aircraft position and the gimbal's true camera attitude (``world.gimbal``) -> ``Frame``."""

    def __init__(self, renderer: TargetCamera, rate_hz: float = 7.5, latency_s: float = 0.0) -> None:
        self.renderer, self.rate_hz, self.latency_s = renderer, float(rate_hz), float(latency_s)
        self.index = 0

    def sample(self, t: float, truth_at, world) -> Frame:
        s = truth_at(t)
        pan, tilt, roll = world.gimbal.camera_attitude(s.euler)
        img = self.renderer.render(s.position, pan, tilt, roll, world.outline)
        self.index += 1
        return Frame(t=t, image=img, index=self.index - 1)
