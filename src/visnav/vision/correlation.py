"""Moravec pseudo-normalized correlation (PNCC) and the PALACE point tracker (seed 000 §2.2.2).

Coherence of a template b (T_W x T_H = N pixels) placed over a window a of the search image,
eq. 2.3 with its sums normalised by N (Algorithm 2, whose step 3 is garbled in the seed text):

    coherence = (mean(a b) - μ_a μ_b) / ((σ_a^2 + σ_b^2) / 2),   σ^2 = mean(x^2) - μ^2.

The numerator is the covariance, the denominator the arithmetic mean of the two variances
(Moravec's replacement for the geometric mean of NCC, eq. 2.2). So coherence is 1 for identical
patches, always in [-1, 1] (|cov| <= σ_a σ_b <= (σ_a^2 + σ_b^2)/2), and, unlike NCC, it drops
with a contrast change: b = k a gives 2k / (1 + k^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["pncc", "self_coherence", "distinct_points", "TrackResult", "PnccTracker"]

_BACK_RADIUS = 2  # px, search radius of the backward match (subpixel mode)
_FLAT_RTOL = 1e-8  # (σ_a^2 + σ_b^2)/2 below this * (data range)^2 counts as "both flat"


def _gray(name: str, a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim != 2 or a.size == 0:
        raise ValueError(f"{name} must be a non-empty 2-D grayscale array, got shape {a.shape}")
    return a


def _window_sums(ii: np.ndarray, th: int, tw: int) -> np.ndarray:
    """Sums over every th x tw window from an integral image (valid placements)."""
    w = ii[th:, tw:] - ii[:-th, tw:]
    w -= ii[th:, :-tw]
    w += ii[:-th, :-tw]
    return w


def pncc(search: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Coherence (eq. 2.3, Alg. 2 steps 2-3) of ``template`` at every valid placement in ``search``.

    Output shape ``(H_s - T_H + 1, W_s - T_W + 1)`` (like ``cv2.matchTemplate``); entry (v, u)
    scores the template's top-left corner at column u, row v. Where both patches are flat the
    coherence is 0.
    """
    s = _gray("search", search)
    t = _gray("template", template)
    th, tw = t.shape
    if th > s.shape[0] or tw > s.shape[1]:
        raise ValueError(f"template {t.shape} must fit inside search {s.shape}")
    n = float(th * tw)
    # Centre both (removes the large common mean before float32 products; coherence is unchanged).
    # cv2 reductions: on these small arrays numpy's per-call overhead dominates.
    a = s.astype(np.float32)
    a -= np.float32(cv2.mean(a)[0])
    b = t.astype(np.float64)
    b -= cv2.mean(b)[0]
    sum_b2 = float(np.vdot(b, b))  # N σ_b²
    # Σ a b' with b' = b - μ_b equals Σ a b - N μ_a μ_b: N times the numerator of eq. 2.3.
    num = cv2.matchTemplate(a, b.astype(np.float32), cv2.TM_CCORR)
    s1, s2 = cv2.integral2(a, sdepth=cv2.CV_64F, sqdepth=cv2.CV_64F)
    sum_a, sum_a2 = (_window_sums(ii, th, tw) for ii in (s1, s2))
    # N (σ_a² + σ_b²) = Σa² - (Σa)²/N + N σ_b²; coherence = 2 Σab' / that.
    sum_a *= sum_a
    sum_a *= 1.0 / n
    den = sum_a2
    den -= sum_a
    np.maximum(den, 0.0, out=den)
    den += sum_b2
    lo_s, hi_s = cv2.minMaxLoc(a)[:2]
    lo_t, hi_t = cv2.minMaxLoc(b)[:2]
    scale = max(hi_s - lo_s, hi_t - lo_t)  # data range, for the "both flat" test
    out = np.zeros(den.shape, np.float32)
    np.divide(num, den, out=out, where=den > (2.0 * _FLAT_RTOL * n) * scale * scale)
    out *= 2.0
    return np.clip(out, -1.0, 1.0, out=out)


