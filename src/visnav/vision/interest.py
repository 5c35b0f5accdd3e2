"""Förstner interest operator (seed 000 §2.2.1, Algorithm 1), vectorized with OpenCV.

The operator picks the point to track: for every pixel it sums the second moments of the
3-pixel gradients over a feature window (the local structure matrix C, eq. 2.1) and takes
the pixel with the largest eigenvalue λ1 of C.

Two deliberate extensions, both off in "thesis mode" (``min_isotropy=0, refine=False``):

- the aperture-problem guard that §2.2.1 and §4.1 call for: a pixel whose isotropy
  λ2/λ1 is below ``min_isotropy`` lies on a straight edge (motion along it cannot be
  measured) and is not eligible;
- ``refine=True``: Förstner & Gülch's (1987) least-squares corner position inside the
  feature window (the point nearest to all gradient lines), for sub-pixel points.

Feature size: Alg. 1 sums u, v from -D_F/2 to D_F/2; we read this as the integer range
``half = feature_size // 2``, i.e. a ``(2*half + 1)^2`` window (7x7 for the default
``feature_size=7``). (The §2.2.1 prose, "D_F = 1 for a 3-pixel gradient", counts pixels
from the centre instead; we follow the algorithm's summation limits.)
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = [
    "InterestPoint",
    "DEFAULT_BORDER",
    "forstner_response",
    "forstner",
    "forstner_top_k",
]

#: Keeps a 21x21 template (half 10) plus a +-30 px search window inside the image.
DEFAULT_BORDER = 10 + 30

#: C counts as singular (Alg. 1 step 3: "assign it a value 0") when λ2 <= this * λ1.
_SINGULAR_RTOL = 1e-6

#: Pixels never to pick: a boolean mask shaped like the image (True = excluded) or (x, y, radius) discs.
Exclusion = np.ndarray | Iterable[tuple[float, float, float]] | None

_GRAD_KERNEL = np.array([[1.0, 0.0, -1.0]], dtype=np.float32)  # I(x-1) - I(x+1) (Alg. 1)


@dataclass(frozen=True)
class InterestPoint:
    """A selected feature: pixel position (x right, y down) and the eigenvalues of C there."""

    x: float
    y: float
    lambda1: float
    lambda2: float

    @property
    def isotropy(self) -> float:
        """λ2/λ1 in [0, 1]: 0 on a straight edge, 1 on an ideal corner or blob."""
        return self.lambda2 / self.lambda1 if self.lambda1 > 0 else 0.0


def _as_gray(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim != 2:
        raise ValueError(f"image must be a 2-D grayscale array, got shape {img.shape}")
    if img.size == 0:
        raise ValueError(f"image must not be empty, got shape {img.shape}")
    return img


def _half(feature_size: int) -> int:
    if int(feature_size) != feature_size or feature_size < 1:
        raise ValueError(f"feature_size must be an integer >= 1, got {feature_size!r}")
    return int(feature_size) // 2


def _gradients(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """I_x = I(x-1, y) - I(x+1, y), I_y = I(x, y-1) - I(x, y+1) (Alg. 1 step 1)."""
    f = img.astype(np.float32, copy=False)
    ix = cv2.filter2D(f, cv2.CV_32F, _GRAD_KERNEL, borderType=cv2.BORDER_REPLICATE)
    iy = cv2.filter2D(f, cv2.CV_32F, _GRAD_KERNEL.T, borderType=cv2.BORDER_REPLICATE)
    return ix, iy


def _eigen(img: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """λ1 >= λ2 of C(x, y) for every pixel (Alg. 1 steps 1-3)."""
    ix, iy = _gradients(img)
    k = (2 * half + 1, 2 * half + 1)

    def box(a: np.ndarray) -> np.ndarray:  # window sum; gradients outside the image count 0
        return cv2.boxFilter(a, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT)

    mxx, myy, mxy = box(ix * ix), box(iy * iy), box(ix * iy)
    # Alg. 1: λ1,2 = (Mxx + Myy +- sqrt(4 Mxy^2 + (Mxx - Myy)^2)) / 2. Same values, written
    # without cancellation: λ1 from the + branch, λ2 = det(C) / λ1 (exactly 0 for a singular C
    # with integer moments, e.g. an axis-aligned or diagonal straight edge in a uint8 image).
    diff = mxx - myy
    lam1 = mxx + myy
    lam1 += np.sqrt(diff * diff + 4.0 * mxy * mxy)
    lam1 *= 0.5
    det = mxx * myy - mxy * mxy
    lam2 = np.zeros_like(lam1)
    np.divide(det, lam1, out=lam2, where=lam1 > 0)
    np.maximum(lam2, 0.0, out=lam2)
    return lam1, lam2


def forstner_response(image: np.ndarray, feature_size: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (λ1, λ2), λ1 >= λ2 >= 0, of the structure matrix C at every pixel.

    Seed 000 Alg. 1 / eq. 2.1, window ``(2*(feature_size//2) + 1)^2``. Returns two float32
    maps shaped like ``image``; within ``feature_size//2 + 1`` px of the image edge they use
    replicated pixels for the gradient and zero gradient outside the image.
    """
    img = _as_gray(image)
    return _eigen(img, _half(feature_size))


