"""Landing-field ground textures built from scikit-image's real texture photographs.

PALACE flew over grass, asphalt and concrete (seed 000, Table 4.1, Fig. 4.4). The default
world needs no external data: :func:`landing_field` tiles a real photograph
(``skimage.data.grass``, ``gravel`` standing in for asphalt, ``brick`` for concrete) into a
large, non-periodic field, and :func:`detail_tile` gives the same photograph at millimetre
scale as a periodic high-pass layer for low-altitude rendering.

Scale. Each 512 px photograph is laid out over ``photo_span_m`` = 2.5 m of ground (~5 mm per
photo pixel). Physically the photos show ~0.5-1 m of ground, but at the 2 cm map resolution
that would leave almost nothing (grass blades, pebbles) above the Nyquist limit; at 2.5 m
the stones, tufts and joints are 5-20 cm wide, i.e. 2-10 map pixels, the scale a 640 px
camera resolves between 6 m and 40 m AGL (PALACE flew 6-30 m). Finer detail for the last
metres comes from :func:`detail_tile` at the photo's own scale.

Non-periodic tiling (all vectorised, no per-pixel Python): four layers of square cells of
side 0.75 ``photo_span_m``, staggered by half a cell in north and/or east. Each cell holds an
independent random crop of one of the eight 90-degree rotations/flips of the photo. A smooth
partition of unity gives every layer weight 0 on its own seams and 1 over the middle of its
cells; where layers overlap they are mixed with the variance-preserving blend of Heitz and
Neyret (2018, "High-performance by-example noise"), so contrast does not dip over the seams.
Finally a smooth multiplicative albedo/illumination field (blobs of ~3 m and ~12 m,
+-15 %) breaks the remaining self-similarity at high altitude.
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from visnav.world.maps import GeoImage

__all__ = ["SURFACES", "PHOTO_SPAN_M", "landing_field", "detail_tile"]

#: surface name -> scikit-image photograph
SURFACES: dict[str, str] = {
    "grass": "grass",
    "asphalt": "gravel",
    "gravel": "gravel",
    "concrete": "brick",
}
#: ground span of one 512 px photograph in :func:`landing_field` [m]
PHOTO_SPAN_M = 2.5
_ALBEDO_AMPLITUDE = 0.15
_MAX_SIDE_PX = 20000


@lru_cache(maxsize=None)
def _photo(surface: str) -> np.ndarray:
    """The photograph for ``surface`` as float32 (read-only, cached)."""
    if surface not in SURFACES:
        raise ValueError(f"surface must be one of {sorted(SURFACES)}, got {surface!r}")
    import skimage.data

    img = getattr(skimage.data, SURFACES[surface])().astype(np.float32)
    img.setflags(write=False)
    return img


def _check_positive(name: str, value) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return v


def _dihedral(img: np.ndarray) -> np.ndarray:
    """(8, n, n): the eight 90-degree rotations / flips of a square image."""
    rots = [np.rot90(img, k) for k in range(4)]
    return np.stack(rots + [r[:, ::-1] for r in rots])


def _ramp(x: np.ndarray, cell: int, feather: float) -> np.ndarray:
    """Weight (0..1) of a layer whose seams lie at multiples of ``cell``; smoothstep ramps.

    0 within cell/4 - feather/2 of a seam, 1 beyond cell/4 + feather/2; the complementary
    layer (seams shifted by cell/2) gets 1 - weight.
    """
    d = np.abs((x % cell) - cell / 2.0)  # distance from the cell middle
    d = cell / 2.0 - d  # distance to the nearest seam
    t = np.clip((d - (cell / 4.0 - feather / 2.0)) / feather, 0.0, 1.0)
    return (t * t * (3.0 - 2.0 * t)).astype(np.float32)


def _fill_layer(out: np.ndarray, bank: np.ndarray, cell: int, rng: np.random.Generator) -> None:
    """Fill ``out`` (rows, cols multiples of ``cell``) with cells of random crops of random
    dihedral variants of the photo (one loop step per row of cells, none per pixel)."""
    v, p, _ = bank.shape
    nr, nc = out.shape[0] // cell, out.shape[1] // cell
    variant = rng.integers(0, v, size=(nr, nc))
    oy = rng.integers(0, p - cell + 1, size=(nr, nc))
    ox = rng.integers(0, p - cell + 1, size=(nr, nc))
    windows = sliding_window_view(bank, (cell, cell), axis=(1, 2))  # (v, ., ., cell, cell)
    cells = out.reshape(nr, cell, nc, cell)
    for r in range(nr):
        cells[r] = windows[variant[r], oy[r], ox[r]].transpose(1, 0, 2)


def _albedo(n: int, res_m: float, rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
    """1 + smooth random field (blobs of ~12 m and ~3 m, weights 0.6 / 0.4), max |.| = 15 %."""
    size_m = n * res_m
    k_fine = max(4, int(math.ceil(size_m / 3.0)) + 3)
    k_big = max(4, int(math.ceil(size_m / 12.0)) + 3)
    fine = rng.standard_normal((k_fine, k_fine)).astype(np.float32)
    big = rng.standard_normal((k_big, k_big)).astype(np.float32)
    mid = 16 * k_fine  # intermediate grid, fine enough for cubic blobs
    f = cv2.resize(fine, (mid, mid), interpolation=cv2.INTER_CUBIC)
    b = cv2.resize(big, (mid, mid), interpolation=cv2.INTER_CUBIC)
    f /= f.std() + 1e-6
    b /= b.std() + 1e-6
    m = 0.6 * b + 0.4 * f
    m -= m.mean()
    m *= _ALBEDO_AMPLITUDE / max(float(np.abs(m).max()), 1e-6)
    m += 1.0
    return cv2.resize(m, (n, n), dst=out, interpolation=cv2.INTER_LINEAR)


def landing_field(
    surface: str,
    size_m: float = 80.0,
    resolution_m: float = 0.02,
    *,
    rng: np.random.Generator,
    center_ne: tuple[float, float] = (0.0, 0.0),
    photo_span_m: float = PHOTO_SPAN_M,
) -> GeoImage:
    """Square non-periodic ground texture of ``surface`` centred on ``center_ne`` [m].

    ``surface``: "grass", "asphalt" (or "gravel"), "concrete". Returns a uint8 GeoImage of
    round(size_m / resolution_m) px a side; intensities are mapped linearly so that the mean
    is 128 and the 0.05 % / 99.95 % quantiles stay inside [4, 251] (nearly nothing saturates).
    """
    if surface not in SURFACES:
        raise ValueError(f"surface must be one of {sorted(SURFACES)}, got {surface!r}")
    size = _check_positive("size_m", size_m)
    res = _check_positive("resolution_m", resolution_m)
    span = _check_positive("photo_span_m", photo_span_m)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    n = int(round(size / res))
    if not 16 <= n <= _MAX_SIDE_PX:
        raise ValueError(
            f"size_m / resolution_m must give 16..{_MAX_SIDE_PX} px, got {size_m}/{resolution_m} = {n}"
        )
    p = max(8, int(round(span / res)))  # photo side at field resolution
    if p % 4:
        p += 4 - p % 4
    photo = cv2.resize(np.asarray(_photo(surface)), (p, p), interpolation=cv2.INTER_AREA)
    mu = float(photo.mean())
    bank = _dihedral(photo - mu)
    cell = max(4, (3 * p // 4) // 2 * 2)
    half = cell // 2
    feather = max(4.0, cell / 8.0)
    x = np.arange(n, dtype=np.float32)
    # random global offset so that seams do not fall on fixed coordinates
    s0r, s0c = (int(v) for v in rng.integers(0, cell, size=2))
    w_r = [_ramp(x + s0r + d, cell, feather) for d in (0, half)]
    w_c = [_ramp(x + s0c + d, cell, feather) for d in (0, half)]
    acc = np.zeros((n, n), np.float32)
    buf = np.empty((n, n), np.float32)
    m_side = (n // cell + 2) * cell
    mosaic = np.empty((m_side, m_side), np.float32)
    for i, dr in enumerate((0, half)):
        for j, dc in enumerate((0, half)):
            _fill_layer(mosaic, bank, cell, rng)
            sr, sc = (s0r + dr) % cell, (s0c + dc) % cell  # seams where row + sr = k cell
            np.multiply(mosaic[sr:sr + n, sc:sc + n], w_c[j][None, :], out=buf)
            buf *= w_r[i][:, None]
            acc += buf
    del mosaic
    # variance-preserving blend: divide by sqrt(sum w^2), separable in rows and columns
    acc *= (1.0 / np.sqrt(w_r[0] ** 2 + w_r[1] ** 2))[:, None]
    acc *= (1.0 / np.sqrt(w_c[0] ** 2 + w_c[1] ** 2))[None, :]
    acc += mu
    acc *= _albedo(n, res, rng, out=buf)
    del buf
    step = max(1, n // 512)
    sub = acc[::step, ::step]
    m = float(sub.mean())
    lo, hi = np.quantile(sub, [0.0005, 0.9995])
    # mean -> 128, the 0.05 % / 99.95 % quantiles inside [4, 251]
    alpha = min(123.0 / max(hi - m, 1e-6), 124.0 / max(m - lo, 1e-6))
    img = cv2.convertScaleAbs(acc, alpha=alpha, beta=128.0 - alpha * m)
    cn, ce = (float(v) for v in center_ne)
    north0 = cn + (n - 1) / 2.0 * res
    east0 = ce - (n - 1) / 2.0 * res
    return GeoImage(img, north0, east0, res, name=f"{surface}_field")


def detail_tile(
    surface: str,
    resolution_m: float = 0.002,
    period_m: float = 1.0,
    *,
    rng: np.random.Generator,
    highpass_sigma_m: float = 0.05,
) -> tuple[np.ndarray, float]:
    """Periodic millimetre-detail tile of ``surface``: (uint8 tile, resolution_m).

    The photograph is scaled to ``period_m`` a side, made seamless under wrap-around (blended
    with itself rolled by half a period, variance-preserving), given a random rotation/flip
    and roll, then high-passed (minus a periodic Gaussian blur of ``highpass_sigma_m``, done
    in the Fourier domain) and offset to mean 128. Rendered with wrap-around over a coarse
    map (as ``coarse + tile - 128``) it adds detail at low altitude and averages out at high
    altitude.
    """
    if surface not in SURFACES:
        raise ValueError(f"surface must be one of {sorted(SURFACES)}, got {surface!r}")
    res = _check_positive("resolution_m", resolution_m)
    period = _check_positive("period_m", period_m)
    sigma = _check_positive("highpass_sigma_m", highpass_sigma_m)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    n = int(round(period / res))
    if not 16 <= n <= 8192:
        raise ValueError(
            f"period_m / resolution_m must give 16..8192 px, got {period_m}/{resolution_m} = {n}"
        )
    n += n % 2
    photo = np.asarray(_photo(surface))
    interp = cv2.INTER_AREA if n < photo.shape[0] else cv2.INTER_CUBIC
    img = cv2.resize(photo, (n, n), interpolation=interp)
    img = _dihedral(img)[rng.integers(0, 8)] - float(img.mean())
    # seamless under wrap-around: weight 0 on each copy's own wrap seam
    x = np.arange(n, dtype=np.float32)
    wa = _ramp(x, n, n / 4.0)
    acc = np.zeros((n, n), np.float32)
    norm = np.zeros((n, n), np.float32)
    for dr in (0, n // 2):
        for dc in (0, n // 2):
            w = np.outer(wa if dr == 0 else 1 - wa, wa if dc == 0 else 1 - wa)
            acc += w * np.roll(img, (dr, dc), axis=(0, 1))
            norm += w * w
    tile = acc / np.sqrt(norm)
    tile = np.roll(tile, tuple(int(v) for v in rng.integers(0, n, size=2)), axis=(0, 1))
    # periodic Gaussian high-pass: multiply the spectrum by 1 - exp(-(sigma k)^2 / 2)
    fy = np.fft.fftfreq(n, d=res)[:, None]
    fx = np.fft.rfftfreq(n, d=res)[None, :]
    k2 = (2 * np.pi) ** 2 * (fx**2 + fy**2)
    spec = np.fft.rfft2(tile) * (1.0 - np.exp(-0.5 * sigma**2 * k2))
    hp = np.fft.irfft2(spec, s=(n, n))
    out = np.clip(np.rint(hp + 128.0), 0, 255).astype(np.uint8)
    return out, res
