"""The forward camera that sees the deck lights (seed 003 §5.1): a small synthetic frame per capture.

The frame is dark sea with a brighter deck plate (a filled polygon of the projected deck corners)
and each visible light drawn as a Gaussian spot at its distorted projection (eq. 5.3-5.7), plus
sensor noise. Extra bright points (not deck lights) can be drawn too, for robustness tests.
Only the few pixels around each spot are touched; a frame costs well under a millisecond plus the
noise (a pre-drawn field shifted at random each frame).

``centroid_noise_px`` moves each spot by white noise before it is drawn: real LED blobs flicker,
bloom and are smeared by the rolling shutter, so their centroids scatter by a few tenths of a pixel
(the rendered spots alone are found to 0.025 px). As a sensor (``sample(t, truth_at, world)``) it
returns a time-stamped ``Frame``; finding the blobs is the navigator's job (``vision/blobs.py``).
"""

from __future__ import annotations

import cv2
import numpy as np

from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import Frame


class LedCamera:
    def __init__(self, camera, T_cam: np.ndarray, rho: np.ndarray, rng: np.random.Generator, noise_gray: float = 2.0,
                 spot_sigma_px: float = 1.3, sea_gray: int = 25, deck_gray: int = 60, centroid_noise_px: float = 0.0,
                 jitter_rng: np.random.Generator | None = None, rate_hz: float = 30.0, latency_s: float = 0.0):
        self.camera, self.T_cam, self.rho = camera, np.asarray(T_cam, float), np.asarray(rho, float)
        self.rng = rng
        self.rate_hz, self.latency_s = rate_hz, latency_s
        self.centroid_noise_px = centroid_noise_px
        self.jitter_rng = jitter_rng if jitter_rng is not None else rng
        self._index = 0
        self.spot_sigma = spot_sigma_px
        self.sea_gray, self.deck_gray = sea_gray, deck_gray
        h, w = camera.height, camera.width
        self._noise = rng.normal(0.0, noise_gray, (h + 64, w + 64)).astype(np.float32) if noise_gray > 0 else None
        r = int(np.ceil(4 * spot_sigma_px))
        yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
        self._r, self._yy, self._xx = r, yy, xx

    def project(self, points_ned: np.ndarray, position: np.ndarray, C_bn: np.ndarray):
        """Pixel positions (N, 2) of NED points and a mask of those in front of the camera and in the image."""
        p_b = (np.asarray(points_ned, float) - position) @ C_bn - self.rho
        s = p_b @ self.T_cam.T
        front = s[:, 2] > 0.05
        xy = s[:, :2] / np.where(front, s[:, 2], 1.0)[:, None]
        uv = self.camera.normalized_to_pixel(xy)  # (applies the lens distortion, eq. 5.3-5.7, once)
        inside = front & self.camera.in_image(uv, margin=2.0) & (np.abs(xy).max(axis=1) < 1.5)
        return uv, inside

    def render(self, position: np.ndarray, C_bn: np.ndarray, lights_ned: np.ndarray, deck_corners_ned: np.ndarray,
               extra_ned: np.ndarray | None = None) -> np.ndarray:
        cam = self.camera
        img = getattr(self, "_img", None)  # one float buffer for every frame (a new one page-faults each time)
        if img is None:
            img = self._img = np.empty((cam.height, cam.width), np.float32)
        img.fill(float(self.sea_gray))
        uvc, okc = self.project(deck_corners_ned, position, C_bn)
        if okc.sum() >= 3:
            cv2.fillPoly(img, [np.round(uvc[okc]).astype(np.int32)], float(self.deck_gray))
        pts = lights_ned if extra_ned is None or len(extra_ned) == 0 else np.vstack([lights_ned, extra_ned])
        uv, ok = self.project(pts, position, C_bn)
        if self.centroid_noise_px > 0 and ok.any():
            uv = uv.copy()
            uv[ok] += self.centroid_noise_px * self.jitter_rng.standard_normal((int(ok.sum()), 2))
        r, s2 = self._r, 2.0 * self.spot_sigma**2
        for (u, v) in uv[ok]:
            iu, iv = int(round(u)), int(round(v))
            spot = 230.0 * np.exp(-((self._xx + iu - u) ** 2 + (self._yy + iv - v) ** 2) / s2)
            u0, u1, v0, v1 = iu - r, iu + r + 1, iv - r, iv + r + 1
            cu0, cv0 = max(u0, 0), max(v0, 0)
            cu1, cv1 = min(u1, cam.width), min(v1, cam.height)
            if cu1 <= cu0 or cv1 <= cv0:
                continue
            sub = spot[cv0 - v0:cv1 - v0, cu0 - u0:cu1 - u0]
            img[cv0:cv1, cu0:cu1] = np.maximum(img[cv0:cv1, cu0:cu1], sub + self.deck_gray)
        if self._noise is not None:
            dy, dx = self.rng.integers(0, 64, 2)
            img += self._noise[dy:dy + cam.height, dx:dx + cam.width]
        return np.clip(img, 0, 255, out=img).astype(np.uint8)

    def sample(self, t: float, truth_at, world) -> Frame:
        """The frame taken at ``t`` of the deck scene ``world`` (``world/deck.DeckWorld``)."""
        s = truth_at(t)
        ds = world.motion.state(t)
        img = self.render(s.position, euler_to_dcm(s.euler), world.to_ned(ds, world.lights_at(t)),
                          world.to_ned(ds, world.corners), world.to_ned(ds, world.extra) if len(world.extra) else None)
        self._index += 1
        return Frame(t=t, image=img, index=self._index - 1)
