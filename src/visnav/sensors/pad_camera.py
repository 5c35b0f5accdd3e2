"""The WITAS landing camera: on a pan-tilt unit on a spring-damped platform, seeing the pad on the field.

A frame is the world's ground (``CameraRenderer``, noise-free) with the pad board (its own
``GeoImage`` and pyramid, ``world/pad.py``) warped on top inside the board's projected outline,
then the lighting gain and the sensor noise. The camera pose is the *actual* one: platform
misalignment and deflection included (``sensors/pantilt.py``); the frame carries only the encoder
angles. A vision black-out (over-exposed frames: sun glare) starts when the true height first
falls below ``blackout_height_m`` and lasts ``blackout_s``.
"""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import PanTiltFrame
from visnav.sensors.base import TruthAt
from visnav.sensors.camera import CameraRenderer, PendingFrame
from visnav.sensors.pantilt import PanTiltUnit, SpringPlatform
from visnav.log_schema import register_stream

_NED = "NED world (origin at the scenario's home)"
register_stream("frame_truth", position=("m", _NED, "true body position at the frame instant"),
                velocity=("m/s", _NED, "true velocity"),
                euler=("rad", "3-2-1 Euler angles (roll, pitch, yaw) of body FRD relative to NED world", "true attitude"),
                camera=("m", _NED, "true camera position"),
                deflection=("rad", "platform (roll, pitch)", "spring-damped platform deflection"),
                pan=("rad", "pan-tilt unit", "true pan angle"), tilt=("rad", "pan-tilt unit", "true tilt angle"),
                blind=("bool", "", "the frame is blacked out (injected black-out)"))



class PadSceneRenderer:
    """Ground + pad board composite for a camera pose (no noise, no lighting)."""

    def __init__(self, camera: PinholeCamera, board, rng: np.random.Generator):
        self.camera = camera
        self.K = camera.K
        self.ground = CameraRenderer(camera, 0.0, rng)
        self.board_renderer = CameraRenderer(camera, 0.0, rng)
        self.board = SimpleNamespace(ground=board, detail=None, sky_level=200)
        h = (board.shape[0] - 1) / 2.0 * board.resolution_m
        cn = board.north0 - h
        ce = board.east0 + h
        self.corners = np.array([[cn + h, ce - h, 0.0], [cn + h, ce + h, 0.0], [cn - h, ce + h, 0.0],
                                 [cn - h, ce - h, 0.0]])

    def _outline(self, cam_pos, C_cn) -> np.ndarray | None:
        P = (self.corners - cam_pos) @ C_cn  # camera frame
        near = 1e-3
        poly = []
        for i in range(4):  # clip against z > near (Sutherland-Hodgman, one plane)
            a, b = P[i], P[(i + 1) % 4]
            if a[2] > near:
                poly.append(a)
            if (a[2] > near) != (b[2] > near):
                s = (near - a[2]) / (b[2] - a[2])
                poly.append(a + s * (b - a))
        if len(poly) < 3:
            return None
        P = np.array(poly)
        uv = P[:, :2] / P[:, 2:3] * [self.K[0, 0], self.K[1, 1]] + self.K[:2, 2]
        return np.clip(uv, -1e5, 1e5)

    def render(self, cam_pos, C_cn, world) -> np.ndarray:
        img = self.ground.render(cam_pos, C_cn, world)
        uv = self._outline(cam_pos, C_cn)
        if uv is not None:
            mask = np.zeros_like(img)
            cv2.fillConvexPoly(mask, np.round(uv * 16).astype(np.int32), 255, cv2.LINE_8, 4)
            if mask.any():
                pad = self.board_renderer.render(cam_pos, C_cn, self.board)
                cv2.copyTo(pad, mask, img)
        return img


