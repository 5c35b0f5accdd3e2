"""Ring detection with sub-pixel ellipses, and the conic algebra of concentric circles.

A *ring* is a dark annulus on a bright board (geometry/pad.py). Detection (``detect_rings``):

1. adaptive mean threshold (robust to a lighting change and a partial shadow: the comparison is
   with the local mean over ``block`` px), dark = foreground;
2. ``cv2.findContours`` (two-level hierarchy): a dark component with a hole is a ring candidate;
   outer boundary and hole must each be ellipses (contour area / fitted ellipse area in 0.85-1.15);
3. sub-pixel boundaries: along ``n_normals`` normals of each fitted ellipse the grey profile is
   sampled (bilinear, ``cv2.remap``) and the crossing of the mid-level between its darkest and
   brightest sample located by linear interpolation; an ellipse is fitted to those points again.
   The contour of a thresholded image lies on the dark pixels, half a pixel inside the true edge
   on both boundaries: a 3 % range error for a 16 px ring if left in. The mid-level crossing is
   unbiased for a symmetric blur, whatever the exposure.

The image of a circle's centre is *not* the centre of its image ellipse under perspective. For
two concentric circles of radii r1 > r2 with image conics Q1, Q2 (x^T Q x = 0), the matrix
Q1^-1 Q2 = H diag(1, 1, (r2/r1)^2) H^-1 up to scale (the circles are diag(1, 1, -r^2) in their
own plane): its distinct eigenvalue's eigenvector is H (0, 0, 1)^T, the exact image of the centre,
and the ratio of its eigenvalues is (r2/r1)^2, a projective invariant that tells rings apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Ring", "concentric_centre", "conic_from_ellipse", "detect_rings", "ellipse_from_conic",
           "line_conic_intersections"]


def conic_from_ellipse(cx: float, cy: float, a: float, b: float, theta: float) -> np.ndarray:
    """3x3 conic (unit Frobenius norm) of the ellipse with centre (cx, cy), semi-axes a, b [px]
    and the a-axis at ``theta`` [rad] from the image x axis."""
    c, s = np.cos(theta), np.sin(theta)
    T = np.array([[c, s, -(c * cx + s * cy)], [-s, c, s * cx - c * cy], [0.0, 0.0, 1.0]])
    Q = T.T @ np.diag([1.0 / a**2, 1.0 / b**2, -1.0]) @ T
    return Q / np.linalg.norm(Q)


def ellipse_from_conic(Q: np.ndarray) -> tuple[float, float, float, float, float]:
    """(cx, cy, a, b, theta) of a real ellipse conic (inverse of ``conic_from_ellipse``)."""
    A = Q[:2, :2]
    c = -np.linalg.solve(A, Q[:2, 2])
    k = float(c @ A @ c + 2 * Q[:2, 2] @ c + Q[2, 2])
    w, V = np.linalg.eigh(-A / k)
    a, b = 1.0 / np.sqrt(w)
    return float(c[0]), float(c[1]), float(a), float(b), float(np.arctan2(V[1, 0], V[0, 0]))


def concentric_centre(Q_out: np.ndarray, Q_in: np.ndarray) -> tuple[np.ndarray, float]:
    """(image of the common centre (2,), (r_in / r_out)^2) from the conics of two concentric circles."""
    m, r2 = concentric_centres(np.asarray(Q_out)[None], np.asarray(Q_in)[None])
    return m[0], float(r2[0])


def concentric_centres(Q_out: np.ndarray, Q_in: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``concentric_centre`` of K pairs at once: (K, 2) centres and (K,) squared radius ratios. The
    pencil Q_out^-1 Q_in of two concentric circles' images has a double eigenvalue and a distinct one
    whose eigenvector is the image of the centre; the distinct one over the double one is (r_in/r_out)^2."""
    M = np.linalg.solve(Q_out, Q_in)
    w, V = np.linalg.eig(M)
    w, V = w.real, V.real
    # the distinct eigenvalue: farthest from the mean of the other two
    d = np.abs(w - 0.5 * (np.roll(w, -1, axis=1) + np.roll(w, -2, axis=1)))
    i = np.argmax(d, axis=1)
    k = np.arange(len(w))
    v = V[k, :, i]
    others = (w.sum(axis=1) - w[k, i]) * 0.5
    return v[:, :2] / v[:, 2:3], w[k, i] / others


