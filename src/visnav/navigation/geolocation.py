"""Ground-target geo-location navigator (seed 002 ch. 7): telemetry + frames in, target estimates out.

``update(measurement)`` takes the typed measurements of ``visnav/measurements.py``:

* ``TelemetrySample`` (5 Hz): kept in a short buffer; a frame is processed once the telemetry
  sample after it has arrived, with the telemetry recorded with it (``telemetry_sync="hold"``: the last
  sample that had arrived at the frame's time, as the thesis' ground station recorded "camera images and
  corresponding telemetry" simultaneously, §7.4.3) or with position, heading and height interpolated to
  the frame's time (``"interpolate"``: a better synchronisation than the thesis had);
* ``OperatorClick``: the operator selected the target in the frame of that time; the template
  tracker starts on it (§7.3: "identified and the tracker initialized manually");
* ``Frame``: tracked; when the target is found the frame is registered to the reference
  (``vision/geolocation_registration.py``) and the target's coordinates read off it (one
  *registration sample*), and the map-based ray (Fig. 7.2) gives a *map-based sample* from the same
  telemetry; each feeds its own recursive least squares (``estimation/rls.py``).

``estimate(t)`` returns the registration estimate (``estimate(t, "map_based")`` the other),
``health(t)`` the counts. The navigator never sees truth; ``samples`` keeps every sample for the log.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from visnav.estimation.rls import RecursiveLeastSquares
from visnav.measurements import Frame, Health, NavInit, OperatorClick, TargetEstimate, TelemetrySample
from visnav.navigation.base import CommandDispatch
from visnav.vision.geolocation_registration import GeoRegistration, map_based_target
from visnav.vision.template_tracker import RotatingTemplateTracker

__all__ = ["GeolocationNavigator"]


def _interp_angle(a0: float, a1: float, w: float) -> float:
    d = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
    return (a0 + w * d + math.pi) % (2 * math.pi) - math.pi


class GeolocationNavigator(CommandDispatch):
    """Target geo-location (seed 002 ch. 7) behind the common navigator protocol (``navigation/base``): the target's
    (north, east) from frames registered to a geo-referenced image, fused by RLS, against the map-based ray."""

    def __init__(self, reference, camera, *, hough: bool = True, median_px: int = 5, search_radius_m: float = 25.0,
                 min_quality: float = 0.05, registration_sigma_m: float = 1.5, map_sigma_m: float = 10.0,
                 gate_prob: float | None = 0.999, tracker_min_score: float = 0.75,
                 process_size=(360, 288), check_rotation: bool = False,
                 scale_search: float = 0.0, rotation_refine_deg: float = 0.0, quality_ref: float = 0.5,
                 rotation_search_deg: float = 0.0, rotation_search_step_deg: float = 7.5,
                 telemetry_sync: str = "interpolate") -> None:
        if telemetry_sync not in ("hold", "interpolate"):
            raise ValueError(f"telemetry_sync must be 'hold' or 'interpolate', not {telemetry_sync!r}")
        self.sync = telemetry_sync
        self.camera = camera
        self.registration = GeoRegistration(reference, camera, process_size=process_size, median_px=median_px,
                                            search_radius_m=search_radius_m, hough=hough,
                                            check_rotation=check_rotation, scale_search=scale_search,
                                            rot_step_deg=rotation_refine_deg,
                                            rotation_search_deg=rotation_search_deg,
                                            rotation_search_step_deg=rotation_search_step_deg)
        self.tracker = RotatingTemplateTracker(min_score=tracker_min_score)
        self.min_quality, self.quality_ref = float(min_quality), float(quality_ref)
        self.R_reg = registration_sigma_m ** 2 * np.eye(2)
        self.R_map = map_sigma_m ** 2 * np.eye(2)
        self.rls = {"registration": RecursiveLeastSquares(2, gate_prob=gate_prob),
                    "map_based": RecursiveLeastSquares(2, gate_prob=gate_prob)}
        self.telemetry: deque[TelemetrySample] = deque(maxlen=50)
        self.pending: deque[Frame] = deque(maxlen=20)
        self.click: OperatorClick | None = None
        self.samples: list[dict] = []
        self.frames_seen = self.frames_tracked = self.registrations = self.registered = 0
        self.notes: list[str] = []
        self._t = 0.0

    # ------------------------------------------------------------------ input
    def update(self, m) -> None:
        self._t = max(self._t, m.t)
        if isinstance(m, TelemetrySample):
            self.telemetry.append(m)
            while self.pending and self.pending[0].t <= m.t:
                self._process(self.pending.popleft())
        elif isinstance(m, OperatorClick):
            self.click = m
        elif isinstance(m, Frame):
            self.pending.append(m)
        else:
            raise TypeError(f"GeolocationNavigator cannot use {type(m).__name__}")

    def initialize(self, init: NavInit) -> None:
        """An operator reset: both estimates restart from no sample (the target's position is what this
        navigator estimates, so an initial pose of the vehicle has nothing to set)."""
        self._cmd_restart(init.t)

    def _cmd_restart(self, t: float) -> None:
        """Forget the fused samples (both RLS estimates); the tracker keeps its target."""
        for r in self.rls.values():
            r.reset()
        self.notes.append(f"restarted at t={t:.2f} s")

    def _cmd_track(self, t: float, pixel) -> None:
        """Designate the target at ``pixel`` in the frame at ``t`` (what an ``OperatorClick`` does)."""
        self.update(OperatorClick(t, np.asarray(pixel, float)))

    def _telemetry_at(self, t: float) -> TelemetrySample | None:
        tel = list(self.telemetry)
        if self.sync == "hold":  # the sample the ground station had at the frame's time (zero-order hold)
            before = [a for a in tel if a.t <= t + 1e-9]  # a sample arriving with the frame counts as had
            return before[-1] if before and tel[-1].t >= t else None
        for a, b in zip(tel[:-1], tel[1:]):
            if a.t <= t <= b.t:
                w = 0.0 if b.t == a.t else (t - a.t) / (b.t - a.t)
                return TelemetrySample(t, a.position + w * (b.position - a.position),
                                       _interp_angle(a.heading, b.heading, w), a.height + w * (b.height - a.height),
                                       a.ground_speed + w * (b.ground_speed - a.ground_speed))
        return None

    def _process(self, frame: Frame) -> None:
        tel = self._telemetry_at(frame.t)
        if tel is None:
            return
        self.frames_seen += 1
        if not self.tracker.started:
            if self.click is None or abs(self.click.t - frame.t) > 1e-6:
                return
            self.tracker.start(frame.image, self.click.pixel, tel.heading)
        tr = self.tracker.track(frame.image, tel.heading)
        if not tr.ok:
            return
        self.frames_tracked += 1
        g = self.registration.register(frame.image, tel.height, tel.heading, tel.position[:2], tr.uv)
        self.registrations += 1
        self.registered += int(g.ok)
        mb = map_based_target(self.camera, tr.uv, tel.position[:2], tel.height, tel.heading)
        s = {"t": frame.t, "uv": tr.uv, "track_score": tr.score, "ok": g.ok, "reason": g.reason,
             "reg": g.target_ne if g.ok else np.full(2, np.nan), "map": mb, "peak": g.peak,
             "second": g.second_peak, "sharpness": g.sharpness, "quality": g.quality,
             "heading_tel": tel.heading, "heading_used": g.heading_used, "height_used": g.height_used,
             "hough_applied": bool(g.alignment is not None and g.alignment.applied),
             "gps": tel.position[:2].copy(), "height": tel.height}
        # a look-alike place (second peak close to the first: a straight road, crop rows) makes a sample
        # less certain: its variance grows as (quality_ref / quality)^2, at most 25-fold
        w = float(np.clip(g.quality / self.quality_ref, 0.2, 1.0)) if g.ok else 0.0
        s["reg_used"] = bool(g.ok and g.quality >= self.min_quality
                             and self.rls["registration"].update(g.target_ne, R=self.R_reg / (w * w)))
        s["map_used"] = bool(np.all(np.isfinite(mb)) and self.rls["map_based"].update(mb, R=self.R_map))
        s["est_reg"] = self._x("registration")
        s["est_map"] = self._x("map_based")
        self.samples.append(s)

    def _x(self, method: str) -> np.ndarray:
        r = self.rls[method]
        return r.x.copy() if r.initialized else np.full(2, np.nan)

    # ------------------------------------------------------------------ output
    def estimate(self, t: float, method: str = "registration") -> TargetEstimate:
        r = self.rls[method]
        return TargetEstimate(t=t, position=self._x(method), covariance=r.covariance(), samples=r.accepted,
                              valid=r.initialized, method=method)

    def health(self, t: float) -> Health:
        r = self.rls["registration"]
        return Health(source="registration", tracking=self.tracker.started, rejected_samples=r.rejected,
                      reinitializations=r.reinits,
                      notes=[f"frames {self.frames_seen}, tracked {self.frames_tracked}, "
                             f"registered {self.registrations}, accepted {r.accepted}"])
