"""Registrability map (beyond seed 002 ch. 7, which asks to know in advance where on a map registration
is reliable): for every cell of a geo-referenced image, how reliably a nadir frame taken above it at
``altitude_m`` registers with the ch. 7 pipeline.

Per cell: the *sensed* template is what the pipeline would correlate (the ground as the camera would see
it on another day, ``world/appearance.py``'s ``ANOTHER_DAY`` by default, ``unstable_m=0`` for the
reference's own day; video noise, the median filter, Sobel edges; the largest square inside the frame
at any heading), the *window* is the reference edge image around the cell extended by the search
radius; the correlation surface (TM_CCOEFF_NORMED, computed for all cells at once by batched FFTs with
window sums from cumulative sums), averaged over ``realizations`` draws of the change, gives

* ``peak``: the correlation at the true position;
* ``ambiguity``: the highest correlation farther than ``exclusion_m`` from it (a look-alike place), also
  with the frame turned by +-``rotations_deg``;
* ``sharpness``: the peak minus the mean on a ring at ``exclusion_m / 2``, relative to the peak;
* ``score`` = max(peak - max(ambiguity, 0), 0) x clip(sharpness, 0, 1), in [0, 1].

``validate`` measures what the score predicts: frames rendered at random places and headings are
registered with ``GeoRegistration`` (heading off by up to ``heading_error_deg``, GPS off by a few
metres), and the failure rate (no match, or the frame centre more than ``fail_m`` off) is compared
between the low- and the high-scoring places.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy import fft as sfft

from visnav.vision.geolocation_registration import sobel_edges
from visnav.world.appearance import ANOTHER_DAY, appearance_change
from visnav.geometry.frames import LocalTangentPlane
from visnav.geometry.camera import PinholeCamera
from visnav.sensors.camera import CameraRenderer
from visnav.vision.geolocation_registration import GeoRegistration, nadir_dcm
from visnav.world.appearance import another_day
from visnav.world.maps import degrade_reference
from visnav.world.scene import World
from visnav.world.wind import SteadyWind, Wind

#: the former name (the uniform model: ``relief_level`` None)
unstable_texture = appearance_change

__all__ = ["Registrability", "registrability_map", "validate", "write_registrability"]


@dataclass
class Registrability:
    score: np.ndarray  # (rows, cols) per cell
    peak: np.ndarray
    ambiguity: np.ndarray
    sharpness: np.ndarray
    cell_m: float
    north0: float  # NED of the centre of cell (0, 0)
    east0: float
    altitude_m: float

    def at(self, ne) -> np.ndarray:
        """Score of the cells holding NED points (N, 2) (NaN off the grid)."""
        ne = np.atleast_2d(np.asarray(ne, float))
        i = np.round((self.north0 - ne[:, 0]) / self.cell_m).astype(int)
        j = np.round((ne[:, 1] - self.east0) / self.cell_m).astype(int)
        ok = (i >= 0) & (j >= 0) & (i < self.score.shape[0]) & (j < self.score.shape[1])
        out = np.full(len(ne), np.nan)
        out[ok] = self.score[i[ok], j[ok]]
        return out


def _box_sums(a: np.ndarray, k: int) -> np.ndarray:
    """Sums over every k x k window of a batch (N, H, W) -> (N, H-k+1, W-k+1), from cumulative sums."""
    c = np.zeros((a.shape[0], a.shape[1] + 1, a.shape[2] + 1))
    c[:, 1:, 1:] = np.cumsum(np.cumsum(a, axis=1, dtype=float), axis=2)
    return c[:, k:, k:] - c[:, :-k, k:] - c[:, k:, :-k] + c[:, :-k, :-k]


def batch_ncc(windows: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """TM_CCOEFF_NORMED of each template (N, q, q) over its window (N, W, W): (N, W-q+1, W-q+1)."""
    n, q, _ = templates.shape
    W = windows.shape[1]
    t = templates - templates.mean(axis=(1, 2), keepdims=True)
    tn = np.sqrt((t * t).sum(axis=(1, 2)))
    size = sfft.next_fast_len(W, real=True)
    Fw = sfft.rfft2(windows.astype(np.float32), s=(size, size), workers=1)
    Ft = sfft.rfft2(t[:, ::-1, ::-1].astype(np.float32), s=(size, size), workers=1)
    full = sfft.irfft2(Fw * Ft, s=(size, size), workers=1)
    num = full[:, q - 1 : W, q - 1 : W]
    s1 = _box_sums(windows, q)
    s2 = _box_sums(windows * windows, q)
    var = np.maximum(s2 - s1 * s1 / (q * q), 0.0)
    den = tn[:, None, None] * np.sqrt(var)
    return np.where(den > 1e-6 * max(float(tn.max()), 1e-12), num / np.maximum(den, 1e-12), 0.0)


def _sensed_edges(img: np.ndarray, noise_sigma: float, median_px: int, rng: np.random.Generator) -> np.ndarray:
    noisy = cv2.add(img, np.clip(np.round(rng.normal(0.0, noise_sigma, img.shape)), -127, 127).astype(np.int16),
                    dtype=cv2.CV_8U) if noise_sigma > 0 else img
    return sobel_edges(cv2.medianBlur(noisy, median_px) if median_px > 1 else noisy)


def registrability_map(geo, altitude_m: float, hfov_deg: float = 53.0, aspect: float = 288 / 360,
                       cell_m: float = 10.0, search_m: float = 15.0, exclusion_m: float = 4.0,
                       work_res_m: float = 0.5, noise_sigma: float = 4.0, median_px: int = 3,
                       chunk: int = 64, seed: int = 0, unstable_m: float = ANOTHER_DAY["scale_m"],
                       texture_keep: float = ANOTHER_DAY["keep"],
                       relief_level: float | None = ANOTHER_DAY["relief_level"],
                       shift_m: float = ANOTHER_DAY["shift_m"], shift_corr_m: float = ANOTHER_DAY["corr_m"],
                       realizations: int = 4, rotations_deg: tuple = (7.5, 15.0)) -> Registrability:
    """The per-cell registrability of ``geo`` (a GeoImage) for frames taken at ``altitude_m``: the
    correlation surfaces of ``realizations`` draws of the appearance change (one when there is none)
    averaged (the expected surface), then peak, ambiguity, sharpness and score (module docstring). The
    ambiguity also counts look-alike places for the frame turned by +-``rotations_deg`` (the heading the
    pipeline searches is uncertain): the reference turned instead of the template, once per angle."""
    if not (np.isfinite(altitude_m) and altitude_m > 0):
        raise ValueError(f"altitude must be positive, got {altitude_m}")
    k = max(1, int(round(work_res_m / geo.resolution_m)))
    res = geo.resolution_m * k
    img = geo.image if k == 1 else cv2.resize(geo.image, (geo.shape[1] // k, geo.shape[0] // k),
                                              interpolation=cv2.INTER_AREA)
    ref = sobel_edges(img)
    rng = np.random.default_rng(seed)
    n_real = max(1, int(realizations)) if unstable_m > 0 else 1
    sensed = [_sensed_edges(appearance_change(img, unstable_m / res, rng, texture_keep, relief_level, shift_m / res,
                                              shift_corr_m / res), noise_sigma, median_px, rng) for _ in range(n_real)]
    width = 2 * altitude_m * math.tan(math.radians(hfov_deg) / 2)
    q = int(width * aspect / math.sqrt(2) / res)  # the square inside the frame at any heading
    r = int(math.ceil(search_m / res))
    if q < 8:
        raise ValueError(f"altitude {altitude_m} m gives a {q} px template at {res} m/px: too small")
    H, W = ref.shape
    step = max(1, int(round(cell_m / res)))
    half = q // 2 + r
    rows = np.arange(half, H - half - 1, step)
    cols = np.arange(half, W - half - 1, step)
    if rows.size == 0 or cols.size == 0:
        raise ValueError(f"map of {H * res:.0f} x {W * res:.0f} m is smaller than one frame + search window "
                         f"({2 * half * res:.0f} m) at {altitude_m} m")
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    centres = np.column_stack([rr.ravel(), cc.ravel()])
    out = {k_: np.zeros(len(centres)) for k_ in ("peak", "amb", "sharp", "std")}
    ex = int(round(exclusion_m / res))
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    rad2 = yy * yy + xx * xx
    far = rad2 > ex * ex
    ring = np.abs(np.sqrt(rad2) - ex / 2) < 0.5
    a = q // 2
    wr = np.arange(-half, -half + q + 2 * r)
    turned = []  # (reference edge image turned by an angle about the map centre, its affine) per angle
    D = int(np.ceil(math.hypot(H, W))) + 2 * half + 4
    for ang in [sg * float(t) for t in rotations_deg for sg in (1.0, -1.0) if t != 0]:
        M = cv2.getRotationMatrix2D((W / 2.0, H / 2.0), ang, 1.0)
        M[:, 2] += (D / 2.0 - W / 2.0, D / 2.0 - H / 2.0)
        turned.append((cv2.warpAffine(ref.astype(np.float32), M, (D, D), flags=cv2.INTER_LINEAR, borderValue=0.0), M))
    for s in range(0, len(centres), chunk):
        cs = centres[s : s + chunk]
        idx_t = (cs[:, 0, None, None] - a + np.arange(q)[None, :, None], cs[:, 1, None, None] - a + np.arange(q)[None, None, :])
        win = ref[cs[:, 0, None, None] + wr[None, :, None], cs[:, 1, None, None] + wr[None, None, :]]
        c = sum(batch_ncc(win, sn[idx_t]) for sn in sensed) / len(sensed)  # (n, 2r+1, 2r+1), zero shift at (r, r)
        tpl = sensed[0][idx_t]
        pk = c[:, r, r]
        out["peak"][s : s + chunk] = pk
        amb = c[:, far].max(axis=1)
        for R_, M in turned:  # the same place or another one, with the frame at a wrong heading
            ct = np.rint(np.column_stack([cs[:, 1], cs[:, 0], np.ones(len(cs))]) @ M.T).astype(int)  # (x, y)
            wt = R_[ct[:, 1, None, None] + wr[None, :, None], ct[:, 0, None, None] + wr[None, None, :]]
            c_t = sum(batch_ncc(wt, sn[idx_t]) for sn in sensed) / len(sensed)
            amb = np.maximum(amb, c_t[:, far].max(axis=1))
        out["amb"][s : s + chunk] = amb
        out["sharp"][s : s + chunk] = (pk - c[:, ring].mean(axis=1)) / np.maximum(np.abs(pk), 1e-6)
        out["std"][s : s + chunk] = tpl.std(axis=(1, 2))
    shape = rr.shape
    peak, amb = out["peak"].reshape(shape), out["amb"].reshape(shape)
    sharp = np.clip(out["sharp"].reshape(shape), 0.0, 1.0)
    score = np.clip(peak - np.maximum(amb, 0.0), 0.0, 1.0) * sharp
    # cell (0, 0) centre: working pixel (rows[0], cols[0]) -> level-0 pixel centre -> NED
    c0 = (cols[0] + 0.5) * k - 0.5
    r0 = (rows[0] + 0.5) * k - 0.5
    (n0, e0), = geo.pixel_to_ned(np.array([[c0, r0]]))
    return Registrability(score, peak, amb, sharp, step * res, float(n0), float(e0), float(altitude_m))


def write_registrability(reg: Registrability, geo, out_dir: Path, stem: str = "registrability") -> dict:
    """``<stem>.png`` (score x 255, one pixel per cell) with a world file aligned with the map (EPSG:4326
    degrees when the map was geo-referenced, local metres east/north otherwise), ``<stem>.npy`` and an
    overlay figure. Returns the paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    png = out_dir / f"{stem}.png"
    cv2.imwrite(str(png), np.clip(np.round(reg.score * 255), 0, 255).astype(np.uint8))
    np.save(out_dir / f"{stem}.npy", reg.score)
    pts = np.array([[reg.north0, reg.east0], [reg.north0, reg.east0 + reg.cell_m], [reg.north0 - reg.cell_m, reg.east0]])
    if geo.origin_geodetic is not None:
        ltp = LocalTangentPlane(geo.origin_geodetic[0], geo.origin_geodetic[1], 0.0)
        lat, lon, _ = ltp.ned_to_geodetic(np.column_stack([pts, np.zeros(3)]))
        x, y = np.asarray(lon, float), np.asarray(lat, float)
    else:
        x, y = pts[:, 1], pts[:, 0]
    wf = [x[1] - x[0], 0.0, 0.0, y[2] - y[0], x[0], y[0]]
    (out_dir / f"{stem}.pgw").write_text("\n".join(f"{v:.12f}" for v in wf) + "\n")
    fig_path = out_dir / f"{stem}_overlay.png"
    _overlay(reg, geo, fig_path)
    return {"png": png, "world_file": out_dir / f"{stem}.pgw", "npy": out_dir / f"{stem}.npy", "overlay": fig_path}


