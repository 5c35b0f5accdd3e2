"""Distortion look-up tables calibrated on a flat board at a known distance (seed 004 §3.1).

The camera looks perpendicular at a board ``d`` metres away, aimed at its centre; every board mark
at (d_x, d_y) is found in the image at (X_m, Y_m) px from the image centre (Y up). Eq. 3.3-3.4 turn
the pixel back into a board distance with the nominal field of view,
``d_xm = d 2 X_m tan(theta_H) / S_x``, and eq. 3.5-3.6 give the relative error ``C = (d_xm - d_x) / d_x``.

* :func:`thesis_lut` is the thesis' table: one quadrant (upper right) measured and mirrored
  (symmetric lens assumed), coordinates normalised to 1 at ``S_x / 2``, ``S_y / 2``, and the
  correction applied multiplicatively, eq. 3.7-3.8: ``X = X_m lookup_X(|X_m|/(S_x/2), |Y_m|/(S_y/2))``
  with ``lookup = 1 / (1 + C)`` (the factor that turns d_xm back into d_x).
* :func:`full_lut` is ours: the whole frame measured, no symmetry assumed, and the correction stored
  as an additive pixel offset, so that an image centre that is not the optical centre (the
  asymmetric crop of §7.1, Fig. 7.2) is corrected too.

Both tables are interpolated linearly (eq. 3.7) on their regular grid, the end cells extrapolated (the values of
scipy's ``RegularGridInterpolator(..., fill_value=None)``, without its per-call set-up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import Delaunay, cKDTree

from visnav.geometry.camera import PinholeCamera
from visnav.vision import kernels
from visnav.vision.rectification import CameraGeometry

__all__ = ["Board", "synthetic_board", "DistortionLUT", "thesis_lut", "full_lut"]


@dataclass(frozen=True)
class Board:
    distance: float
    dx: np.ndarray  # board mark offsets [m], right
    dy: np.ndarray  # [m], up
    Xm: np.ndarray  # measured image coordinates [px] from the image centre, right
    Ym: np.ndarray  # [px], up


def synthetic_board(camera: PinholeCamera, distance_m: float = 2.0, spacing_m: float = 0.05,
                    pixel_noise: float = 0.0, rng: np.random.Generator | None = None) -> Board:
    """The calibration photo of Fig. 3.1 made synthetically: a grid of marks on a wall ``distance_m``
    in front of the camera (optical axis perpendicular, through the board centre), projected through
    ``camera`` (its distortion and principal point); marks outside the image are dropped."""
    if not distance_m > 0:
        raise ValueError(f"distance_m must be positive, got {distance_m!r}")
    # wide enough for the widest ray of the lens (corners at up to ~1.5 x the pinhole extent)
    ext_x = 1.6 * distance_m * (camera.width / 2 + abs(camera.cx - (camera.width - 1) / 2)) / camera.fx
    ext_y = 1.6 * distance_m * (camera.height / 2 + abs(camera.cy - (camera.height - 1) / 2)) / camera.fy
    gx = np.arange(-ext_x, ext_x + 1e-9, spacing_m)
    gy = np.arange(-ext_y, ext_y + 1e-9, spacing_m)
    dx, dy = (a.ravel() for a in np.meshgrid(gx - gx.mean(), gy - gy.mean()))
    pts = np.stack([dx, -dy, np.full(dx.shape, distance_m)], axis=1)  # OpenCV frame: y down
    uv = camera.project(pts)
    ok = camera.in_image(uv)
    if pixel_noise > 0:
        uv = uv + (rng or np.random.default_rng(0)).normal(0.0, pixel_noise, uv.shape)
    Xm = uv[ok, 0] - (camera.width - 1) / 2.0
    Ym = (camera.height - 1) / 2.0 - uv[ok, 1]
    return Board(float(distance_m), dx[ok], dy[ok], Xm, Ym)


@dataclass
class DistortionLUT:
    """Two tables on a regular grid of normalised coordinates; ``kind`` 'factor' (eq. 3.7-3.8,
    mirrored quadrant) or 'offset' (whole frame, additive)."""

    kind: str
    gx: np.ndarray
    gy: np.ndarray
    table_x: np.ndarray  # (len(gx), len(gy))
    table_y: np.ndarray
    width: int
    height: int

    def __post_init__(self) -> None:
        self._tables = np.stack([self.table_x, self.table_y], axis=-1)  # (len(gx), len(gy), 2)
        self._lists = tuple(np.asarray(a, float).tolist() for a in (self.gx, self.gy, self.table_x, self.table_y))

    def _lookup(self, a, b) -> np.ndarray:
        """Eq. 3.7: both tables interpolated bilinearly at normalised (a, b) (the end cells extrapolated); (..., 2)."""
        i, u = _cell(self.gx, a)
        j, v = _cell(self.gy, b)
        t, u, v = self._tables, u[..., None], v[..., None]
        return (t[i, j] * (1 - u) * (1 - v) + t[i, j + 1] * (1 - u) * v
                + t[i + 1, j] * u * (1 - v) + t[i + 1, j + 1] * u * v)

    def correct(self, Xm, Ym):
        """Corrected image coordinates (X_tgt, Y_tgt) of measured (X_tgtm, Y_tgtm) [px]."""
        Xm, Ym = np.asarray(Xm, float), np.asarray(Ym, float)
        if kernels.ENABLED and Xm.size == 1 and Ym.size == 1:  # one point: vision/kernels on floats
            a, b = Xm.item() / (self.width / 2.0), Ym.item() / (self.height / 2.0)
            if self.kind == "factor":
                cx, cy = kernels.bilinear1(*self._lists, abs(a), abs(b))
                return Xm * cx, Ym * cy
            cx, cy = kernels.bilinear1(*self._lists, a, b)
            return Xm + cx, Ym + cy
        nx, ny = np.broadcast_arrays(Xm / (self.width / 2.0), Ym / (self.height / 2.0))
        if self.kind == "factor":  # eq. 3.7-3.8: the quadrant's table at (|X_m|, |Y_m|), a factor
            c = self._lookup(np.abs(nx), np.abs(ny))
            return Xm * c[..., 0], Ym * c[..., 1]
        c = self._lookup(nx, ny)
        return Xm + c[..., 0], Ym + c[..., 1]


def _cell(g: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid cell of ``x`` on the ascending grid ``g`` (the first or last outside it) and ``x``'s place in it."""
    i = np.minimum(np.maximum(np.searchsorted(g, x, side="right") - 1, 0), len(g) - 2)
    return i, (x - g[i]) / (g[i + 1] - g[i])


