"""Geo-referenced ground rasters (north-up, square pixels) in the local NED tangent plane.

A :class:`GeoImage` is the texture of the flat ground plane z = 0 that the camera renderer
warps into frames (DESIGN.md section 5) and that map-registration algorithms (seed 002,
eq. 5.14-5.15) correlate against. Pixel convention: (col, row), column grows east, row grows
south; (north0, east0) is the NED position of the *centre* of the top-left pixel.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import json
import tempfile
from visnav.geometry.frames import LocalTangentPlane

__all__ = ["GeoImage", "degrade_reference"]

_WORLD_FILE_SUFFIXES = {
    ".png": (".pgw", ".pngw"),
    ".jpg": (".jgw", ".jpgw"),
    ".jpeg": (".jgw", ".jpegw"),
    ".tif": (".tfw", ".tifw"),
    ".tiff": (".tfw", ".tiffw"),
}


def _as_points(x, name: str) -> tuple[np.ndarray, tuple[int, ...]]:
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 or a.shape[-1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got shape {a.shape}")
    return a.reshape(-1, 2), a.shape[:-1]


def _geodetic_to_ne(lat_deg, lon_deg, origin: tuple[float, float]) -> np.ndarray:
    """North, east [m] of geodetic points (h = 0) in the tangent plane at ``origin``."""
    ned = np.asarray(LocalTangentPlane(origin[0], origin[1], 0.0).geodetic_to_ned(lat_deg, lon_deg, 0.0), dtype=float)
    return ned[..., :2]


class GeoImage:
    """North-up grayscale raster on the ground plane, with a lazily built image pyramid.

    Pyramid level ``L`` has resolution ``resolution_m * 2**L``. Its pixel (c, r) is centred at
    level-0 pixel (c 2^L + (2^L - 1)/2, r 2^L + (2^L - 1)/2): each level averages 2x2 blocks.
    ``cv2.pyrDown`` samples the even pixels (a quarter-pixel shift per level), so each level
    is first shifted by half a pixel (a 2x2 box average, anchor at the top-left) and then
    reduced with ``cv2.pyrDown``: together a 6-tap binomial [1 5 10 10 5 1]/32 low-pass,
    centred between the two pixels it merges.
    """

    def __init__(
        self,
        image: np.ndarray,
        north0: float,
        east0: float,
        resolution_m: float,
        name: str = "",
    ) -> None:
        img = np.asarray(image)
        if img.ndim != 2:
            raise ValueError(f"image must be a 2-D grayscale array, got shape {img.shape}")
        if img.shape[0] < 1 or img.shape[1] < 1:
            raise ValueError(f"image must not be empty, got shape {img.shape}")
        if img.dtype != np.uint8:
            if not (np.issubdtype(img.dtype, np.number) or img.dtype == bool):
                raise ValueError(f"image must be uint8 or numeric, got dtype {img.dtype}")
            f = img.astype(float)
            if not np.all(np.isfinite(f)) or f.min() < 0 or f.max() > 255:
                raise ValueError(
                    f"image of dtype {img.dtype} must hold finite values in [0, 255], "
                    f"got range [{np.nanmin(f)}, {np.nanmax(f)}]"
                )
            img = np.rint(f).astype(np.uint8)
        res = float(resolution_m)
        if not (math.isfinite(res) and res > 0):
            raise ValueError(f"resolution_m must be positive and finite, got {resolution_m}")
        for nm, v in (("north0", north0), ("east0", east0)):
            if not math.isfinite(float(v)):
                raise ValueError(f"{nm} must be finite, got {v}")
        self.image = np.ascontiguousarray(img)
        self.north0 = float(north0)
        self.east0 = float(east0)
        self.resolution_m = res
        self.name = name
        self.origin_geodetic: tuple[float, float] | None = None
        self._levels: list[np.ndarray] = [self.image]

    def __repr__(self) -> str:
        h, w = self.shape
        return (
            f"GeoImage(name={self.name!r}, shape=({h}, {w}), north0={self.north0:.3f}, "
            f"east0={self.east0:.3f}, resolution_m={self.resolution_m:g})"
        )

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of level 0."""
        return self.image.shape  # type: ignore[return-value]

    def extent_ned(self) -> tuple[float, float, float, float]:
        """(n_min, n_max, e_min, e_max) of the outer pixel edges [m]."""
        h, w = self.shape
        r = self.resolution_m
        return (
            self.north0 - (h - 0.5) * r,
            self.north0 + 0.5 * r,
            self.east0 - 0.5 * r,
            self.east0 + (w - 0.5) * r,
        )

    def ned_to_pixel(self, ne) -> np.ndarray:
        """(N, 2) north, east [m] -> (N, 2) level-0 (col, row), float."""
        p, lead = _as_points(ne, "ne")
        col = (p[:, 1] - self.east0) / self.resolution_m
        row = (self.north0 - p[:, 0]) / self.resolution_m
        return np.stack([col, row], axis=-1).reshape(*lead, 2)

    def pixel_to_ned(self, colrow) -> np.ndarray:
        """(N, 2) level-0 (col, row) -> (N, 2) north, east [m]."""
        p, lead = _as_points(colrow, "colrow")
        north = self.north0 - p[:, 1] * self.resolution_m
        east = self.east0 + p[:, 0] * self.resolution_m
        return np.stack([north, east], axis=-1).reshape(*lead, 2)

    def affine(self, level: int = 0) -> np.ndarray:
        """(3, 3) matrix taking [col, row, 1] of pyramid ``level`` to [north, east, 1]."""
        lv = self._check_level(level)
        s = 2.0**lv
        r = self.resolution_m
        off = 0.5 * (s - 1.0) * r  # level-L pixel 0 is centred at level-0 pixel (s-1)/2
        return np.array(
            [
                [0.0, -r * s, self.north0 - off],
                [r * s, 0.0, self.east0 + off],
                [0.0, 0.0, 1.0],
            ]
        )

    # ------------------------------------------------------------------ pyramid
    @property
    def max_level(self) -> int:
        """Coarsest pyramid level (its smaller side is still >= 1 px)."""
        return max(0, int(math.floor(math.log2(min(self.shape)))))

    def _check_level(self, level) -> int:
        if isinstance(level, bool) or not isinstance(level, (int, np.integer)):
            raise ValueError(f"level must be an int, got {level!r}")
        if not 0 <= int(level) <= self.max_level:
            raise ValueError(f"level must be in [0, {self.max_level}], got {level}")
        return int(level)

    def level(self, level: int) -> np.ndarray:
        """uint8 image of pyramid ``level`` (built on first use, then cached)."""
        lv = self._check_level(level)
        while len(self._levels) <= lv:
            prev = self._levels[-1].astype(np.float32)
            # half-pixel shift: dst(x, y) = mean of src over (x..x+1, y..y+1)
            shifted = cv2.blur(prev, (2, 2), anchor=(0, 0), borderType=cv2.BORDER_REPLICATE)
            down = cv2.pyrDown(shifted, borderType=cv2.BORDER_REPLICATE)
            self._levels.append(np.clip(np.rint(down), 0, 255).astype(np.uint8))
        return self._levels[lv]

    def level_resolution(self, level: int) -> float:
        """Ground resolution of pyramid ``level`` [m/px]."""
        return self.resolution_m * 2.0 ** self._check_level(level)

    def level_for_gsd(self, gsd_m: float) -> int:
        """Coarsest level whose resolution is still <= ``gsd_m`` (no aliasing); 0 if finer."""
        g = float(gsd_m)
        if not (math.isfinite(g) and g > 0):
            raise ValueError(f"gsd_m must be positive and finite, got {gsd_m}")
        lv = int(math.floor(math.log2(g / self.resolution_m) + 1e-9))
        return min(max(lv, 0), self.max_level)

    # ------------------------------------------------------------------ pixels
    def crop(self, n_center: float, e_center: float, size_m: float) -> GeoImage:
        """Square window of about ``size_m`` side around (n_center, e_center), clipped to the map.

        The window snaps to whole pixels, so the crop's pixels are the map's pixels.
        """
        s = float(size_m)
        if not (math.isfinite(s) and s > 0):
            raise ValueError(f"size_m must be positive and finite, got {size_m}")
        (c, r), = self.ned_to_pixel([[n_center, e_center]])
        npx = max(1, int(round(s / self.resolution_m)))
        c0 = int(math.floor(c - (npx - 1) / 2.0 + 0.5))
        r0 = int(math.floor(r - (npx - 1) / 2.0 + 0.5))
        h, w = self.shape
        c1, r1 = min(c0 + npx, w), min(r0 + npx, h)
        c0, r0 = max(c0, 0), max(r0, 0)
        if c1 <= c0 or r1 <= r0:
            raise ValueError(
                f"crop centre ({n_center}, {e_center}) with size_m={size_m} lies outside the "
                f"map extent {self.extent_ned()}"
            )
        (n0, e0), = self.pixel_to_ned([[c0, r0]])
        out = GeoImage(self.image[r0:r1, c0:c1].copy(), n0, e0, self.resolution_m, self.name)
        out.origin_geodetic = self.origin_geodetic
        return out

    def sample(self, ne) -> np.ndarray:
        """Bilinear intensities at (N, 2) north, east [m]; NaN outside :meth:`extent_ned`.

        Inside the extent but beyond the outermost pixel centres the edge pixel is repeated.
        """
        p, lead = _as_points(ne, "ne")
        cr = self.ned_to_pixel(p)
        h, w = self.shape
        col, row = cr[:, 0], cr[:, 1]
        inside = (col >= -0.5) & (col <= w - 0.5) & (row >= -0.5) & (row <= h - 0.5)
        col = np.clip(np.nan_to_num(col), 0.0, w - 1.0)
        row = np.clip(np.nan_to_num(row), 0.0, h - 1.0)
        c0 = np.minimum(np.floor(col).astype(np.intp), max(w - 2, 0))
        r0 = np.minimum(np.floor(row).astype(np.intp), max(h - 2, 0))
        c1 = np.minimum(c0 + 1, w - 1)
        r1 = np.minimum(r0 + 1, h - 1)
        fc, fr = col - c0, row - r0
        img = self.image
        top = img[r0, c0] * (1 - fc) + img[r0, c1] * fc
        bot = img[r1, c0] * (1 - fc) + img[r1, c1] * fc
        val = top * (1 - fr) + bot * fr
        return np.where(inside, val, np.nan).reshape(lead)

    # ------------------------------------------------------------------ files
    @classmethod
    def load(
        cls,
        path: str | Path,
        world_file: str | Path | None = None,
        origin: tuple[float, float] | None = None,
    ) -> GeoImage:
        """Read a PNG/JPEG (as grayscale) and its ESRI world file in EPSG:4326 degrees.

        World-file lines: pixel width [deg lon], 0, 0, -pixel height [deg lat], lon and lat of
        the centre of the top-left pixel. ``world_file`` defaults to the .pgw/.jgw/.wld beside
        the image. Positions go to the NED tangent plane at ``origin`` = (lat0_deg, lon0_deg)
        (default: the image centre) on WGS84; the pixel size in metres is taken at the map
        centre. Because a degree of longitude is shorter than a degree of latitude, the east
        and north resolutions differ: the raster is resampled (``cv2.resize``, columns only)
        to square pixels at the north resolution, which moves the east edge by at most half a
        pixel. The map stays aligned with the geodetic grid, not with NED (meridian
        convergence: ~3 cm over 500 m at 60 deg latitude).
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"map image not found: {path}")
        if path.suffix.lower() in (".tif", ".tiff") and world_file is None:
            return _load_geotiff(cls, path, origin)
        if world_file is None:
            suffixes = _WORLD_FILE_SUFFIXES.get(path.suffix.lower(), ()) + (".wld",)
            candidates = [path.with_suffix(s) for s in suffixes]
            found = [c for c in candidates if c.is_file()]
            if not found:
                tried = ", ".join(str(c) for c in candidates)
                raise FileNotFoundError(f"world file for {path} not found (tried {tried})")
            world_file = found[0]
        world_file = Path(world_file)
        if not world_file.is_file():
            raise FileNotFoundError(f"world file not found: {world_file}")
        image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise ValueError(f"cannot decode image file (corrupt or unsupported format): {path}")
        a, d, b, e, c, f = _read_world_file(world_file)
        h, w = image.shape
        crs = _check_sidecar(path, world_file, (a, e, c, f), (h, w))
        if crs == "projected":
            return _projected(cls, image, path, (a, e, c, f))
        lat_c = f + e * (h - 1) / 2.0
        lon_c = c + a * (w - 1) / 2.0
        if origin is None:
            origin = (lat_c, lon_c)
        else:
            if len(origin) != 2 or not all(math.isfinite(float(v)) for v in origin):
                raise ValueError(f"origin must be (lat0_deg, lon0_deg), got {origin!r}")
            origin = (float(origin[0]), float(origin[1]))
        # metres per pixel at the map centre, by central differences
        ne = _geodetic_to_ne(
            np.array([lat_c - e / 2, lat_c + e / 2, lat_c, lat_c]),
            np.array([lon_c, lon_c, lon_c - a / 2, lon_c + a / 2]),
            (lat_c, lon_c),
        )
        res_n = float(ne[0, 0] - ne[1, 0])
        res_e = float(ne[3, 1] - ne[2, 1])
        (n_tl, e_tl), = _geodetic_to_ne(np.array([f]), np.array([c]), origin)
        w_sq = max(1, int(round(w * res_e / res_n)))
        if w_sq != w:
            interp = cv2.INTER_AREA if w_sq < w else cv2.INTER_LINEAR
            image = cv2.resize(image, (w_sq, h), interpolation=interp)
        east0 = float(e_tl) - res_e / 2.0 + res_n / 2.0  # keep the west edge
        out = cls(image, float(n_tl), east0, res_n, name=path.stem)
        out.origin_geodetic = (float(origin[0]), float(origin[1]))
        return out


def _read_world_file(path: Path) -> tuple[float, ...]:
    """The six numbers of an ESRI world file; ValueError names the path and the line."""
    lines = [ln.strip() for ln in path.read_text(errors="replace").splitlines()]
    numbered = [(i + 1, ln) for i, ln in enumerate(lines) if ln]
    if len(numbered) != 6:
        raise ValueError(
            f"malformed world file {path}: expected 6 numbers (one per line), "
            f"found {len(numbered)} non-empty lines"
        )
    vals = []
    for lineno, ln in numbered:
        try:
            v = float(ln)
        except ValueError:
            raise ValueError(f"malformed world file {path}, line {lineno}: {ln!r} is not a number")
        if not math.isfinite(v):
            raise ValueError(f"malformed world file {path}, line {lineno}: {ln!r} is not finite")
        vals.append(v)
    a, d, b, e, c, f = vals
    for (lineno, _), v in zip(numbered[1:3], (d, b)):
        if v != 0.0:
            raise ValueError(
                f"malformed world file {path}, line {lineno}: rotation term {v!r} must be 0 "
                "(only north-up maps are supported)"
            )
    if not a > 0:
        raise ValueError(f"malformed world file {path}, line {numbered[0][0]}: pixel width {a!r} must be > 0")
    if not e < 0:
        raise ValueError(
            f"malformed world file {path}, line {numbered[3][0]}: pixel height {e!r} must be < 0 (north-up)"
        )
    return a, d, b, e, c, f


def _is_geodetic(a: float, e: float, c: float, f: float) -> bool:
    """A world file in degrees (EPSG:4326) rather than metres of a projected CRS."""
    return abs(a) < 0.01 and abs(e) < 0.01 and abs(c) <= 180.0 and abs(f) <= 90.0


def _check_sidecar(path: Path, world_file: Path, wf: tuple, shape: tuple[int, int]) -> str:
    """'geodetic' or 'projected'; a ``.json`` sidecar (width_px, height_px, crs, bounds) must agree
    with the image and the world file, and a geodetic extent must stay on the globe."""
    a, e, c, f = wf
    h, w = shape
    crs = "geodetic" if _is_geodetic(a, e, c, f) else "projected"
    side = path.with_suffix(".json")
    if side.is_file():
        try:
            meta = json.loads(side.read_text())
        except ValueError as exc:
            raise ValueError(f"map sidecar {side} is not valid JSON: {exc}") from None
        mw, mh = meta.get("width_px"), meta.get("height_px")
        if (mw is not None and int(mw) != w) or (mh is not None and int(mh) != h):
            raise ValueError(f"world file {world_file} / sidecar {side} describe a {mw}x{mh} px image but "
                             f"{path} is {w}x{h} px: the world file does not match its image")
        if "east_lon" in meta and crs == "geodetic":
            east = c + a * (w - 0.5)
            if abs(east - float(meta["east_lon"])) > 2 * a:
                raise ValueError(f"world file {world_file} puts the east edge at {east:.6f} deg but {side} says "
                                 f"{meta['east_lon']}: the world file does not match the image size {w}x{h}")
        if str(meta.get("crs", "")).upper() not in ("", "EPSG:4326"):
            crs = "projected"
    if crs == "geodetic":
        south, east = f + e * (h - 0.5), c + a * (w - 0.5)
        if south < -90.0 or east > 180.0:
            raise ValueError(f"world file {world_file} with a {w}x{h} px image reaches lat {south:.3f}, "
                             f"lon {east:.3f}: the world file does not match its image size")
    return crs


def _projected(cls, image: np.ndarray, path: Path, wf: tuple) -> GeoImage:
    """A world file in metres (projected CRS, x east, y north): the NED origin is the map centre."""
    a, e, c, f = wf
    h, w = image.shape
    res_n, res_e = -e, a
    w_sq = max(1, int(round(w * res_e / res_n)))
    if w_sq != w:
        image = cv2.resize(image, (w_sq, h), interpolation=cv2.INTER_AREA if w_sq < w else cv2.INTER_LINEAR)
    xc, yc = c + a * (w - 1) / 2.0, f + e * (h - 1) / 2.0
    return cls(image, f - yc, c - xc - res_e / 2.0 + res_n / 2.0, res_n, name=path.stem)


def _load_geotiff(cls, path: Path, origin) -> GeoImage:
    """GeoTIFF through rasterio (optional extra): north-up, EPSG:4326 or projected."""
    try:
        import rasterio
    except ImportError:
        raise ValueError(f"{path}: reading GeoTIFF needs rasterio (pip install rasterio), "
                         "or give a PNG/JPEG with a world file") from None

    with rasterio.open(path) as src:
        band = src.read(1)
        tr = src.transform
        if tr.b != 0 or tr.d != 0:
            raise ValueError(f"{path}: only north-up GeoTIFFs are supported")
        img = cv2.normalize(band.astype(np.float32), None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / (path.stem + ".png")
        cv2.imwrite(str(png), img)
        png.with_suffix(".pgw").write_text(
            f"{tr.a}\n0\n0\n{tr.e}\n{tr.c + tr.a / 2}\n{tr.f + tr.e / 2}\n")
        return cls.load(png, origin=origin)


def degrade_reference(geo: GeoImage, resolution_m: float = 1.0, gain: float = 0.8, offset: float = 25.0,
                      gamma: float = 1.2, blur_m: float = 1.0) -> GeoImage:
    """The navigator's reference map: the same ground seen by another sensor on another day.

    Resampled to ``resolution_m`` over the same extent (anti-aliased, exact geometry: the new pixel
    centres are placed with an affine warp), blurred by a Gaussian of ``blur_m``, and re-mapped in
    brightness and contrast: I' = 255 (I/255)^gamma * gain + offset.
    """
    R = float(resolution_m)
    if not (math.isfinite(R) and R >= geo.resolution_m):
        raise ValueError(f"resolution_m must be >= the map's {geo.resolution_m} m, got {resolution_m}")
    r = geo.resolution_m
    k = R / r
    img = geo.image.astype(np.float32)
    sigma = math.hypot(0.5 * k if k > 1 else 0.0, blur_m / r)
    if sigma > 0.1:
        img = cv2.GaussianBlur(img, (0, 0), sigma)
    h, w = geo.shape
    H, W = max(1, int(math.floor(h / k))), max(1, int(math.floor(w / k)))
    # dst pixel (c', r') centre -> src (c, r) = ((c' + 0.5) k - 0.5, ...)
    M = np.array([[k, 0.0, 0.5 * k - 0.5], [0.0, k, 0.5 * k - 0.5]], np.float32)
    small = cv2.warpAffine(img, M, (W, H), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                           borderMode=cv2.BORDER_REPLICATE)
    out = 255.0 * (np.clip(small, 0, 255) / 255.0) ** gamma * gain + offset
    north0 = geo.north0 + 0.5 * r - 0.5 * R
    east0 = geo.east0 - 0.5 * r + 0.5 * R
    ref = GeoImage(np.clip(np.rint(out), 0, 255).astype(np.uint8), north0, east0, R, name=geo.name + "-reference")
    ref.origin_geodetic = geo.origin_geodetic
    return ref