def _overlay(reg: Registrability, geo, path: Path, marks=None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n0, n1, e0, e1 = geo.extent_ned()
    h, w = reg.score.shape
    ext_s = [reg.east0 - reg.cell_m / 2, reg.east0 + (w - 0.5) * reg.cell_m,
             reg.north0 - (h - 0.5) * reg.cell_m, reg.north0 + reg.cell_m / 2]
    tall = (n1 - n0) > (e1 - e0)
    fig, ax = plt.subplots(1, 2, figsize=(9, 8) if tall else (14, 5.5))
    for a_ in ax:
        a_.imshow(geo.image, cmap="gray", extent=[e0, e1, n0, n1])
    im = ax[1].imshow(reg.score, cmap="RdYlGn", vmin=0, vmax=max(0.3, float(np.nanmax(reg.score))), alpha=0.6,
                      extent=ext_s)
    fig.colorbar(im, ax=ax[1], fraction=0.046, label="registrability score")
    if marks is not None:
        for (ne, ok) in marks:
            ax[1].plot(ne[1], ne[0], "o" if ok else "x", color="b" if ok else "r", ms=4)
    ax[0].set_title(f"map {geo.name}")
    ax[1].set_title(f"registrability at {reg.altitude_m:.0f} m AGL (cell {reg.cell_m:.0f} m)")
    for a_ in ax:
        a_.set_xlabel("east [m]")
    ax[0].set_ylabel("north [m]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def validate(reg: Registrability, geo, n: int = 60, heading_error_deg: float = 15.0, gps_error_m: float = 4.0,
             fail_m: float = 5.0, seed: int = 0, hough: bool = True, unstable_m: float = ANOTHER_DAY["scale_m"],
             texture_keep: float = ANOTHER_DAY["keep"], relief_level: float | None = ANOTHER_DAY["relief_level"],
             shift_m: float = ANOTHER_DAY["shift_m"], shift_corr_m: float = ANOTHER_DAY["corr_m"], quantiles: int = 4,
             **registration_kw) -> dict:
    """Register ``n`` frames rendered at random places of the scored area; failure rate by score.

    A failure: no match, or the frame centre registered more than ``fail_m`` from the truth. The
    frames, headings and GPS errors depend on ``seed`` only (the same for any ``hough`` or
    ``registration_kw``). Returns per-frame arrays (``error_m``, ``heading_error``, ``hough_applied``,
    ``quality``) and the failure rate below / above the median score and per score quantile."""

    rng = np.random.default_rng(seed)
    f = 360.0 / math.tan(math.radians(26.5))
    cam = PinholeCamera(720, 576, f, f, 359.5, 287.5, (-0.22, 0.06, 0, 0, 0, 0, 0, 0))
    ren = CameraRenderer(cam, 4.0, rng)
    # the frames are taken on another day than the reference (world/appearance.py; unstable_m 0: the same day)
    flight = another_day(geo, np.random.default_rng(seed + 1), unstable_m, texture_keep, relief_level, shift_m,
                         shift_corr_m)
    world = World(ground=flight, surface="map", wind=Wind(SteadyWind(0.0, 0.0)))
    ref = degrade_reference(geo, geo.resolution_m, 0.85, 20.0, 1.15, 0.3)
    kw = {"scale_search": 0.06, "rot_step_deg": 0.75, **registration_kw}
    gr = GeoRegistration(ref, cam, hough=hough, **kw)
    h, w = reg.score.shape
    ne = np.column_stack([reg.north0 - rng.uniform(0, h - 1, n) * reg.cell_m,
                          reg.east0 + rng.uniform(0, w - 1, n) * reg.cell_m])
    scores = reg.at(ne)
    err = np.full(n, np.inf)
    dpsi = np.zeros(n)
    applied = np.zeros(n, bool)
    quality = np.full(n, np.nan)
    for i, p in enumerate(ne):
        psi = rng.uniform(-math.pi, math.pi)
        img = ren.render(np.array([p[0], p[1], -reg.altitude_m]), nadir_dcm(psi), world)
        dpsi[i] = math.radians(rng.uniform(-1, 1) * heading_error_deg)
        g = gr.register(img, reg.altitude_m, psi + dpsi[i], p + rng.normal(0.0, gps_error_m / math.sqrt(2), 2),
                        [cam.cx, cam.cy])
        applied[i] = bool(g.alignment is not None and g.alignment.applied)
        if g.ok:
            err[i], quality[i] = float(np.linalg.norm(g.target_ne - p)), g.quality
    fails = err > fail_m
    lo = scores <= np.nanmedian(scores)
    edges = np.nanquantile(scores, np.linspace(0, 1, quantiles + 1))
    qi = np.clip(np.searchsorted(edges, scores, side="right") - 1, 0, quantiles - 1)
    return {"positions": ne, "scores": scores, "failed": fails, "error_m": err, "heading_error": dpsi,
            "hough_applied": applied, "quality": quality,
            "fail_rate_low": float(fails[lo].mean()) if lo.any() else math.nan,
            "fail_rate_high": float(fails[~lo].mean()) if (~lo).any() else math.nan,
            "fail_rate_quantile": [float(fails[qi == k].mean()) if (qi == k).any() else math.nan
                                   for k in range(quantiles)],
            "score_quantile_edges": [float(v) for v in edges],
            "score_median": float(np.nanmedian(scores))}