def _to_grid(px, py, values, gx, gy) -> list[np.ndarray]:
    """Scattered (px, py) -> regular grid, linear inside the marks' hull, nearest mark outside;
    one triangulation for all ``values`` (a list of arrays)."""
    pts = np.column_stack([px, py])
    tri = Delaunay(pts)
    G = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1)
    _, nearest = cKDTree(pts).query(G)
    out = []
    for v in values:
        lin = LinearNDInterpolator(tri, v)(G)  # NaN outside the hull (no separate find_simplex:
        out.append(np.where(np.isfinite(lin), lin, v[nearest]))  # its walk is erratically slow)
    return out


def thesis_lut(board: Board, geom: CameraGeometry, n: int = 11) -> DistortionLUT:
    """Eq. 3.3-3.8: relative-error tables from the upper-right quadrant, mirrored to the others."""
    d = board.distance
    q = (board.dx > 0) & (board.dy > 0) & (board.Xm > 0) & (board.Ym > 0)
    dxm = d * 2.0 * board.Xm[q] * np.tan(geom.half_hfov) / geom.width  # eq. 3.3
    dym = d * 2.0 * board.Ym[q] * np.tan(geom.half_vfov) / geom.height  # eq. 3.4
    cx = (dxm - board.dx[q]) / board.dx[q]  # eq. 3.5
    cy = (dym - board.dy[q]) / board.dy[q]  # eq. 3.6
    nx, ny = board.Xm[q] / (geom.width / 2.0), board.Ym[q] / (geom.height / 2.0)
    g = np.linspace(0.0, 1.0, n)
    tx, ty = _to_grid(nx, ny, [1.0 / (1.0 + cx), 1.0 / (1.0 + cy)], g, g)
    return DistortionLUT("factor", g, g, tx, ty, geom.width, geom.height)


def full_lut(board: Board, geom: CameraGeometry, nx: int = 33, ny: int = 25) -> DistortionLUT:
    """Our table: the pixel offset from measured to ideal pinhole coordinates over the whole frame,
    ideal = ``f d_x / d`` with the nominal ``f = S_x / (2 tan theta_H)`` (eq. 3.3 inverted)."""
    d = board.distance
    ox = geom.fx * board.dx / d - board.Xm
    oy = geom.fy * board.dy / d - board.Ym
    px, py = board.Xm / (geom.width / 2.0), board.Ym / (geom.height / 2.0)
    gx, gy = np.linspace(-1.0, 1.0, nx), np.linspace(-1.0, 1.0, ny)
    tx, ty = _to_grid(px, py, [ox, oy], gx, gy)
    return DistortionLUT("offset", gx, gy, tx, ty, geom.width, geom.height)
