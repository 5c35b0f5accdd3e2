"""Registration of a downward camera frame to a geo-referenced reference map (seed 002 §5.7, Fig. 5.13).

frame (grey) -> scaled to the reference resolution (eq. 5.14: s = d / (f I_res)) -> rotated north-up
with the filter's heading -> normalized cross-correlation (eq. 5.15, OpenCV's TM_CCOEFF_NORMED is the
same expression) over a window of the reference centred on the predicted position and sized from the
filter's uncertainty -> a map of NCC values over candidate *vehicle* positions: the camera view-angle
offset (where the optical axis meets the ground, from roll, pitch, heading and height) and the camera
lever arm are removed.

The template is the largest north-up square that fits inside the rotated footprint. A template whose
standard deviation is below ``min_template_std`` (water, fog: no texture) gives no registration.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from visnav.geometry.rotations import euler_to_dcm

__all__ = ["MapRegistration", "Registration", "ncc_to_likelihood"]


@dataclass
class Registration:
    ok: bool
    reason: str = ""
    ncc: np.ndarray | None = None  # (M, M) NCC over candidate vehicle positions
    north0: float = 0.0  # vehicle north of ncc[0, 0]
    east0: float = 0.0
    step_m: float = 1.0  # ncc rows go north -> south (north decreases), columns west -> east
    peak_ne: np.ndarray | None = None
    peak: float = float("nan")
    template_std: float = float("nan")
    template_px: int = 0

    def sample(self, north: np.ndarray, east: np.ndarray, fill: float) -> np.ndarray:
        """NCC at vehicle positions (bilinear; ``fill`` outside the searched window)."""
        mx = ((east - self.east0) / self.step_m).astype(np.float32)
        my = ((self.north0 - north) / self.step_m).astype(np.float32)
        return cv2.remap(self.ncc.astype(np.float32), mx, my, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=float(fill))


def ncc_to_likelihood(ncc: np.ndarray, gain: float, floor: float) -> np.ndarray:
    """p(y | x) from the correlation surface: floor + exp(gain (C - max C)). The floor keeps a wrong
    match from wiping out the right hypothesis (the thesis leaves the shape open, §5.8.4)."""
    c = np.nan_to_num(ncc, nan=-1.0)
    return floor + np.exp(gain * (c - c.max()))


class MapRegistration:
    def __init__(self, reference, K: np.ndarray, mount, min_template_std: float = 4.0):
        """``reference``: a north-up ``GeoImage`` (the navigator's map); ``K``: camera matrix;
        ``mount``: the camera mount (``camera_pose(position, C_bn)``)."""
        self.ref = reference
        self.K = np.asarray(K, float)
        self.mount = mount
        self.min_std = float(min_template_std)

    def sensed_template(self, image: np.ndarray, euler: np.ndarray, height: float) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 5.14 + alignment: the north-up template at the reference resolution and the NE
        offset of its centre from the camera's nadir (the view-angle offset, from the full attitude)."""
        res = self.ref.resolution_m
        fx, fy = self.K[0, 0], self.K[1, 1]
        s = np.array([height / (fx * res), height / (fy * res)])  # eq. 5.14: image px -> map px
        h, w = image.shape
        small = cv2.resize(image, (max(2, int(round(w * s[0]))), max(2, int(round(h * s[1])))),
                           interpolation=cv2.INTER_AREA)
        # level camera with the estimated heading: where its optical axis meets the ground
        _, C_level = self.mount.camera_pose(np.zeros(3), euler_to_dcm([0.0, 0.0, float(euler[2])]))
        rl = C_level[:, 2]
        f_level = rl[:2] * (height / max(rl[2], 0.2))
        psi = float(euler[2])
        side = int(np.floor(min(w * s[0], h * s[1]) / (abs(np.cos(psi)) + abs(np.sin(psi))))) - 1
        side = max(side, 3)
        # template pixel (col, row) -> ground point relative to the camera (dn, de, height) -> image pixel
        c = (side - 1) / 2.0
        M = np.array([[0.0, -res, f_level[0] + res * c], [res, 0.0, f_level[1] - res * c], [0.0, 0.0, height]])
        H_img = self.K @ C_level.T @ M  # template px -> full image px (level camera)
        sx, sy = small.shape[1] / w, small.shape[0] / h  # full -> reduced pixel centres (INTER_AREA)
        S = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])
        tpl = cv2.warpPerspective(small, S @ H_img, (side, side), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                  borderMode=cv2.BORDER_REPLICATE)
        # view-angle offset: the template centre shows where the *tilted* principal ray meets the
        # ground (small-tilt approximation), relative to the vehicle (lever arm included)
        cam, C_cn = self.mount.camera_pose(np.zeros(3), euler_to_dcm(euler))
        ray = C_cn[:, 2]
        off = cam[:2] + ray[:2] * (height / max(ray[2], 0.2))
        return tpl, off

    def register(self, image: np.ndarray, euler, height: float, predicted_ne, radius_m: float) -> Registration:
        """NCC of the frame against the reference around ``predicted_ne`` (vehicle position) within
        ``radius_m``; ``euler`` the filter's attitude, ``height`` the camera height above ground."""
        if not (np.isfinite(height) and height > 1.0):
            return Registration(False, f"height {height} m not usable")
        euler = np.asarray(euler, float)
        tpl, off = self.sensed_template(image, euler, height)
        std = float(tpl.std())
        if std < self.min_std:
            return Registration(False, f"textureless frame (template std {std:.1f} < {self.min_std})",
                                template_std=std, template_px=tpl.shape[0])
        res = self.ref.resolution_m
        side = tpl.shape[0]
        r = int(np.ceil(radius_m / res))
        centre = np.asarray(predicted_ne, float)[:2] + off  # predicted template centre on the ground
        (cc, rc), = self.ref.ned_to_pixel([centre])
        c0 = int(np.round(cc)) - r - side // 2
        r0 = int(np.round(rc)) - r - side // 2
        n = 2 * r + side
        H, W = self.ref.shape
        if c0 < 0 or r0 < 0 or c0 + n > W or r0 + n > H:
            # clip the search window to the map
            c0c, r0c = max(c0, 0), max(r0, 0)
            c1c, r1c = min(c0 + n, W), min(r0 + n, H)
            if c1c - c0c < side + 2 or r1c - r0c < side + 2:
                return Registration(False, "search window outside the reference map", template_std=std,
                                    template_px=side)
            c0, r0, win = c0c, r0c, self.ref.image[r0c:r1c, c0c:c1c]
        else:
            win = self.ref.image[r0 : r0 + n, c0 : c0 + n]
        if float(win.std()) < 1e-3:
            return Registration(False, "reference window has no texture", template_std=std, template_px=side)
        ncc = cv2.matchTemplate(win, tpl, cv2.TM_CCOEFF_NORMED)
        # ncc[i, j]: template top-left at window (col j, row i) -> template centre at map pixel
        # (c0 + j + (side-1)/2, r0 + i + (side-1)/2); vehicle = that ground point - offset
        (n0, e0), = self.ref.pixel_to_ned([[c0 + (side - 1) / 2.0, r0 + (side - 1) / 2.0]])
        i, j = np.unravel_index(int(np.argmax(ncc)), ncc.shape)
        reg = Registration(True, "", ncc, n0 - off[0], e0 - off[1], res, None, float(ncc[i, j]), std, side)
        reg.peak_ne = np.array([reg.north0 - i * res, reg.east0 + j * res])
        return reg
