"""The CONDOR vision chain of seed 004 ch. 3 in one object: measured pixel -> distortion table ->
roll -> tilt -> pan -> range and bearing (``thesis`` or ``exact`` flavour, see rectification.py)."""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.camera import PinholeCamera
from visnav.vision.distortion_lut import DistortionLUT, full_lut, synthetic_board, thesis_lut
from visnav.vision.rectification import CameraGeometry, RangeEstimate, altimeter_correction, estimate_range


class VisionRange:
    def __init__(self, camera: PinholeCamera, nominal_hfov: float, method: str = "exact", lut: str = "full",
                 board_distance_m: float = 2.0, board_spacing_m: float = 0.04) -> None:
        """``camera`` is the real lens (what the calibration board is photographed with);
        ``nominal_hfov`` [rad] the full horizontal FOV coded into the processing (§2.4)."""
        w, h = camera.width, camera.height
        half_h = nominal_hfov / 2.0
        half_v = math.atan(math.tan(half_h) * h / w)  # square pixels
        self.geom = CameraGeometry(w, h, half_h, half_v)
        self.method = method
        self.lut: DistortionLUT | None = None
        if lut != "none":
            board = synthetic_board(camera, board_distance_m, board_spacing_m)
            self.lut = full_lut(board, self.geom) if lut == "full" else thesis_lut(board, self.geom)

    def correct(self, Xm: float, Ym: float) -> tuple[float, float]:
        if self.lut is None:
            return Xm, Ym
        x, y = self.lut.correct(np.array([Xm]), np.array([Ym]))
        return float(x[0]), float(y[0])

    def estimate(self, Xm: float, Ym: float, h_bar: float, tilt: float, roll: float,
                 t_outside_c: float | None = None, c0: float = 0.004, c1: float = 0.00005) -> RangeEstimate:
        """Range from a measured pixel (from the image centre, Y up), raw baro height (temperature
        corrected by eq. 2.1 when ``t_outside_c`` is given), camera tilt and roll."""
        if not (math.isfinite(Xm) and math.isfinite(Ym)):
            return RangeEstimate(False, reason="no estimate: no target pixel")
        h = h_bar if t_outside_c is None else altimeter_correction(h_bar, t_outside_c, c0, c1)
        X, Y = self.correct(Xm, Ym)
        return estimate_range(X, Y, h, tilt, roll, self.geom, self.method)