def self_coherence(image: np.ndarray, x: float, y: float, template_size: int = 21, search_radius: int = 30,
                   exclude_px: int = 3) -> float:
    """Distinctness of the point (x, y): the highest coherence (eq. 2.3) of its own template at a
    *local maximum* of the coherence surface over the tracker's search window (+-``search_radius``,
    clipped to the image) more than ``exclude_px`` from the point itself. Near 1: a repeated
    pattern (tiles, a grid, a row of equal edges) within reach of one step, where the tracker can
    jump to the copy; a plain blurred corner has a broad single peak and scores low (its
    shoulders are no local maxima). -1 when no other local maximum exists."""
    img = _gray("image", image)
    h = int(template_size) // 2
    xi, yi = int(round(x)), int(round(y))
    H, W = img.shape
    if not (h <= xi <= W - 1 - h and h <= yi <= H - 1 - h):
        raise ValueError(f"point ({x}, {y}) leaves no room for a {template_size} px template in {W}x{H}")
    x0, x1 = max(xi - search_radius, h), min(xi + search_radius, W - 1 - h)
    y0, y1 = max(yi - search_radius, h), min(yi + search_radius, H - 1 - h)
    c = pncc(img[y0 - h : y1 + h + 1, x0 - h : x1 + h + 1], img[yi - h : yi + h + 1, xi - h : xi + h + 1])
    peak = (c >= cv2.dilate(c, np.ones((3, 3), np.uint8))) & (c > -1.0)
    vv, uu = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
    peak &= np.maximum(np.abs(uu - xi), np.abs(vv - yi)) > int(exclude_px)
    return float(c[peak].max()) if peak.any() else -1.0


def distinct_points(image: np.ndarray, points, template_size: int = 21, search_radius: int = 30,
                    max_self_coherence: float = 0.9, exclude_px: int = 3) -> list:
    """The ``points`` (anything with ``.x``, ``.y``: Förstner picks, strongest first) whose
    ``self_coherence`` is at most ``max_self_coherence``, in their order: the distinctness guard of
    the PALACE tracker (``navigation.tracker.max_self_coherence``). On the real EuRoC frames the
    PNCC tracks that jumped 13-30 px to a copy of their own texture all started at points scoring
    0.93-0.99 (docs/real-data.md); 1.0 turns the guard off."""
    if max_self_coherence >= 1.0:
        return list(points)
    return [p for p in points
            if self_coherence(image, p.x, p.y, template_size, search_radius, exclude_px) <= max_self_coherence]


@dataclass
class TrackResult:
    """One tracking step: position (pixels, x right, y down), its coherence, and whether it held.

    ``reason`` is "" on success, else "edge" (the point is leaving or has left the image) or
    "low coherence" (best match below ``min_coherence``); then x, y are the old position.
    """

    x: float
    y: float
    coherence: float
    ok: bool
    reason: str = ""


def _parabola(c_m: float, c_0: float, c_p: float) -> float:
    """Vertex offset of the parabola through (-1, c_m), (0, c_0), (1, c_p), clamped to +-0.5."""
    curv = c_m - 2.0 * c_0 + c_p
    if not curv < 0.0:
        return 0.0
    return float(np.clip(0.5 * (c_m - c_p) / curv, -0.5, 0.5))


_U = np.array([[-1.0, 0.0, 1.0]] * 3)  # column offset of each 3x3 neighbour
_V = _U.T  # row offset


def _quadratic_peak(c3: np.ndarray) -> tuple[float, float] | None:
    """Vertex of the least-squares quadratic a + b u + c v + d u^2 + e v^2 + f u v on a 3x3 patch.

    Unlike two separable parabolas it follows a peak elongated along a diagonal. Returns None
    unless the fit has a maximum; offsets clamped to +-0.5 px.
    """
    b = float((_U * c3).sum()) / 6.0
    c = float((_V * c3).sum()) / 6.0
    f = float((_U * _V * c3).sum()) / 4.0
    d = float(((_U * _U - 2.0 / 3.0) * c3).sum()) / 2.0
    e = float(((_V * _V - 2.0 / 3.0) * c3).sum()) / 2.0
    det = 4.0 * d * e - f * f  # Hessian [[2d, f], [f, 2e]] must be negative definite
    if not (d < 0.0 and det > 0.0):
        return None
    du = (-2.0 * e * b + f * c) / det
    dv = (f * b - 2.0 * d * c) / det
    return float(np.clip(du, -0.5, 0.5)), float(np.clip(dv, -0.5, 0.5))


def _subpixel_peak(c: np.ndarray, u: int, v: int) -> tuple[float, float]:
    """Sub-pixel offset of the coherence peak at (u, v): 2-D quadratic, else separable parabolas."""
    rows, cols = c.shape
    if 0 < u < cols - 1 and 0 < v < rows - 1:
        q = _quadratic_peak(c[v - 1 : v + 2, u - 1 : u + 2].astype(np.float64))
        if q is not None:
            return q
    fx = _parabola(float(c[v, u - 1]), float(c[v, u]), float(c[v, u + 1])) if 0 < u < cols - 1 else 0.0
    fy = _parabola(float(c[v - 1, u]), float(c[v, u]), float(c[v + 1, u])) if 0 < v < rows - 1 else 0.0
    return fx, fy


