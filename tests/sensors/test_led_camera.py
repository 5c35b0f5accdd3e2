"""The LED camera's uint8 render is pixel for pixel the float32 render it replaced (issue #19, speed round 4)."""

import cv2
import numpy as np
import pytest

from visnav.estimation.deck import camera_rotation
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.rotations import euler_to_dcm
from visnav.scenarios.config_deck import DIST_EQ_5_6_5_7
from visnav.sensors.led_camera import LedCamera

CAM = PinholeCamera(752, 480, 420.0, 420.0, 375.5, 239.5, DIST_EQ_5_6_5_7)
T = camera_rotation(np.radians(43.5), np.radians(-3.4))
RHO = np.array([0.101, 0.008, 0.11])


def reference_render(self: LedCamera, position, C_bn, lights_ned, deck_corners_ned, extra_ned=None):
    """The float32 render as it was before speed round 4 (the reference the uint8 render must equal)."""
    cam = self.camera
    img = np.empty((cam.height, cam.width), np.float32)
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


def _scene(rng):
    """A random vehicle pose and, in its camera's view (partly outside it), lights, extra points and corners."""
    pos = rng.normal(0.0, 3.0, 3)
    C = euler_to_dcm(rng.uniform(-np.pi, np.pi, 3))

    def ned(s):  # camera-frame points -> NED for this pose
        return (s @ T + RHO) @ C.T + pos

    depth = rng.uniform(0.5, 6.0)
    n = rng.integers(1, 9)
    centre = rng.uniform(-0.8, 0.8, 2)
    spread = rng.choice([0.005, 0.02, 0.2, 0.8])  # 0.005: spots that overlap
    xy = centre + rng.normal(0.0, spread, (n, 2))
    lights = np.column_stack([xy, np.ones(n)]) * (depth + rng.normal(0.0, 0.05, (n, 1)))
    ne = rng.integers(0, 3)
    extra = np.column_stack([rng.uniform(-1.0, 1.0, (ne, 2)), np.ones(ne)]) * depth
    k = rng.choice([3, 4, 5])
    c = rng.uniform(-1.2, 1.2, 2)
    ang = np.sort(rng.uniform(0, 2 * np.pi, k))
    rad = rng.choice([0.05, 0.3, 1.0])
    cxy = c + rad * np.column_stack([np.cos(ang), np.sin(ang)])
    corners = np.column_stack([cxy, np.ones(k)]) * (depth * rng.uniform(0.8, 1.2, (k, 1)))
    if rng.uniform() < 0.1:
        corners[0, 2] = -1.0  # a corner behind the camera
    return pos, C, ned(lights), ned(corners), ned(extra) if len(extra) else None


@pytest.mark.parametrize("kw", [dict(noise_gray=2.0), dict(noise_gray=0.0),
                                dict(noise_gray=30.0, centroid_noise_px=0.3, shared_jitter=True),
                                dict(noise_gray=5.0, sea_gray=90, deck_gray=40, centroid_noise_px=0.5)])
def test_uint8_render_equals_float_reference(kw):
    kw = dict(kw)
    shared = kw.pop("shared_jitter", False)

    def make():
        rng = np.random.default_rng(11)
        jit = None if shared else np.random.default_rng(12)
        return LedCamera(CAM, T, RHO, rng, jitter_rng=jit, **kw)

    new, ref = make(), make()
    scenes = np.random.default_rng(5)
    drawn = 0
    for _ in range(150):
        pos, C, lights, corners, extra = _scene(scenes)
        a = new.render(pos, C, lights, corners, extra)
        b = reference_render(ref, pos, C, lights, corners, extra)
        assert a.dtype == np.uint8 and a.shape == b.shape
        assert np.array_equal(a, b)
        drawn += int((b > 150).any())
    assert drawn > 50  # most scenes draw spots
    # the generators were drawn from alike (the frames that follow stay the same)
    assert new.rng.integers(1 << 30) == ref.rng.integers(1 << 30)