def _check_border(border: int) -> int:
    if int(border) != border or border < 0:
        raise ValueError(f"border must be an integer >= 0, got {border!r}")
    return int(border)


def _bounds(shape: tuple[int, int], region: Sequence[int] | None, border: int) -> tuple[int, int, int, int] | None:
    """Half-open search rectangle (x0, y0, x1, y1) inside the image and the border, or None."""
    h, w = shape
    if region is None:
        x0, y0, x1, y1 = 0, 0, w, h
    else:
        if len(region) != 4:
            raise ValueError(f"region must be (x0, y0, x1, y1), got {region!r}")
        x0, y0, x1, y1 = (int(round(v)) for v in region)
        if x1 <= x0 or y1 <= y0:
            raise ValueError(f"region must have x1 > x0 and y1 > y0, got {tuple(region)!r}")
        if x1 <= 0 or y1 <= 0 or x0 >= w or y0 >= h:
            raise ValueError(f"region {tuple(region)!r} lies outside the {w}x{h} image")
    x0, y0 = max(x0, border), max(y0, border)
    x1, y1 = min(x1, w - border), min(y1, h - border)
    if x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1, y1


def _exclusion_mask(exclude: Exclusion, shape: tuple[int, int]) -> np.ndarray | None:
    """``exclude``: a boolean mask (True = not eligible) or an iterable of (x, y, radius) discs."""
    if exclude is None:
        return None
    if isinstance(exclude, np.ndarray) and exclude.dtype == bool:
        if exclude.shape != shape:
            raise ValueError(f"exclude mask must have the image shape {shape}, got {exclude.shape}")
        return exclude
    discs = np.asarray(list(exclude) if isinstance(exclude, Iterable) else exclude, dtype=float)
    if discs.size == 0:
        return None
    if discs.ndim != 2 or discs.shape[1] != 3:
        raise ValueError(f"exclude must be a boolean mask or (x, y, radius) triples, got {exclude!r}")
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    mask = np.zeros(shape, dtype=bool)
    for cx, cy, r in discs:  # loop over discs (few), not pixels
        mask |= (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r
    return mask


def _scores(image, feature_size, region, min_isotropy, border, exclude):
    """λ1 where eligible (else 0) on the search rectangle; also λ2 and the crop geometry."""
    img = _as_gray(image)
    half = _half(feature_size)
    border = _check_border(border)
    if not 0.0 <= min_isotropy <= 1.0:
        raise ValueError(f"min_isotropy must be in [0, 1], got {min_isotropy!r}")
    mask = _exclusion_mask(exclude, img.shape)
    b = _bounds(img.shape, region, border)
    if b is None:
        return None
    x0, y0, x1, y1 = b
    # Crop with a (half + 1) px apron: inside the rectangle the response equals the full-image one.
    pad = half + 1
    cx0, cy0 = max(x0 - pad, 0), max(y0 - pad, 0)
    cx1, cy1 = min(x1 + pad, img.shape[1]), min(y1 + pad, img.shape[0])
    lam1, lam2 = _eigen(img[cy0:cy1, cx0:cx1], half)
    sl = np.s_[y0 - cy0 : y1 - cy0, x0 - cx0 : x1 - cx0]
    lam1, lam2 = lam1[sl], lam2[sl]
    ok = (lam1 > 0) & (lam2 > _SINGULAR_RTOL * lam1) & (lam2 >= min_isotropy * lam1)
    if mask is not None:
        ok &= ~mask[y0:y1, x0:x1]
    score = np.where(ok, lam1, np.float32(0.0))
    return img, half, (x0, y0), score, lam1, lam2


def _corner_offset(img: np.ndarray, half: int, x: int, y: int) -> np.ndarray | None:
    """Förstner-Gülch corner in the window at (x, y): argmin_d Σ_w (g_i · (d - u_i))^2."""
    h, w = img.shape
    r = half + 1
    if x - r < 0 or y - r < 0 or x + r >= w or y + r >= h:
        return None
    patch = img[y - r : y + r + 1, x - r : x + r + 1].astype(np.float64)
    gx = (patch[1:-1, :-2] - patch[1:-1, 2:]).ravel()  # Alg. 1 gradients on the window
    gy = (patch[:-2, 1:-1] - patch[2:, 1:-1]).ravel()
    v, u = np.mgrid[-half : half + 1, -half : half + 1]
    u, v = u.ravel().astype(float), v.ravel().astype(float)
    c = np.array([[gx @ gx, gx @ gy], [gx @ gy, gy @ gy]])
    rhs = np.array([gx * gx @ u + gx * gy @ v, gx * gy @ u + gy * gy @ v])
    try:
        d = np.linalg.solve(c, rhs)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(d)) or np.any(np.abs(d) > half + 0.5):
        return None  # the corner estimate left the window
    return d


