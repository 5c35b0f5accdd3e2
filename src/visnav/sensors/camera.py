"""Camera that renders frames of the textured ground plane (DESIGN §5).

A frame is the plane-induced homography from map pixels to image pixels, applied with
``cv2.warpPerspective`` on the map pyramid level nearest the camera's ground sample distance
(no aliasing); a wrapped fine-detail tile adds millimetre texture at low altitude; lens distortion
(``cv2.remap``) when the camera has any; then sensor noise. Rays that miss the ground show sky.
"""

from __future__ import annotations

import contextlib
import math

import cv2
import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.mounts import FixedMount
from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import Frame
from visnav.sensors.base import TruthAt
from visnav.scalar import clip as _clip


def ground_homography(K: np.ndarray, cam_pos: np.ndarray, C_cn: np.ndarray, affine: np.ndarray) -> np.ndarray:
    """Homography from map pixels [col, row, 1] to image pixels for the ground plane z = 0.

    ``affine`` maps [col, row, 1] to [north, east, 1]. A ground point p = (n, e, 0) projects to
    K C_cn^T (p - c); with p - c = M [col, row, 1]^T the homography is K C_cn^T M.
    """
    M = np.array(
        [
            [affine[0, 0], affine[0, 1], affine[0, 2] - cam_pos[0]],
            [affine[1, 0], affine[1, 1], affine[1, 2] - cam_pos[1]],
            [0.0, 0.0, -cam_pos[2]],
        ]
    )
    return K @ C_cn.T @ M