def conics_from_ellipses(E: np.ndarray) -> np.ndarray:
    """``conic_from_ellipse`` of K ellipses (K, 5) at once: (K, 3, 3)."""
    cx, cy, a, b, th = (np.asarray(E, float)[:, j] for j in range(5))
    c, s = np.cos(th), np.sin(th)
    tx, ty = -(c * cx + s * cy), s * cx - c * cy
    ia, ib = 1.0 / a**2, 1.0 / b**2
    # T^T diag(1/a^2, 1/b^2, -1) T with T = [[c, s, tx], [-s, c, ty], [0, 0, 1]]
    Q = np.empty((len(cx), 3, 3))
    Q[:, 0, 0] = c * c * ia + s * s * ib
    Q[:, 0, 1] = Q[:, 1, 0] = c * s * ia - s * c * ib
    Q[:, 1, 1] = s * s * ia + c * c * ib
    Q[:, 0, 2] = Q[:, 2, 0] = c * tx * ia - s * ty * ib
    Q[:, 1, 2] = Q[:, 2, 1] = s * tx * ia + c * ty * ib
    Q[:, 2, 2] = tx * tx * ia + ty * ty * ib - 1.0
    return Q / np.linalg.norm(Q, axis=(1, 2))[:, None, None]


def line_conic_intersections(m0: np.ndarray, m1: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Points m0 + s (m1 - m0) on the conic, (2, 2): first the one with s < 0, then s > 0
    (m0 inside the ellipse). NaN where the line misses it."""
    p = np.array([m0[0], m0[1], 1.0])
    d = np.array([m1[0] - m0[0], m1[1] - m0[1], 0.0])
    Qd = Q @ d
    a, b, c = d @ Qd, p @ Qd, p @ Q @ p
    disc = b * b - a * c
    if disc < 0 or a == 0:
        return np.full((2, 2), np.nan)
    r = np.sqrt(disc)
    s = np.sort([(-b - r) / a, (-b + r) / a])
    return np.array([m0 + s[0] * (m1 - m0), m0 + s[1] * (m1 - m0)])


@dataclass
class Ring:
    """A detected ring: outer and inner ellipses (cx, cy, a, b, theta) and conics, the image of its
    centre, the measured inner/outer radius ratio and its size sqrt(a b) of the outer ellipse [px]."""

    outer: tuple
    inner: tuple
    Q_out: np.ndarray
    Q_in: np.ndarray
    centre: np.ndarray
    ratio: float
    size: float


def _fit(pts: np.ndarray):
    (cx, cy), (w, h), ang = cv2.fitEllipse(pts.astype(np.float32))
    if not (w > 0 and h > 0):
        return None
    return float(cx), float(cy), 0.5 * float(w), 0.5 * float(h), float(np.radians(ang))


def _refine(gray: np.ndarray, ellipses: list, n: int) -> list:
    """Sub-pixel boundary points along the normals of each ellipse, refitted (None where too few)."""
    if not ellipses:
        return []
    phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    E = np.array(ellipses)
    cx, cy, a, b, th = (E[:, i][:, None] for i in range(5))
    ca, sa = np.cos(th), np.sin(th)
    ex, ey = a * np.cos(phi), b * np.sin(phi)
    px = cx + ca * ex - sa * ey
    py = cy + sa * ex + ca * ey
    nx_, ny_ = np.cos(phi) / a, np.sin(phi) / b  # gradient of the implicit function (local axes)
    nx = ca * nx_ - sa * ny_
    ny = sa * nx_ + ca * ny_
    nn = np.hypot(nx, ny)
    nx, ny = nx / nn, ny / nn
    half = np.clip(0.25 * b, 1.5, 4.0)  # profile half length [px]
    s = np.linspace(-1.0, 1.0, 13)[None, None, :] * half[:, :, None]
    mx = (px[:, :, None] + nx[:, :, None] * s).astype(np.float32)
    my = (py[:, :, None] + ny[:, :, None] * s).astype(np.float32)
    k = len(ellipses)
    prof = cv2.remap(gray, mx.reshape(1, -1), my.reshape(1, -1), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE).reshape(k, n, 13).astype(np.float32)
    lo, hi = prof.min(axis=2, keepdims=True), prof.max(axis=2, keepdims=True)
    f = prof - 0.5 * (lo + hi)
    cross = (f[:, :, :-1] * f[:, :, 1:]) <= 0
    # the crossing nearest the profile's middle
    mid = np.abs(np.arange(12) - 5.5)[None, None, :]
    score = np.where(cross, mid, np.inf)
    j = np.argmin(score, axis=2)
    ok = np.isfinite(np.take_along_axis(score, j[:, :, None], axis=2)[:, :, 0]) & ((hi - lo)[:, :, 0] > 12)
    f0 = np.take_along_axis(f, j[:, :, None], axis=2)[:, :, 0]
    f1 = np.take_along_axis(f, j[:, :, None] + 1, axis=2)[:, :, 0]
    denom = np.where(f0 - f1 == 0, 1.0, f0 - f1)
    frac = np.clip(f0 / denom, 0.0, 1.0)
    step = 2.0 * half / 12.0  # (k, 1)
    sj = -half + step * (j + frac)
    qx, qy = px + nx * sj, py + ny * sj
    out = []
    for i in range(k):
        m = ok[i]
        if m.sum() < max(8, int(0.6 * n)):
            out.append(None)
            continue
        out.append(_fit(np.column_stack([qx[i, m], qy[i, m]])))
    return out


def _is_ellipse(contour: np.ndarray, e) -> bool:
    area = cv2.contourArea(contour)
    return e is not None and 0.8 < area / (np.pi * e[2] * e[3] + 1e-9) < 1.2


def detect_rings(gray: np.ndarray, block: int = 51, offset: float = 30.0, min_radius_px: float = 4.0,
                 min_inner_px: float = 2.0, n_normals: int = 48, margin_px: float = 2.0) -> list[Ring]:
    """Every ring in a uint8 grayscale image (see the module docstring). Rings touching the image
    border (within ``margin_px``) are dropped: an incomplete ring has no trustworthy ellipse."""
    if gray.ndim != 2 or gray.dtype != np.uint8:
        raise ValueError(f"detect_rings needs a uint8 HxW image, got {gray.dtype} {gray.shape}")
    h, w = gray.shape
    bw = cv2.adaptiveThreshold(gray, 255, cv2.ADAPTIVE_THRESH_MEAN_C, cv2.THRESH_BINARY_INV, block, offset)
    contours, hier = cv2.findContours(bw, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if hier is None:
        return []
    hier = hier[0]
    pairs = []
    for i in np.flatnonzero((hier[:, 3] == -1) & (hier[:, 2] != -1)):  # outer boundaries with a hole
        c = contours[i]
        if len(c) < 12:
            continue
        x, y, bw_, bh_ = cv2.boundingRect(c)
        if x <= margin_px or y <= margin_px or x + bw_ >= w - 1 - margin_px or y + bh_ >= h - 1 - margin_px:
            continue
        if min(bw_, bh_) < 2 * min_radius_px:
            continue
        best, area = -1, 0.0
        ch = hier[i, 2]
        while ch != -1:  # the largest hole
            ar = cv2.contourArea(contours[ch])
            if ar > area:
                best, area = ch, ar
            ch = hier[ch, 0]
        if best < 0 or len(contours[best]) < 8:
            continue
        a_out = cv2.contourArea(c)
        if a_out < np.pi * min_radius_px**2 or not 0.04 < area / a_out < 0.85:
            continue
        eo = _fit(c.reshape(-1, 2))
        if not _is_ellipse(c, eo):  # the outer boundary first: a non-ellipse costs one fit, not two
            continue
        ei = _fit(contours[best].reshape(-1, 2))
        if not _is_ellipse(contours[best], ei):
            continue
        if min(ei[2], ei[3]) < min_inner_px:
            continue
        pairs.append((eo, ei))
    if not pairs:
        return []
    ref = _refine(gray, [p[0] for p in pairs] + [p[1] for p in pairs], n_normals)
    k = len(pairs)
    keep = [i for i in range(k) if ref[i] is not None and ref[k + i] is not None]
    if not keep:
        return []
    Qo = conics_from_ellipses(np.array([ref[i] for i in keep]))
    Qi = conics_from_ellipses(np.array([ref[k + i] for i in keep]))
    try:
        M, R2 = concentric_centres(Qo, Qi)
    except np.linalg.LinAlgError:  # a singular pair among them: one at a time
        pairs_out = [concentric_centre(a, b) if np.linalg.cond(a) < 1e12 else (np.full(2, np.nan), np.nan)
                     for a, b in zip(Qo, Qi)]
        M = np.array([p[0] for p in pairs_out])
        R2 = np.array([p[1] for p in pairs_out])
    rings = []
    for n, i in enumerate(keep):
        eo, ei, m, r2 = ref[i], ref[k + i], M[n], float(R2[n])
        if not (np.all(np.isfinite(m)) and 0.0 < r2 < 1.0) or np.hypot(*(m - eo[:2])) > 0.5 * min(eo[2], eo[3]):
            continue
        rings.append(Ring(eo, ei, Qo[n], Qi[n], m, float(np.sqrt(r2)), float(np.sqrt(eo[2] * eo[3]))))
    return rings