def _refine(img: np.ndarray, half: int, x: int, y: int, iterations: int = 3) -> tuple[float, float]:
    """Sub-pixel corner near pixel (x, y); the window is re-centred on the estimate (<= 3 times)."""
    cx, cy = x, y
    px, py = float(x), float(y)
    for _ in range(iterations):
        d = _corner_offset(img, half, cx, cy)
        if d is None:
            break
        px, py = cx + float(d[0]), cy + float(d[1])
        nx, ny = int(round(px)), int(round(py))
        if (nx, ny) == (cx, cy):
            break
        cx, cy = nx, ny
    return px, py


def _point(img, half, x, y, lam1, lam2, refine) -> InterestPoint:
    px, py = _refine(img, half, x, y) if refine else (float(x), float(y))
    return InterestPoint(px, py, float(lam1), float(lam2))


def forstner(
    image: np.ndarray,
    feature_size: int = 7,
    region: Sequence[int] | None = None,
    min_isotropy: float = 0.2,
    border: int = DEFAULT_BORDER,
    exclude: Exclusion = None,
    refine: bool = False,
) -> InterestPoint | None:
    """Strongest feature: argmax of λ1 (seed 000 Alg. 1) among eligible pixels, or None.

    A pixel is eligible when C is not singular (Alg. 1 step 3), its isotropy λ2/λ1 is at least
    ``min_isotropy`` (aperture-problem guard, §2.2.1/§4.1; 0 reproduces the thesis), it lies
    in ``region`` = (x0, y0, x1, y1) (half-open pixel rectangle, default the whole image), at
    least ``border`` px from every image edge (default: a 21x21 template and a +-30 px search
    fit), and not in ``exclude`` (boolean mask, True = excluded, or (x, y, radius) discs).
    Returns None when nothing is eligible (e.g. a flat image). ``refine=True`` moves the point to
    the Förstner-Gülch sub-pixel corner in its feature window (λ1, λ2 stay the pixel's).
    """
    out = _scores(image, feature_size, region, min_isotropy, border, exclude)
    if out is None:
        return None
    img, half, (x0, y0), score, lam1, lam2 = out
    i = int(np.argmax(score))
    iy, ix = divmod(i, score.shape[1])
    if score[iy, ix] <= 0:
        return None
    return _point(img, half, x0 + ix, y0 + iy, lam1[iy, ix], lam2[iy, ix], refine)


def forstner_top_k(
    image: np.ndarray,
    k: int,
    feature_size: int = 7,
    region: Sequence[int] | None = None,
    min_isotropy: float = 0.2,
    border: int = DEFAULT_BORDER,
    exclude: Exclusion = None,
    min_distance: float = 10.0,
    refine: bool = False,
) -> list[InterestPoint]:
    """Up to ``k`` features by decreasing λ1, pairwise at least ``min_distance`` px apart.

    Same eligibility as :func:`forstner`; non-maximum suppression keeps local maxima of λ1
    (grey dilation), then greedily drops candidates nearer than ``min_distance`` to a stronger one.
    """
    if int(k) != k or k < 1:
        raise ValueError(f"k must be an integer >= 1, got {k!r}")
    if not min_distance >= 0:
        raise ValueError(f"min_distance must be >= 0, got {min_distance!r}")
    out = _scores(image, feature_size, region, min_isotropy, border, exclude)
    if out is None:
        return []
    img, half, (x0, y0), score, lam1, lam2 = out
    r = max(int(np.floor(min_distance)), 1)
    peaks = (score > 0) & (score >= cv2.dilate(score, np.ones((2 * r + 1, 2 * r + 1), np.uint8)))
    ys, xs = np.nonzero(peaks)
    order = np.argsort(-score[ys, xs], kind="stable")
    ys, xs = ys[order], xs[order]
    chosen: list[int] = []
    md2 = float(min_distance) ** 2
    for j in range(len(xs)):  # loop over candidate peaks, not pixels; stops at k
        if chosen:
            c = np.asarray(chosen)
            if np.any((xs[c] - xs[j]) ** 2 + (ys[c] - ys[j]) ** 2 < md2):
                continue
        chosen.append(j)
        if len(chosen) == k:
            break
    return [_point(img, half, x0 + xs[j], y0 + ys[j], lam1[ys[j], xs[j]], lam2[ys[j], xs[j]], refine) for j in chosen]