class CameraRenderer:
    """Renders ideal-pinhole frames, then distortion and noise."""

    def __init__(self, camera: PinholeCamera, noise_sigma: float, rng: np.random.Generator,
                 lod_bias: float = 1.5):
        self.camera = camera
        self.lod_bias = lod_bias  # > 1 samples a coarser level (less aliasing, more blur)
        self.size = (camera.width, camera.height)
        self.K = camera.K
        self.Kinv = np.linalg.inv(self.K)
        pad = 32
        self._pad = pad
        self.rng = rng
        self._noise = None
        if noise_sigma > 0:
            bank = rng.normal(0.0, noise_sigma, (4, camera.height + pad, camera.width + pad))
            self._noise = np.clip(np.round(bank), -127, 127).astype(np.int16)
            # the bank split into its positive and negative parts (uint8): image + n saturated to [0, 255]
            # is (image + max(n, 0) saturated) - max(-n, 0) saturated, exactly (one of the two is 0), in
            # two uint8 passes instead of a mixed uint8 + int16 one
            self._noise_pos = np.maximum(self._noise, 0).astype(np.uint8)
            self._noise_neg = np.maximum(-self._noise, 0).astype(np.uint8)
        w, h = self.size
        self._corners = np.array([[0, 0, 1], [w - 1, 0, 1], [0, h - 1, 1], [w - 1, h - 1, 1]], dtype=float)
        self._undistort_maps = None
        if camera.has_distortion:
            u, v = np.meshgrid(np.arange(camera.width, dtype=float), np.arange(camera.height, dtype=float))
            xy = camera.pixel_to_normalized(np.column_stack([u.ravel(), v.ravel()]))
            mx = (camera.fx * xy[:, 0] + camera.cx).reshape(u.shape).astype(np.float32)
            my = (camera.fy * xy[:, 1] + camera.cy).reshape(u.shape).astype(np.float32)
            self._undistort_maps = (mx, my)
        self._tile_levels: dict[int, tuple[np.ndarray, int]] = {}
        self._blend_cache: dict[tuple, np.ndarray] = {}
        self._affines: dict[tuple, np.ndarray] = {}
        self._affines_of: dict[tuple, object] = {}

    # -- pieces ----------------------------------------------------------------------------
    def _sky_mask(self, C_cn: np.ndarray) -> np.ndarray | None:
        """Pixels whose ray does not point down at the ground (None when every ray hits)."""
        w, h = self.size
        # d_z(u, v) = row 2 of C_cn K^-1 [u v 1]^T is affine in (u, v)
        c = C_cn[2] @ self.Kinv
        if (self._corners @ c > 1e-6).all():
            return None
        u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
        return (c[0] * u + c[1] * v + c[2]) <= 1e-6

    def _border_value(self, ground) -> int:
        """Ground beyond the map's edge is drawn in the map's mean grey."""
        if getattr(self, "_border_for", None) is not ground:
            self._border_for = ground
            self._border = int(np.mean(ground.level(0)[::8, ::8]))
        return self._border

    def _tile_level(self, tile: np.ndarray, level: int) -> tuple[np.ndarray, int]:
        """The detail tile reduced ``level`` times, repeated to about 2048 px; and its period in px."""
        if level not in self._tile_levels:
            img = tile
            for _ in range(level):
                img = cv2.resize(img, (img.shape[1] // 2, img.shape[0] // 2), interpolation=cv2.INTER_AREA)
            m = max(1, int(np.ceil(2048 / img.shape[0])))
            self._tile_levels[level] = (np.ascontiguousarray(np.tile(img, (m, m))), img.shape[0])
        return self._tile_levels[level]

    @staticmethod
    def _ground_centre(cam_pos: np.ndarray, C_cn: np.ndarray) -> np.ndarray:
        """Where the optical axis meets the ground (or the point below the camera if it does not)."""
        d = C_cn[:, 2]
        if d[2] > 1e-3:
            return cam_pos + d * (-cam_pos[2] / d[2])
        return cam_pos

    def _affine(self, ground, L: int) -> np.ndarray:
        """``ground.affine(L)``, cached (read-only)."""
        key = (id(ground), L)
        a = self._affines.get(key)
        if a is None or self._affines_of.get(key) is not ground:
            a = self._affines[key] = ground.affine(L)
            a.setflags(write=False)
            self._affines_of[key] = ground
        return a

    def _blended_level(self, ground, L: int, q: int) -> np.ndarray:
        """Level ``L`` blended with level ``L + 1`` (upsampled) at weight q/8, cached."""
        if q == 0:
            return ground.level(L)
        key = (id(ground), L, q)
        img = self._blend_cache.get(key)
        if img is None:
            lo = ground.level(L)
            up_key = (id(ground), L, "up")  # level L + 1 upsampled: one resize for all the weights of level L
            up = self._blend_cache.get(up_key)
            if up is None:
                up = self._blend_cache[up_key] = cv2.resize(ground.level(L + 1), (lo.shape[1], lo.shape[0]),
                                                            interpolation=cv2.INTER_LINEAR)
            img = self._blend_cache[key] = cv2.addWeighted(lo, 1.0 - q / 8.0, up, q / 8.0, 0.0)
        return img

    def plan(self, cam_pos: np.ndarray, C_cn: np.ndarray, world) -> tuple:
        """Everything of a frame but its pixels: the pyramid level and its homography, the detail tile's,
        the sky, the noise draw (``render`` = ``execute(plan(...))``). The Python part of a frame: a frame
        rendered on a worker thread is planned on the caller's, so the worker only runs OpenCV (which
        releases the GIL) and does not take the interpreter from the simulation loop between calls."""
        w, h = self.size
        height = -float(cam_pos[2])
        axis_down = float(C_cn[2, 2])
        depth = height / max(axis_down, 0.05)
        gsd = max(depth, 1e-3) / self.camera.fx
        ground = world.ground
        # trilinear ("mip-mapped") sampling: a blend of the two pyramid levels around the ground
        # sample distance, so the image statistics change smoothly with height (no jump at a level
        # switch, which would break a correlation tracker) and the map is never sampled below
        # Nyquist. The blend weight is quantised to 1/8 and the blended levels are cached, so a
        # frame costs one warp.
        lf = float(np.log2(gsd * self.lod_bias / ground.resolution_m))
        top = ground.max_level
        L0 = min(max(math.floor(lf), 0), max(top - 1, 0))
        q = int(round(8 * _clip(lf - L0, 0.0, 1.0))) if top > 0 else 0
        if q == 8:
            L0, q = min(L0 + 1, top), 0
        base = (self._blended_level(ground, L0, q), ground_homography(self.K, cam_pos, C_cn, self._affine(ground, L0)),
                self._border_value(ground))
        detail = None
        if world.detail is not None and gsd < 0.03:
            tres = world.detail_resolution_m
            Lt = 0
            while tres * 2 ** (Lt + 1) <= gsd and Lt < 4:
                Lt += 1
            tile, period = self._tile_level(world.detail, Lt)
            r = tres * world.detail.shape[0] / period  # exact even when the size is not divisible by 2^Lt
            # Shift the (periodic) tile by whole periods so the view's centre lands mid-tile: the
            # warp then rarely needs BORDER_WRAP, whose per-pixel modulo is the slow path.
            centre = self._ground_centre(cam_pos, C_cn)
            c0 = centre[1] / r - tile.shape[1] / 2
            r0 = -centre[0] / r - tile.shape[0] / 2
            sc, sr = np.floor(c0 / period) * period, np.floor(r0 / period) * period
            # tile pixel (c, r) -> (n, e) = (-(row + sr) * r, (col + sc) * r): north up like every map
            At = np.array([[0.0, -r, -sr * r], [r, 0.0, sc * r], [0.0, 0.0, 1.0]])
            # fade the detail in as the ground sample distance shrinks below 3 cm
            wgt = _clip((0.03 - gsd) / 0.02, 0.0, 1.0)
            detail = (tile, ground_homography(self.K, cam_pos, C_cn, At), wgt)
        sky = self._sky_mask(C_cn)
        noise = None
        if self._noise is not None:
            k = int(self.rng.integers(0, self._noise.shape[0]))
            dy, dx = (int(x) for x in self.rng.integers(0, self._pad, 2))
            noise = (self._noise_pos[k, dy : dy + h, dx : dx + w], self._noise_neg[k, dy : dy + h, dx : dx + w])
        return base, detail, sky, world.sky_level, noise

    def execute(self, plan: tuple) -> np.ndarray:
        """The pixels of a ``plan``: OpenCV calls only."""
        (level, Hm, border), detail, sky, sky_level, noise = plan
        img = cv2.warpPerspective(level, Hm, self.size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                                  borderValue=border)
        if detail is not None:
            tile, Ht, wgt = detail
            det = cv2.warpPerspective(tile, Ht, self.size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
            img = cv2.addWeighted(img, 1.0, det, wgt, -128.0 * wgt)
        if sky is not None:
            img[sky] = sky_level
        if self._undistort_maps is not None:
            img = cv2.remap(img, *self._undistort_maps, interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if noise is not None:
            img = cv2.add(img, noise[0])
            cv2.subtract(img, noise[1], dst=img)
        return img

    def render(self, cam_pos: np.ndarray, C_cn: np.ndarray, world) -> np.ndarray:
        return self.execute(self.plan(cam_pos, C_cn, world))


class Camera:
    """Camera sensor on a mount: captures at ``capture_hz``; the vision pipeline consumes every
    ``decimation``-th frame, and only those are rendered (the others would be discarded)."""

    #: a frame is a function of the truth, the world and the camera's own noise draws only (not of the
    #: navigator or the mission): the loop may sample it before it delivers what was due earlier
    samples_truth_only = True

    def __init__(
        self,
        camera: PinholeCamera,
        mount: FixedMount,
        rng: np.random.Generator,
        capture_hz: float = 30.0,
        process_hz: float = 10.0,
        noise_sigma: float = 2.0,
        latency_s: float = 0.0,
        delay_s: float = 0.0,
    ):
        self.camera = camera
        self.mount = mount
        self.capture_hz = capture_hz
        self.decimation = max(1, int(round(capture_hz / process_hz)))
        self.rate_hz = capture_hz / self.decimation
        self.latency_s = latency_s
        self.delay_s = delay_s  # unknown: the image shows the instant delay_s before its stamp
        self.renderer = CameraRenderer(camera, noise_sigma, rng)
        self.frames = 0

    def sample(self, t: float, truth_at: TruthAt, world) -> Frame:
        s = truth_at(t - self.delay_s)
        cam_pos, C_cn = self.mount.camera_pose(s.position, euler_to_dcm(s.euler))
        img = self.renderer.render(cam_pos, C_cn, world)
        self.frames += 1
        return Frame(t=t, image=img, index=self.frames * self.decimation)

    def sample_async(self, t: float, truth_at: TruthAt, world, executor, then=None) -> "PendingFrame":
        """Like ``sample`` but renders on ``executor`` (one worker: frames stay in order and the
        noise draws stay reproducible); the frame is planned here (its Python part) and rendered there by
        OpenCV, which releases the GIL, so it renders on the second core while the simulation steps on
        through the camera's latency. ``then(image)``, when given, runs there too, right after the frame
        is rendered (a navigator's ``frame_prework``: work on the image ahead of its delivery); a function it
        returns runs there after the frame is handed over."""
        s = truth_at(t - self.delay_s)
        cam_pos, C_cn = self.mount.camera_pose(s.position, euler_to_dcm(s.euler))
        self.frames += 1
        plan = self.renderer.plan(cam_pos, C_cn, world)
        if then is None:
            fut = executor.submit(self.renderer.execute, plan)
        else:
            fut = executor.submit(_render_then, self.renderer.execute, plan, then, executor)
        return PendingFrame(t=t, future=fut, index=self.frames * self.decimation)


def _render_then(execute, plan, then, executor) -> np.ndarray:
    """Render, run ``then`` on the image; what ``then`` returns (more work on the frame that its delivery does
    not wait for) is queued behind it on the same thread."""
    img = execute(plan)
    after = then(img)
    if after is not None:
        with contextlib.suppress(RuntimeError):  # the run is ending (the pool shut down): whoever needs it
            executor.submit(after)  # works it out (``vision/klt._TopUp``)
    return img


class PendingFrame:
    """A frame still being rendered; ``result()`` waits for it and returns the ``Frame``."""

    def __init__(self, t: float, future, index: int):
        self.t = t
        self.future = future
        self.index = index

    def done(self) -> bool:
        """The image is rendered (``result()`` will not wait)."""
        return self.future.done()

    def result(self) -> Frame:
        return Frame(t=self.t, image=self.future.result(), index=self.index)