class PadCamera:
    """Camera sensor (``rate_hz``, ``latency_s``, ``sample``/``sample_async`` as ``sensors/camera.Camera``)."""

    def __init__(self, camera: PinholeCamera, board, ptu: PanTiltUnit, platform: SpringPlatform,
                 rng: np.random.Generator, rate_hz: float = 20.0, noise_sigma: float = 2.0, latency_s: float = 0.05,
                 blackout_height_m: float | None = None, blackout_s: float = 0.0,
                 lighting_change_s: float | None = None, lighting_gain: float = 1.0, recorder=None):
        self.camera = camera
        self.rate_hz = float(rate_hz)
        self.latency_s = float(latency_s)
        self.ptu, self.platform = ptu, platform
        self.scene = PadSceneRenderer(camera, board, rng)
        self.rng = rng
        self.noise_sigma = float(noise_sigma)
        self._noise = None
        if noise_sigma > 0:
            bank = rng.normal(0.0, noise_sigma, (4, camera.height + 32, camera.width + 32))
            self._noise = np.clip(np.round(bank), -127, 127).astype(np.int16)
        self.blackout_height = blackout_height_m
        self.blackout_s = float(blackout_s)
        self.blackout_start: float | None = None
        self.lighting_change_s, self.lighting_gain = lighting_change_s, float(lighting_gain)
        self.frames = 0
        self.record = recorder or (lambda *a, **k: None)  # truth at the frame instants: to the log only

    def pose(self, t: float, truth_at: TruthAt):
        """Actual camera centre and C_cn at ``t`` (advances the servos and the platform)."""
        s = truth_at(t)
        self.ptu.advance(t)
        self.platform.advance(t, truth_at)
        C_bn = euler_to_dcm(s.euler)
        R_cb = self.platform.rotation() @ self.ptu.mount.R_cam_to_body
        cam = s.position + C_bn @ (self.ptu.mount.lever_arm + R_cb @ self.ptu.head_offset)
        return cam, C_bn @ R_cb, s

    def _blind(self, t: float, height: float) -> bool:
        if self.blackout_height is None or self.blackout_s <= 0:
            return False
        if self.blackout_start is None and height <= self.blackout_height:
            self.blackout_start = t
        return self.blackout_start is not None and t < self.blackout_start + self.blackout_s

    def _finish(self, img: np.ndarray, t: float) -> np.ndarray:
        if self.lighting_change_s is not None and t >= self.lighting_change_s and self.lighting_gain != 1.0:
            img = cv2.convertScaleAbs(img, alpha=self.lighting_gain)
        if self._noise is not None:
            h, w = img.shape
            k = int(self.rng.integers(0, self._noise.shape[0]))
            dy, dx = (int(x) for x in self.rng.integers(0, 32, 2))
            img = cv2.add(img, self._noise[k, dy:dy + h, dx:dx + w], dtype=cv2.CV_8U)
        return img

    def _prepare(self, t, truth_at):
        cam, C_cn, s = self.pose(t, truth_at)
        pan, tilt = self.ptu.encoders()
        self.frames += 1
        blind = self._blind(t, -float(s.position[2]))
        self.record("frame_truth", t, position=s.position, velocity=s.velocity, euler=s.euler, camera=cam,
                    deflection=self.platform.deflection, pan=self.ptu.angles[0], tilt=self.ptu.angles[1], blind=blind)
        return cam, C_cn, pan, tilt, blind

    def _render(self, cam, C_cn, world, blind, t):
        if blind:  # over-exposed: nothing but glare
            return np.full((self.camera.height, self.camera.width), 250, np.uint8)
        return self._finish(self.scene.render(cam, C_cn, world), t)

    def sample(self, t: float, truth_at: TruthAt, world) -> PanTiltFrame:
        cam, C_cn, pan, tilt, blind = self._prepare(t, truth_at)
        return PanTiltFrame(t=t, image=self._render(cam, C_cn, world, blind, t), index=self.frames, pan=pan, tilt=tilt)

    def sample_async(self, t: float, truth_at: TruthAt, world, executor) -> "PendingPanTiltFrame":
        cam, C_cn, pan, tilt, blind = self._prepare(t, truth_at)
        fut = executor.submit(self._render, cam, C_cn, world, blind, t)
        return PendingPanTiltFrame(t, fut, self.frames, pan, tilt)


class PendingPanTiltFrame(PendingFrame):
    def __init__(self, t, future, index, pan, tilt):
        super().__init__(t, future, index)
        self.pan, self.tilt = pan, tilt

    def result(self) -> PanTiltFrame:
        return PanTiltFrame(t=self.t, image=self.future.result(), index=self.index, pan=self.pan, tilt=self.tilt)
