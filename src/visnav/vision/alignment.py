"""Image alignment by the standard Hough transform (seed 002 §7.3.3, Algorithm 1, eq. 7.1).

Lines ``rho = x cos(theta) + y sin(theta)`` (eq. 7.1) are found with ``cv2.HoughLines`` on a binary
edge map of the sensed image (already scaled and rotated north with the telemetry heading, Alg. 1
step 1) and of the reference crop centred on the GPS position (step 2). Step 3 pairs "corresponding
lines": the thesis does not say how; here each strong sensed line is paired with the reference line of
nearest angle, but only after a consensus rotation has been chosen (the vote-weighted mode of all
pairwise angle differences within +-45 deg, a 1-D Hough over the rotation), so that a lone line of
another road cannot pull the mean. Step 4 averages the paired differences (``theta_avg``); step 5
applies it only when ``|theta_avg| < 45 deg`` and (beyond the thesis) only when at least
``min_pairs`` lines agree and no other rotation has ``max_ambiguity`` of the consensus' support;
otherwise the telemetry heading is kept.

Angles: image axes x right, y down; a line's normal angle theta is in [0, pi). Rotating the image
content by +a (counterclockwise as displayed, ``cv2.getRotationMatrix2D(c, deg(a), 1)``) turns every
line's theta into theta - a (mod pi). :func:`hough_alignment` returns the rotation ``a`` that takes the
sensed image onto the reference in that sense.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Alignment", "binary_edges", "hough_lines", "hough_alignment"]

_HALF = np.pi


@dataclass(frozen=True)
class Alignment:
    angle: float  # rad, rotation of the sensed image content onto the reference (0 when not applied)
    applied: bool
    pairs: int  # corresponding lines used for the mean
    theta_avg: float  # rad, Alg. 1 step 4 (NaN when no pair)
    reason: str = ""


def binary_edges(edge_mag: np.ndarray, mask: np.ndarray | None = None, keep: float = 0.08) -> np.ndarray:
    """uint8 0/255 map of the strongest ``keep`` share of an edge-magnitude image (inside ``mask``)."""
    e = np.asarray(edge_mag, np.float32)
    vals = e[mask > 0] if mask is not None else e.ravel()
    if vals.size == 0:
        return np.zeros(e.shape, np.uint8)
    thr = float(np.quantile(vals, 1.0 - keep))
    out = (e > max(thr, 1e-6)).astype(np.uint8) * 255
    if mask is not None:
        out[mask == 0] = 0
    return out


def hough_lines(binary: np.ndarray, max_lines: int = 12, min_votes_frac: float = 0.12,
                theta_step: float = np.pi / 720) -> tuple[np.ndarray, np.ndarray]:
    """(theta [rad] in [0, pi), votes) of the strongest lines of a binary edge map (eq. 7.1).

    The vote threshold is ``min_votes_frac`` times the shorter image side; non-maximum neighbours
    (within 3 deg and 4 px) of a stronger line are dropped so that one thick road is one line."""
    h, w = binary.shape
    thr = max(10, int(min_votes_frac * min(h, w)))
    lines = cv2.HoughLinesWithAccumulator(binary, 1, theta_step, thr)
    if lines is None or len(lines) == 0:
        return np.zeros(0), np.zeros(0)
    lines = lines.reshape(-1, 3)
    order = np.argsort(-lines[:, 2], kind="stable")
    lines = lines[order]
    kept: list[np.ndarray] = []
    for rho, th, v in lines:
        if any(abs(rho - k[0]) < 4 and _adiff(th, k[1]) < np.radians(3.0) for k in kept):
            continue
        kept.append(np.array([rho, th, v]))
        if len(kept) >= max_lines:
            break
    k = np.array(kept)
    return np.mod(k[:, 1], _HALF), k[:, 2]


def _adiff(a: float, b: float) -> float:
    d = (a - b + _HALF / 2) % _HALF - _HALF / 2
    return abs(d)


def _wrapped(d: np.ndarray) -> np.ndarray:
    """Angle differences of lines (period pi) wrapped to [-pi/2, pi/2)."""
    return (d + _HALF / 2) % _HALF - _HALF / 2


def hough_alignment(sensed_binary: np.ndarray, reference_binary: np.ndarray, max_angle: float = np.radians(45.0),
                    min_pairs: int = 2, pair_tol: float = np.radians(3.0), max_ambiguity: float = 0.8,
                    **line_kw) -> Alignment:
    """Algorithm 1 steps 3-5 on two binary edge maps of about the same ground area."""
    ts, vs = hough_lines(sensed_binary, **line_kw)
    tr, vr = hough_lines(reference_binary, **line_kw)
    if ts.size == 0 or tr.size == 0:
        return Alignment(0.0, False, 0, float("nan"), "no lines")
    # rotation a maps sensed theta_s to theta_s - a; a corresponding reference line has theta_r
    d = _wrapped(ts[:, None] - tr[None, :])  # candidate a for each pair
    wgt = np.sqrt(vs[:, None] * vr[None, :])
    ok = np.abs(d) < max_angle
    if not ok.any():
        return Alignment(0.0, False, 0, float("nan"), "no pair within 45 deg")
    # consensus: vote-weighted mode of the pair differences (kernel density on a 0.25 deg grid)
    grid = np.radians(np.arange(-45.0, 45.0 + 1e-9, 0.25))
    k = np.exp(-0.5 * (_wrapped(grid[:, None] - d[ok][None, :]) / pair_tol) ** 2)
    dens = k @ wgt[ok]
    im = int(np.argmax(dens))
    mode = float(grid[im])
    # beyond the thesis: a second rotation nearly as well supported (periodic crop rows, a grid of
    # roads) makes the alignment ambiguous: keep the telemetry heading then
    far = np.abs(_wrapped(grid - mode)) > 3 * pair_tol
    if far.any() and dens[far].max() > max_ambiguity * dens[im]:
        return Alignment(0.0, False, 0, float("nan"), "ambiguous rotation (two line families agree)")
    # correspondence: each sensed line with the reference line nearest to theta_s - mode
    resid = np.abs(_wrapped(d - mode))
    j = np.argmin(resid, axis=1)
    sel = resid[np.arange(ts.size), j] < pair_tol
    pairs = int(sel.sum())
    if pairs == 0:
        return Alignment(0.0, False, 0, float("nan"), "no corresponding lines")
    dd = d[np.arange(ts.size), j][sel]
    theta_avg = float(mode + np.mean(_wrapped(dd - mode)))  # Alg. 1 step 4 (the mean)
    if abs(theta_avg) >= max_angle:
        return Alignment(0.0, False, pairs, theta_avg, "mean angle beyond 45 deg (step 5)")
    if pairs < min_pairs:
        return Alignment(0.0, False, pairs, theta_avg, f"{pairs} corresponding line(s) < {min_pairs}")
    return Alignment(theta_avg, True, pairs, theta_avg, "")
