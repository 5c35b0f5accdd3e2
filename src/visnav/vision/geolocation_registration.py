"""Ground-target geo-location by registration to a geo-referenced image (seed 002 §7.3, Fig. 7.3).

Sensed frame: gray -> reduced to the processing size (360x288, §7.4.3) -> lens distortion removed
(§7.3.2) -> median filter -> Sobel edges -> scaled to the reference resolution with the barometric
height (eq. 5.14: s = h / (f I_res)) and rotated to north with the telemetry heading (one affine warp
for both) -> Algorithm 1 alignment (``vision/alignment.py``) -> correlation with the reference edge
image over a search window centred on the GPS position (``cv2.matchTemplate``, TM_CCOEFF_NORMED,
computed by DFT) -> the target's pixel is carried through the same frame->map transform and read off
the reference (§7.3.4: "the template coordinates must be rotated using the same angle").

Beyond the thesis: a match-quality score from the correlation surface (the peak, the second-highest
peak outside an exclusion disc, their ratio and the peak's sharpness), a sub-pixel peak (parabola),
and an optional rotation check: the sensed edge image is NCC-correlated at the Hough angle and at the
telemetry heading and the better one is kept (off by default, the thesis' Alg. 1 is the default).

The map-based method (§7.2, Fig. 7.2) for comparison: the ray from the telemetry pose through the
target pixel, intersected with flat ground (the camera assumed nadir, as the gimbal is meant to hold).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.vision.alignment import Alignment, binary_edges, hough_alignment

__all__ = ["GeoRegistration", "GeoMatch", "sobel_edges", "map_based_target", "nadir_dcm", "peak_quality"]


def sobel_edges(gray: np.ndarray) -> np.ndarray:
    """Sobel gradient magnitude (float32) of a grey image (Fig. 7.3 'Sobel edge detector').

    The magnitude is ``sqrt(gx*gx + gy*gy)`` in float32 by numpy (each operation correctly rounded),
    not ``cv2.magnitude``: OpenCV hands that to IPP where it has it, whose result (within 2 ulp)
    depends on the address of the output buffer (mod 64 bytes), i.e. on the heap of the process,
    which made the same seed give other registrations in another process."""
    g = np.asarray(gray, np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    np.multiply(gx, gx, out=gx)
    np.multiply(gy, gy, out=gy)
    np.add(gx, gy, out=gx)
    return np.sqrt(gx, out=gx)


def nadir_dcm(heading: float) -> np.ndarray:
    """C_cn (camera -> NED) of a nadir camera whose image top points along ``heading``."""
    c, s = math.cos(heading), math.sin(heading)
    # camera x (image right) = body right, y (image down) = body backward, z = down
    return np.array([[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 1.0]])


def map_based_target(camera: PinholeCamera, uv, position_ne, height: float, heading: float,
                     C_cn: np.ndarray | None = None) -> np.ndarray:
    """Fig. 7.2: ground point (n, e) of pixel ``uv`` seen from ``position_ne`` at ``height`` above flat
    ground, the camera attitude taken as nadir at ``heading`` (or ``C_cn`` when known)."""
    ray = camera.unproject(np.asarray(uv, float).reshape(1, 2))[0]
    d = (nadir_dcm(heading) if C_cn is None else C_cn) @ ray
    if not d[2] > 1e-6:
        return np.full(2, np.nan)
    return np.asarray(position_ne, float)[:2] + d[:2] * (height / d[2])


def peak_quality(c: np.ndarray, i: int, j: int, exclusion_px: int) -> tuple[float, float, float]:
    """(peak, second peak outside a disc of ``exclusion_px``, sharpness) of a correlation surface.

    Sharpness: the peak minus the mean of the surface on a ring of radius ``exclusion_px / 2``
    (how fast the match degrades off the true position)."""
    h, w = c.shape
    yy, xx = np.ogrid[:h, :w]
    r2 = (yy - i) ** 2 + (xx - j) ** 2
    outside = c[r2 > exclusion_px * exclusion_px]
    second = float(outside.max()) if outside.size else -1.0
    rr = max(1, exclusion_px // 2)
    ring = c[(r2 >= (rr - 0.5) ** 2) & (r2 < (rr + 0.5) ** 2)]
    sharp = float(c[i, j] - ring.mean()) if ring.size else 0.0
    return float(c[i, j]), second, sharp


def _subpixel(c: np.ndarray, i: int, j: int) -> tuple[float, float]:
    def par(a, b, d):
        den = a - 2 * b + d
        return 0.0 if abs(den) < 1e-12 else float(np.clip(0.5 * (a - d) / den, -0.5, 0.5))

    di = par(c[i - 1, j], c[i, j], c[i + 1, j]) if 0 < i < c.shape[0] - 1 else 0.0
    dj = par(c[i, j - 1], c[i, j], c[i, j + 1]) if 0 < j < c.shape[1] - 1 else 0.0
    return i + di, j + dj


@dataclass
class GeoMatch:
    ok: bool
    reason: str = ""
    target_ne: np.ndarray | None = None  # registered target position (n, e) [m]
    frame_centre_ne: np.ndarray | None = None  # ground point of the processed image centre
    heading_used: float = float("nan")  # rad, telemetry heading + Hough correction
    alignment: Alignment | None = None
    peak: float = float("nan")
    second_peak: float = float("nan")
    sharpness: float = float("nan")
    quality: float = float("nan")  # 1 - second / peak (0: ambiguous, 1: unique)
    A: np.ndarray | None = None  # 2x3 affine: processed undistorted pixel -> reference pixel
    height_used: float = float("nan")  # m, the height that set the scale (baro, or the scale search)


class GeoRegistration:
    """Fig. 7.3 with a fixed reference. ``camera``: intrinsics at the grabbed size (720x576)."""

    def __init__(self, reference, camera: PinholeCamera, process_size=(360, 288), median_px: int = 5,
                 search_radius_m: float = 20.0, hough: bool = True, exclusion_m: float = 4.0,
                 edge_keep: float = 0.08, check_rotation: bool = False, scale_search: float = 0.0,
                 scale_steps: int = 2, rot_step_deg: float = 0.0, rotation_search_deg: float = 0.0,
                 rotation_search_step_deg: float = 5.0) -> None:
        self.ref = reference
        self.cam_full = camera
        w, h = (int(v) for v in process_size)
        sx, sy = w / camera.width, h / camera.height
        # the reduced image: pixel centres scale as (u + 0.5) s - 0.5 (INTER_AREA)
        self.cam = PinholeCamera(w, h, camera.fx * sx, camera.fy * sy, (camera.cx + 0.5) * sx - 0.5,
                                 (camera.cy + 0.5) * sy - 0.5, camera.dist)
        self.size = (w, h)
        self.median_px, self.search_radius_m, self.hough = int(median_px), float(search_radius_m), bool(hough)
        self.exclusion_m, self.edge_keep, self.check_rotation = float(exclusion_m), float(edge_keep), check_rotation
        self.scale_search, self.scale_steps = float(scale_search), int(scale_steps)
        self.rot_step = math.radians(rot_step_deg)
        self.rot_search, self.rot_search_step = math.radians(rotation_search_deg), math.radians(rotation_search_step_deg)
        K = self.cam.K
        dist = np.array(self.cam.dist)
        self._maps = cv2.initUndistortRectifyMap(K, dist, None, K, (w, h), cv2.CV_32FC1) \
            if self.cam.has_distortion else None
        ones = np.full((h, w), 255, np.uint8)
        valid = ones if self._maps is None else cv2.remap(ones, *self._maps, cv2.INTER_NEAREST,
                                                          borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        self.valid = cv2.erode(valid, np.ones((5, 5), np.uint8))  # edges at the undistortion border dropped
        self.ref_edges = sobel_edges(reference.image)  # Fig. 7.3, reference branch (done once)

    # ------------------------------------------------------------------ sensed branch
    def preprocess(self, image: np.ndarray) -> np.ndarray:
        """gray -> 360x288 -> undistorted -> median -> Sobel magnitude (masked to the valid area)."""
        img = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        if img.shape[1] != self.size[0] or img.shape[0] != self.size[1]:
            img = cv2.resize(img, self.size, interpolation=cv2.INTER_AREA)
        if self._maps is not None:
            img = cv2.remap(img, *self._maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if self.median_px > 1:
            img = cv2.medianBlur(img, self.median_px)
        e = sobel_edges(img)
        e[self.valid == 0] = 0.0
        return e

    def to_processed_px(self, uv_full) -> np.ndarray:
        """Grabbed (distorted, 720x576) pixel -> processed undistorted pixel."""
        xy = self.cam_full.pixel_to_normalized(np.asarray(uv_full, float).reshape(-1, 2))
        return np.column_stack([self.cam.fx * xy[:, 0] + self.cam.cx, self.cam.fy * xy[:, 1] + self.cam.cy])

    def _affine(self, height: float, heading: float, centre_px: np.ndarray) -> np.ndarray:
        """2x3: processed pixel -> reference pixel, image centre at ``centre_px`` (col, row), north up."""
        res = self.ref.resolution_m
        s = height / (self.cam.fx * res)  # eq. 5.14 (square pixels assumed, fx ~ fy)
        c, sn = math.cos(heading), math.sin(heading)
        R = s * np.array([[c, -sn], [sn, c]])  # image right/down -> map col/row (image top = heading)
        t = centre_px - R @ np.array([self.cam.cx, self.cam.cy])
        return np.hstack([R, t[:, None]])

    def _warp(self, edges: np.ndarray, height: float, heading: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Edge image scaled + rotated north on a canvas holding all of it; its mask; the affine."""
        w, h = self.size
        s = height / (self.cam.fx * self.ref.resolution_m)
        side = int(math.ceil(s * math.hypot(w, h))) + 2
        ctr = np.array([(side - 1) / 2.0, (side - 1) / 2.0])
        A = self._affine(height, heading, ctr)
        flags = cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR
        out = cv2.warpAffine(edges, A, (side, side), flags=flags, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        m = cv2.warpAffine(self.valid, A, (side, side), flags=cv2.INTER_NEAREST, borderValue=0)
        return out, m, A

    def _inscribed(self, side: int, heading: float) -> int:
        """Largest centred axis-aligned square inside the rotated (scaled) frame rectangle."""
        w, h = self.size
        s = side / math.hypot(w, h)
        c, sn = abs(math.cos(heading)), abs(math.sin(heading))
        return max(8, int(math.floor(s * min(w, h) / (c + sn) * 0.97)) - 2)

    # ------------------------------------------------------------------ registration
    def register(self, image: np.ndarray, height: float, heading: float, gps_ne, target_uv=None) -> GeoMatch:
        """Register one frame; ``gps_ne``: where the search window is centred (the GPS position of
        the vehicle: the nadir point); ``target_uv``: the tracked pixel in the grabbed frame."""
        if not (np.isfinite(height) and height > 2.0 and np.isfinite(heading)):
            return GeoMatch(False, f"height {height} / heading {heading} not usable")
        edges = self.preprocess(image)
        head = float(heading)
        align = None
        ref = self.ref
        (gc, gr), = ref.ned_to_pixel(np.asarray(gps_ne, float)[:2].reshape(1, 2))
        if self.hough:
            warped, mask, _ = self._warp(edges, height, head)
            side = warped.shape[0]
            win = self._ref_window(gc, gr, side // 2)
            if win is not None and mask.any():
                # Alg. 1 step 2: the reference crop of the frame's size; both cut to the disc the
                # frame covers at any heading so that neither sees lines the other cannot
                rad = side * min(self.size) / (2 * math.hypot(*self.size))
                yy, xx = np.ogrid[:side, :side]
                disc = (yy - (side - 1) / 2) ** 2 + (xx - (side - 1) / 2) ** 2 <= rad * rad
                sb = binary_edges(warped, mask, self.edge_keep)
                rb = binary_edges(win[0][:side, :side], None, self.edge_keep)
                sb[~disc] = 0
                rb[~disc] = 0
                align = hough_alignment(sb, rb)
                if align.applied:
                    # content rotated by +a (counterclockwise on screen) = heading decreased by a
                    head = head - align.angle
        if self.hough and self.rot_search > 0 and not (align is not None and align.applied):
            best = self._rotation_search(edges, height, head, gc, gr)
        else:
            best = self._match(edges, height, head, gc, gr)
        if self.check_rotation and align is not None and align.applied:
            alt = self._match(edges, height, float(heading), gc, gr)
            if alt.ok and (not best.ok or alt.quality > best.quality + 0.05):
                best = alt
        if best.ok and (self.scale_search > 0 or self.rot_step > 0):
            best = self._refine(edges, height, best.heading_used, best)
        best.alignment = align
        if best.ok and target_uv is not None:
            p = self.to_processed_px(target_uv)[0]
            cr = best.A @ np.array([p[0], p[1], 1.0])
            best.target_ne = ref.pixel_to_ned(cr.reshape(1, 2))[0]
        return best

    def _rotation_search(self, edges: np.ndarray, height: float, heading: float, gc: float, gr: float) -> GeoMatch:
        """Beyond the thesis, where Algorithm 1 has no answer (no corresponding lines: water, forest,
        fields without straight edges; or two line families that agree equally): the correlation of
        the thesis' final step over headings within +-``rotation_search_deg`` of the telemetry
        heading (the thesis assumes at most 45 deg of heading error, Alg. 1 step 5) in steps of
        ``rotation_search_step_deg``, then half steps around the best; the highest peak wins."""
        n = int(round(self.rot_search / self.rot_search_step))
        offs = np.arange(-n, n + 1) * self.rot_search_step
        runs = [self._match(edges, height, heading + d, gc, gr) for d in offs]
        pk = np.array([r.peak if r.ok else -np.inf for r in runs])
        i = int(np.argmax(pk))
        if not np.isfinite(pk[i]):
            return runs[n]
        best = runs[i]
        for d in (-0.5 * self.rot_search_step, 0.5 * self.rot_search_step):
            r = self._match(edges, height, heading + offs[i] + d, gc, gr)
            if r.ok and r.peak > best.peak:
                best = r
        return best

    @staticmethod
    def _parabola_best(x: np.ndarray, runs: list) -> float:
        """The argument of the best peak over ``x``, refined by a parabola through its neighbours."""
        pk = np.array([r.peak if r.ok else -1.0 for r in runs])
        i = int(np.argmax(pk))
        if not 0 < i < len(x) - 1:
            return float(x[i])
        den = pk[i - 1] - 2 * pk[i] + pk[i + 1]
        d = 0.0 if den >= -1e-9 else float(np.clip(0.5 * (pk[i - 1] - pk[i + 1]) / den, -0.5, 0.5))
        return float(x[i] + d * (x[1] - x[0]))

    def _refine(self, edges: np.ndarray, height: float, heading: float, best: GeoMatch) -> GeoMatch:
        """Beyond the thesis: around the match found, the scale (the thesis names a search in scale as
        the way to get the ground altitude, §7.2; the baro height is biased) over heights
        h (1 + k e / steps), k = -steps..steps, and then the rotation (+-``rot_step``, what is left of
        the Hough angle), each refined by a parabola over the correlation peaks; searched within a few
        pixels of the match. The quality figures stay those of the full search."""
        cc, cr = best.A @ np.array([self.cam.cx, self.cam.cy, 1.0])
        h = height
        if self.scale_search > 0:
            f = 1.0 + np.arange(-self.scale_steps, self.scale_steps + 1) * self.scale_search / max(self.scale_steps, 1)
            h = height * self._parabola_best(f, [self._match(edges, height * fi, heading, cc, cr, 4) for fi in f])
        psi = heading
        if self.rot_step > 0:
            d = np.array([-self.rot_step, 0.0, self.rot_step])
            psi = heading + self._parabola_best(d, [self._match(edges, h, heading + di, cc, cr, 4) for di in d])
        out = self._match(edges, h, psi, cc, cr, 4)
        if not out.ok or out.peak < best.peak:
            return best
        out.second_peak, out.quality, out.sharpness = best.second_peak, best.quality, best.sharpness
        return out

    def _ref_window(self, cc: float, rc: float, half: int):
        H, W = self.ref.shape
        c0, r0 = int(round(cc)) - half, int(round(rc)) - half
        c1, r1 = c0 + 2 * half + 1, r0 + 2 * half + 1
        c0c, r0c, c1c, r1c = max(c0, 0), max(r0, 0), min(c1, W), min(r1, H)
        if c1c - c0c < 16 or r1c - r0c < 16:
            return None
        win = np.zeros((r1 - r0, c1 - c0), np.float32)
        win[r0c - r0 : r1c - r0, c0c - c0 : c1c - c0] = self.ref_edges[r0c:r1c, c0c:c1c]
        return win, c0, r0

    def _match(self, edges: np.ndarray, height: float, heading: float, gc: float, gr: float,
               radius_px: int | None = None) -> GeoMatch:
        warped, mask, A = self._warp(edges, height, heading)
        side = warped.shape[0]
        q = self._inscribed(side, heading)
        a = (side - q) // 2
        tpl = np.ascontiguousarray(warped[a : a + q, a : a + q])
        if float(tpl.std()) < 1e-3:
            return GeoMatch(False, "no edges in the frame", heading_used=heading)
        r = int(math.ceil(self.search_radius_m / self.ref.resolution_m)) if radius_px is None else int(radius_px)
        # the template centre is the frame centre = the canvas centre; it is searched within r of the GPS
        got = self._ref_window(gc, gr, q // 2 + r)
        if got is None:
            return GeoMatch(False, "search window outside the reference", heading_used=heading)
        win, c0, r0 = got
        if float(win.std()) < 1e-3:
            return GeoMatch(False, "reference window without edges", heading_used=heading)
        c = cv2.matchTemplate(win, tpl, cv2.TM_CCOEFF_NORMED)
        i, j = np.unravel_index(int(np.argmax(c)), c.shape)
        ex = max(2, int(round(self.exclusion_m / self.ref.resolution_m)))
        peak, second, sharp = peak_quality(c, int(i), int(j), ex)
        fi, fj = _subpixel(c, int(i), int(j))
        # canvas pixel (x, y) sits at reference pixel (c0 + fj + x - a, r0 + fi + y - a)
        A = A.copy()
        A[:, 2] += np.array([c0 + fj - a, r0 + fi - a])
        ctr = A @ np.array([self.cam.cx, self.cam.cy, 1.0])
        quality = 1.0 - max(second, 0.0) / peak if peak > 0 else 0.0
        return GeoMatch(True, "", None, self.ref.pixel_to_ned(ctr.reshape(1, 2))[0], heading, None, peak,
                        second, sharp, quality, A, height)