class PnccTracker:
    """Frame-to-frame PNCC point tracker (seed 000 §2.2.2, Algorithm 2).

    ``mode="thesis"``: every frame the template (``template_size`` square, 21 in PALACE) is
    searched for at the candidate centres within +-``search_radius`` px of the last point (the
    61x61 "search window"), the argmax of coherence is the new point (Alg. 2 step 4) and the
    template is replaced by the pixels there. With integer positions this drifts by
    discretisation (§4.2). ``subpixel=True`` refines the peak with a quadratic fitted to its
    3x3 neighbourhood (with the cross term, so that a diagonal ridge is followed; separable
    parabolas as fallback; clamped to +-0.5 px) and re-extracts the template there
    (``cv2.getRectSubPix``). On real texture the correlation peak is asymmetric, so any 3-point
    fit is biased by ~0.01-0.03 px even at zero motion, and template replacement accumulates
    that bias frame after frame; the sub-pixel step is therefore the mean of the forward match
    and of the backward match (new template searched in the previous frame, +-2 px), which
    cancels it. ``mode="anchored"`` also keeps the first template as an anchor
    and, when it still matches with coherence >= ``min_coherence`` within ``anchor_radius`` px
    of the frame-to-frame match, takes the anchor's match: the random walk stops.

    The search window is clipped to where the template fits in the image; a failed step
    (``ok=False``) keeps the old position and template.
    """

    def __init__(
        self,
        template_size: int = 21,
        search_radius: int = 30,
        subpixel: bool = False,
        min_coherence: float = 0.5,
        mode: str = "thesis",
        anchor_radius: int = 2,
    ) -> None:
        if int(template_size) != template_size or template_size < 3 or template_size % 2 == 0:
            raise ValueError(f"template_size must be an odd integer >= 3, got {template_size!r}")
        if int(search_radius) != search_radius or search_radius < 1:
            raise ValueError(f"search_radius must be an integer >= 1, got {search_radius!r}")
        if not -1.0 <= min_coherence <= 1.0:
            raise ValueError(f"min_coherence must be in [-1, 1], got {min_coherence!r}")
        if mode not in ("thesis", "anchored"):
            raise ValueError(f"mode must be 'thesis' or 'anchored', got {mode!r}")
        if int(anchor_radius) != anchor_radius or anchor_radius < 1:
            raise ValueError(f"anchor_radius must be an integer >= 1, got {anchor_radius!r}")
        self.template_size = int(template_size)
        self.search_radius = int(search_radius)
        self.subpixel = bool(subpixel)
        self.min_coherence = float(min_coherence)
        self.mode = mode
        self.anchor_radius = int(anchor_radius)
        self._half = self.template_size // 2
        self._template: np.ndarray | None = None
        self._prev: tuple[np.ndarray, tuple[int, int]] | None = None  # (crop, origin), subpixel only
        self._anchor: np.ndarray | None = None
        self.x = float("nan")
        self.y = float("nan")
        self.coherence = float("nan")
        self.frames = 0
        self.used_anchor = False

    @property
    def template(self) -> np.ndarray | None:
        """The current template (float32, read-only view), None before :meth:`init`."""
        if self._template is None:
            return None
        v = self._template.view()
        v.flags.writeable = False
        return v

    @property
    def initialized(self) -> bool:
        return self._template is not None

    def _extract(self, img: np.ndarray, x: float, y: float) -> np.ndarray:
        """Template centred on (x, y): a plain copy at integer positions, else bilinear."""
        h = self._half
        xi, yi = int(round(x)), int(round(y))
        if xi == x and yi == y:
            return img[yi - h : yi + h + 1, xi - h : xi + h + 1].astype(np.float32)
        # Bilinear samples need one more pixel around the template: convert only that crop.
        x0, y0 = max(xi - h - 1, 0), max(yi - h - 1, 0)
        crop = img[y0 : yi + h + 2, x0 : xi + h + 2].astype(np.float32)
        size = (self.template_size, self.template_size)
        return cv2.getRectSubPix(crop, size, (float(x) - x0, float(y) - y0))

    def _fits(self, shape: tuple[int, int], x: float, y: float) -> bool:
        h = self._half
        return h <= x <= shape[1] - 1 - h and h <= y <= shape[0] - 1 - h

    def init(self, image: np.ndarray, x: float, y: float) -> None:
        """Start a track at pixel (x, y); rounded to integers unless ``subpixel``."""
        img = _gray("image", image)
        if not self.subpixel:
            x, y = float(round(x)), float(round(y))
        if not (np.isfinite(x) and np.isfinite(y) and self._fits(img.shape, x, y)):
            raise ValueError(
                f"point (x={x}, y={y}) must leave room for the {self.template_size}x{self.template_size}"
                f" template inside the {img.shape[1]}x{img.shape[0]} image"
            )
        self._template = self._extract(img, x, y)
        self._anchor = self._template.copy() if self.mode == "anchored" else None
        self.x, self.y, self.coherence = float(x), float(y), 1.0
        self._keep_previous(img)
        self.frames = 0
        self.used_anchor = False

    def _keep_previous(self, img: np.ndarray) -> None:
        """Subpixel mode: copy the part of this frame the backward match will search."""
        if not self.subpixel:
            return
        m = self._half + _BACK_RADIUS + 1
        cx, cy = int(round(self.x)), int(round(self.y))
        x0, y0 = max(cx - m, 0), max(cy - m, 0)
        self._prev = (img[y0 : cy + m + 1, x0 : cx + m + 1].copy(), (x0, y0))

    def _match(self, img: np.ndarray, template: np.ndarray, cx: int, cy: int, radius: int, origin=(0, 0)):
        """Best centre for ``template`` within +-radius of (cx, cy), clipped to the image.

        ``img`` may be a crop whose pixel (0, 0) is ``origin`` (x, y) of the full image.
        Returns (x, y, coherence, clipped_hit) or None when no centre fits; ``clipped_hit`` says
        the best match lies on a side of the window that the image edge cut off.
        """
        h = self._half
        ox, oy = origin
        hh, ww = img.shape
        cx, cy = cx - ox, cy - oy
        x0, x1 = max(cx - radius, h), min(cx + radius, ww - 1 - h)
        y0, y1 = max(cy - radius, h), min(cy + radius, hh - 1 - h)
        if x1 < x0 or y1 < y0:
            return None
        crop = img[y0 - h : y1 + h + 1, x0 - h : x1 + h + 1]  # converted once, inside pncc
        c = pncc(crop, template)
        j = int(np.argmax(c))
        v, u = divmod(j, c.shape[1])
        best = float(c[v, u])
        clipped_hit = (
            (u == 0 and x0 > cx - radius)
            or (u == c.shape[1] - 1 and x1 < cx + radius)
            or (v == 0 and y0 > cy - radius)
            or (v == c.shape[0] - 1 and y1 < cy + radius)
        )
        fx, fy = _subpixel_peak(c, u, v) if self.subpixel else (0.0, 0.0)
        return ox + x0 + u + fx, oy + y0 + v + fy, best, clipped_hit

    def _fail(self, coherence: float, reason: str) -> TrackResult:
        return TrackResult(self.x, self.y, coherence, False, reason)

    def track(self, image: np.ndarray) -> TrackResult:
        """Find the template in ``image`` near the last point (Alg. 2); update the track."""
        if self._template is None:
            raise RuntimeError("PnccTracker.track() called before init()")
        img = _gray("image", image)
        self.frames += 1
        self.used_anchor = False
        cx, cy = int(round(self.x)), int(round(self.y))
        m = self._match(img, self._template, cx, cy, self.search_radius)
        if m is None:
            return self._fail(float("nan"), "edge")
        x, y, coh, clipped_hit = m
        if clipped_hit or coh < self.min_coherence:
            return self._fail(coh, "edge" if (clipped_hit or self._clipped(img.shape, cx, cy)) else "low coherence")
        if self._prev is not None:  # forward-backward mean (see class docstring)
            crop, origin = self._prev
            b = self._match(crop, self._extract(img, x, y), cx, cy, _BACK_RADIUS, origin)
            if b is not None and b[2] >= self.min_coherence:
                x, y = x + 0.5 * (self.x - b[0]), y + 0.5 * (self.y - b[1])
        if self._anchor is not None:
            a = self._match(img, self._anchor, int(round(x)), int(round(y)), self.anchor_radius)
            if a is not None and not a[3] and a[2] >= self.min_coherence:
                x, y, coh, _ = a
                self.used_anchor = True
        if not self._fits(img.shape, x, y):  # a sub-pixel correction pushed it past the edge
            return self._fail(coh, "edge")
        self._template = self._extract(img, x, y)
        self.x, self.y, self.coherence = float(x), float(y), float(coh)
        self._keep_previous(img)
        return TrackResult(self.x, self.y, self.coherence, True, "")

    def _clipped(self, shape: tuple[int, int], cx: int, cy: int) -> bool:
        """Whether the image edge cut the search window around (cx, cy)."""
        r, h = self.search_radius, self._half
        return cx - r < h or cy - r < h or cx + r > shape[1] - 1 - h or cy + r > shape[0] - 1 - h
