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
                 jitter_rng: np.random.Generator | None = None, rate_hz: float = 30.0, latency_s: float = 0.0,
                 time_offset_s: float = 0.0):
        self.time_offset_s = time_offset_s  # the frame shows the scene this long before its stamp
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
        return self._pixels(self._camera_xyz(points_ned, position, C_bn))

    def _camera_xyz(self, points_ned, position, C_bn) -> np.ndarray:
        """NED points -> camera axes (N, 3)."""
        p_b = (np.asarray(points_ned, float) - position) @ C_bn - self.rho
        return p_b @ self.T_cam.T

    def _pixels(self, s: np.ndarray):
        """Pixels (N, 2) of camera-axes points and the mask of those in front and in the image (row by row:
        several point sets may go through in one call)."""
        front = s[:, 2] > 0.05
        xy = s[:, :2] / np.where(front, s[:, 2], 1.0)[:, None]
        uv = self.camera.normalized_to_pixel(xy)  # (applies the lens distortion, eq. 5.3-5.7, once)
        inside = front & self.camera.in_image(uv, margin=2.0) & (np.abs(xy).max(axis=1) < 1.5)
        return uv, inside

    def _fields(self):
        """The frame's two backgrounds with the noise field already added, as uint8 (built once).

        A pixel of the old float32 frame was ``uint8(clip(float32(gray) + noise))`` with ``gray`` the sea's
        or the deck's level wherever no spot was drawn; that is a fixed function of the pixel's place in
        the noise field, so both are stored for the whole field and the frame only selects between them."""
        f = getattr(self, "_u8", None)
        if f is None:
            h, w = self.camera.height, self.camera.width
            noise = self._noise if self._noise is not None else np.zeros((h + 64, w + 64), np.float32)
            sea = np.clip(np.full(noise.shape, float(self.sea_gray), np.float32) + noise, 0, 255).astype(np.uint8)
            deck = np.clip(np.full(noise.shape, float(self.deck_gray), np.float32) + noise, 0, 255).astype(np.uint8)
            f = self._u8 = (noise, sea, deck, np.zeros((h, w), np.uint8), np.zeros((h, w), np.float32))
        return f

    def render(self, position: np.ndarray, C_bn: np.ndarray, lights_ned: np.ndarray, deck_corners_ned: np.ndarray,
               extra_ned: np.ndarray | None = None) -> np.ndarray:
        """The uint8 frame: sea, the deck polygon, the spots, the noise window of this frame.

        Pixel for pixel what the float32 frame gave (sea level filled, deck polygon filled, each spot's
        patch set to ``max(pixel, spot + deck_gray)``, the noise window added, clipped to [0, 255],
        truncated to uint8; ``tests/sensors/test_led_camera.py`` keeps that reference and compares), but in
        uint8: the backgrounds plus noise come precomputed (``_fields``), the polygon selects the deck's
        pixels through a mask of its bounding box, and only the spots' patches are computed in float32.
        """
        cam = self.camera
        h, w = cam.height, cam.width
        noise, sea, deck, mask, acc = self._fields()
        pts = lights_ned if extra_ned is None or len(extra_ned) == 0 else np.vstack([lights_ned, extra_ned])
        nc = len(deck_corners_ned)
        uv, ok = self._pixels(np.concatenate([self._camera_xyz(deck_corners_ned, position, C_bn),
                                              self._camera_xyz(pts, position, C_bn)]))
        uvc, okc, uv, ok = uv[:nc], ok[:nc], uv[nc:], ok[nc:]
        if self.centroid_noise_px > 0 and ok.any():
            uv = uv.copy()
            uv[ok] += self.centroid_noise_px * self.jitter_rng.standard_normal((int(ok.sum()), 2))
        dy, dx = self.rng.integers(0, 64, 2) if self._noise is not None else (0, 0)
        nz = noise[dy:dy + h, dx:dx + w]
        img = sea[dy:dy + h, dx:dx + w].copy()
        box = None
        if okc.sum() >= 3:  # the deck polygon, rasterised into the mask over its bounding box (the same pixels)
            poly = np.round(uvc[okc]).astype(np.int32)
            us, vs = zip(*poly.tolist())
            x0, y0, x1, y1 = max(min(us), 0), max(min(vs), 0), min(max(us) + 1, w), min(max(vs) + 1, h)
            if x1 > x0 and y1 > y0:
                box = (slice(y0, y1), slice(x0, x1))
                cv2.fillPoly(mask[box], [poly], 1, offset=(-x0, -y0))
                cv2.copyTo(deck[dy + y0:dy + y1, dx + x0:dx + x1], mask[box], img[box])
        uvs = uv[ok]
        if len(uvs):
            # every spot at once (the same elementwise arithmetic as one spot at a time)
            r, s2 = self._r, 2.0 * self.spot_sigma**2
            U, V = uvs[:, 0, None, None], uvs[:, 1, None, None]
            iu, iv = np.rint(U).astype(np.int64), np.rint(V).astype(np.int64)  # round half to even, as round()
            spots = ((230.0 * np.exp(-((self._xx + iu - U) ** 2 + (self._yy + iv - V) ** 2) / s2))
                     + self.deck_gray).astype(np.float32)  # float32(spot + deck_gray)
            patches = []
            for k, (cu, cv) in enumerate(zip(iu.ravel().tolist(), iv.ravel().tolist())):
                u0, v0 = cu - r, cv - r
                cu0, cv0, cu1, cv1 = max(u0, 0), max(v0, 0), min(cu + r + 1, w), min(cv + r + 1, h)
                if cu1 <= cu0 or cv1 <= cv0:
                    continue
                p = (slice(cv0, cv1), slice(cu0, cu1))
                np.maximum(acc[p], spots[k, cv0 - v0:cv1 - v0, cu0 - u0:cu1 - u0], out=acc[p])  # overlaps: largest
                patches.append(p)
            for p in patches:  # the pixel's level under the spot, the spot where larger, plus the noise
                a = acc[p]
                if self.sea_gray > self.deck_gray:  # (spots are >= deck_gray: above the deck they always win)
                    a = np.maximum(a, np.where(mask[p] != 0, np.float32(self.deck_gray), np.float32(self.sea_gray)))
                a = np.minimum(np.maximum(a + nz[p], 0.0), 255.0)
                img[p] = a.astype(np.uint8)
            for p in patches:
                acc[p] = 0.0
        if box is not None:
            mask[box] = 0
        return img

    def sample(self, t: float, truth_at, world) -> Frame:
        """The frame stamped ``t`` of the deck scene ``world`` (``world/deck.DeckWorld``), taken ``time_offset_s``
        earlier."""
        t_scene = t - self.time_offset_s
        s = truth_at(t_scene)
        ds = world.motion.state(t_scene)
        img = self.render(s.position, euler_to_dcm(s.euler), world.to_ned(ds, world.lights_at(t)),
                          world.to_ned(ds, world.corners), world.to_ned(ds, world.extra) if len(world.extra) else None)
        self._index += 1
        return Frame(t=t, image=img, index=self._index - 1)
