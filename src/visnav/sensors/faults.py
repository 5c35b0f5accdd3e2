"""Fault injection at the sensor side (issue #18): the loop and the navigators stay ignorant.

A scenario's ``[[faults]]`` list (``scenarios/config_integrity.FaultConfig``) is applied by wrapping the
sensors (``apply_faults``: each faulted sensor's ``sample`` / ``sample_async`` output is changed while
the fault is active, by the measurement's own time stamp ``t``), the world's wind (``GustyWind``) and,
at build time, the WITAS maps (``map_faults``). Kinds and what each changes (nothing else):

=================== ========== ==================================================================
kind                target     change while ``start_s <= t < start_s + duration_s``
=================== ========== ==================================================================
camera_blackout     camera     image all zeros (lens cap, lost video)
camera_frozen       camera     the image of the last frame before the fault, new time stamps
camera_brightness   camera     image * ``gain`` + ``offset_dn`` (clipped to 0..255)
camera_blur         camera     linear motion blur of ``blur_px`` pixels along ``blur_deg``
imu_gyro_bias       imu        gyro + ``bias`` [deg/s] (the attitude solution is the autopilot's: unchanged)
imu_accel_bias      imu        accelerometer + ``bias`` [m/s^2]
imu_drop            imu        the IMU message (rates, forces, attitude) lost with ``drop_probability``
                               (the deck's and CONDOR's IMU send rates and forces alone: that message)
clock_jump          ``sensor`` every time stamp of the stream + ``jump_s`` (the data unchanged)
range_dropout       ``sensor`` laser / sonar: no return (range NaN)
range_stuck         ``sensor`` laser / sonar: the range of the first sample in the fault, repeated
gps_spoof           gps        fix walks off at ``walk_mps`` towards ``walk_deg`` (velocity consistent);
                               with ``lost_after`` no fix from the end of the walk on
wind_gust           world      a (1 - cos) gust of ``speed_mps`` from ``from_deg`` over the window
map_offset          WITAS map  reference map shifted by ``offset_m`` (north, east) [build time]
feature_poor        WITAS map  a ``size_m`` area at ``centre_m`` of the world map replaced by still water
=================== ========== ==================================================================
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from visnav.measurements import AttitudeSample, Frame, GpsSample, ImuSample, RangeSample
from visnav.sensors.camera import PendingFrame
from visnav.world.maps import GeoImage

#: kind -> the sensor it targets by default (None: not a sensor fault)
TARGET = {"camera_blackout": "camera", "camera_frozen": "camera", "camera_brightness": "camera",
          "camera_blur": "camera", "imu_gyro_bias": "imu", "imu_accel_bias": "imu", "imu_drop": "imu",
          "clock_jump": "camera", "range_dropout": "laser", "range_stuck": "laser", "gps_spoof": "gps",
          "wind_gust": None, "map_offset": None, "feature_poor": None}


def target_of(fault) -> str | None:
    if fault.kind in ("clock_jump", "range_dropout", "range_stuck") and fault.sensor:
        return fault.sensor
    return TARGET[fault.kind]


def blur_kernel(length_px: int, angle_deg: float) -> np.ndarray:
    """Normalised linear motion-blur kernel (a line of ``length_px`` along ``angle_deg``)."""
    n = int(length_px) | 1
    k = np.zeros((n, n), np.float32)
    c = n // 2
    a = math.radians(angle_deg)
    dx, dy = math.cos(a), math.sin(a)
    for s in np.linspace(-(length_px - 1) / 2, (length_px - 1) / 2, 4 * n):
        k[int(round(c + s * dy)), int(round(c + s * dx))] = 1.0
    return k / k.sum()


class FaultySensor:
    """Wraps one sensor; every other attribute is the wrapped sensor's.

    A ``clock_jump`` moves the stamps, not the data's arrival: the measurement taken at ``t`` carries the stamp
    ``t + jump_s`` but reaches the navigator when the unjumped one would (``t + latency``), as a sensor whose own
    clock jumped would against the receiver's. ``latency_s`` is therefore the wrapped sensor's minus the jump of
    the sample just taken (the loop schedules a delivery at stamp + ``latency_s`` right after sampling)."""

    def __init__(self, inner, faults, rng: np.random.Generator):
        object.__setattr__(self, "_inner", inner)
        object.__setattr__(self, "_faults", list(faults))
        object.__setattr__(self, "_rng", rng)
        object.__setattr__(self, "_state", {})  # per-fault memory (frozen image, stuck range)
        object.__setattr__(self, "_jump", 0.0)  # the clock jump of the sample just taken [s]

    @property
    def latency_s(self) -> float:
        return self._inner.latency_s - self._jump

    def _clock_jump(self, t: float) -> float:
        jump = sum(f.jump_s for f in self._faults if f.kind == "clock_jump" and f.active(t))
        object.__setattr__(self, "_jump", jump)
        return jump

    def __getattr__(self, name):
        if name == "sample_async":  # only where the wrapped sensor renders (the loop asks ``hasattr``)
            getattr(self._inner, name)
            return self._sample_async
        return getattr(self._inner, name)

    def __setattr__(self, name, value):
        setattr(self._inner, name, value)

    # ------------------------------------------------------------------ sampling
    def sample(self, t, *args, **kwargs):
        out = self._inner.sample(t, *args, **kwargs)
        first = out[0] if isinstance(out, tuple) and out else out
        self._clock_jump(first.t if first is not None else t)
        return self.apply(out)

    def _sample_async(self, t, *args, **kwargs):
        pending = self._inner.sample_async(t, *args, **kwargs)
        self._clock_jump(pending.t if pending is not None else t)
        return _FaultyPending(pending, self) if pending is not None else None

    def apply(self, out):
        """The fault(s) applied to one ``sample`` output (a measurement, a tuple of them, or None)."""
        if out is None:
            return None
        if isinstance(out, tuple):
            ms = list(out)
            t = next((m.t for m in ms if m is not None), None)
            if t is None:
                return out
            if self._dropped(t):
                return tuple(None for _ in ms)
            return tuple(self._one(m) if m is not None else None for m in ms)
        if self._dropped(out.t):  # a sensor that sends its IMU sample alone (the deck's, CONDOR's autopilot)
            return None
        return self._one(out)

    def _dropped(self, t: float) -> bool:
        return any(f.active(t) and f.kind == "imu_drop" and self._rng.random() < f.drop_probability
                   for f in self._faults)

    def _one(self, m):
        t0 = m.t
        for i, f in enumerate(self._faults):
            if not f.active(t0):
                if f.kind == "camera_frozen" and isinstance(m, Frame):
                    self._state[i] = m.image  # the last image before the fault
                continue
            m = self._change(i, f, m, t0)
            if m is None:
                return None
        return m

    def _change(self, i, f, m, t0):
        k = f.kind
        if k == "clock_jump":
            return replace(m, t=m.t + f.jump_s)
        if isinstance(m, Frame):
            img = m.image
            if k == "camera_blackout":
                img = np.zeros_like(img)
            elif k == "camera_frozen":
                img = self._state.setdefault(i, img)
            elif k == "camera_brightness":
                img = np.clip(img.astype(np.float32) * f.gain + f.offset_dn, 0, 255).round().astype(np.uint8)
            elif k == "camera_blur":
                img = cv2.filter2D(img, -1, blur_kernel(f.blur_px, f.blur_deg), borderType=cv2.BORDER_REPLICATE)
            return replace(m, image=img)
        if isinstance(m, ImuSample):
            if k == "imu_gyro_bias":
                return replace(m, gyro=np.asarray(m.gyro, float) + np.radians(np.asarray(f.bias, float)))
            if k == "imu_accel_bias":
                return replace(m, accel=np.asarray(m.accel, float) + np.asarray(f.bias, float))
            return m
        if isinstance(m, RangeSample):
            if k == "range_dropout":
                return replace(m, range=float("nan"))
            if k == "range_stuck":
                return replace(m, range=self._state.setdefault(i, m.range))
            return m
        if isinstance(m, GpsSample) and k == "gps_spoof":
            a = math.radians(f.walk_deg)
            d = np.array([math.cos(a), math.sin(a), 0.0]) * f.walk_mps
            return replace(m, position=np.asarray(m.position, float) + d * (t0 - f.start_s),
                           velocity=np.asarray(m.velocity, float) + d)
        return m


class _FaultyPending(PendingFrame):
    """A frame still rendering; the fault is applied when the loop takes it (frames come in order)."""

    def __init__(self, pending, sensor: FaultySensor):
        super().__init__(pending.t + sensor._jump, pending.future, pending.index)
        self._pending, self._sensor = pending, sensor

    def result(self):
        return self._sensor.apply(self._pending.result())


def _gps_lost(faults, t: float) -> bool:
    return any(f.kind == "gps_spoof" and f.lost_after and t >= f.end_s for f in faults)


class FaultyGps(FaultySensor):
    def apply(self, out):
        if out is not None and _gps_lost(self._faults, out.t):
            return None
        return super().apply(out)


class GustyWind:
    """The world's wind plus (1 - cos) gusts of ``wind_gust`` faults (beyond the turbulence model)."""

    def __init__(self, inner, faults):
        self._inner = inner
        self._faults = [f for f in faults if f.kind == "wind_gust"]

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def gust(self, t: float) -> np.ndarray:
        g = np.zeros(3)
        for f in self._faults:
            if f.active(t):
                a = math.radians(f.from_deg)
                shape = 0.5 * (1.0 - math.cos(2 * math.pi * (t - f.start_s) / f.duration_s)) \
                    if math.isfinite(f.duration_s) else 1.0
                g += -f.speed_mps * shape * np.array([math.cos(a), math.sin(a), 0.0])
        return g

    def velocity_ned(self, t, *args, **kwargs):
        return self._inner.velocity_ned(t, *args, **kwargs) + self.gust(t)


def apply_faults(sensors: dict, faults, rng: np.random.Generator) -> dict:
    """``sensors`` (role -> sensor) with the sensors that a fault targets wrapped; the others as given.
    A fault whose target is not among them is an error (one line)."""
    faults = list(faults or ())
    out = dict(sensors)
    for name in sorted({target_of(f) for f in faults if target_of(f) is not None}):
        if name not in out:
            kinds = ", ".join(sorted({f.kind for f in faults if target_of(f) == name}))
            raise ValueError(f"faults: {kinds} needs a '{name}' sensor, this scenario has "
                             f"{', '.join(sorted(out))}")
    for name, s in sensors.items():
        mine = [f for f in faults if target_of(f) == name]
        if mine:
            out[name] = (FaultyGps if name == "gps" else FaultySensor)(s, mine, rng)
    return out


def inject_faults(sensors: dict, world, faults, rng: np.random.Generator) -> dict:
    """The loop's hook (``app/loop.py``, every system): its sensors (role -> sensor as the mission's builder
    named them: the R-MAX's ``imu gps laser sonar camera baro compass``, the deck's ``ahrs imu camera``,
    CONDOR's ``ahrs imu pitot baro compass gps camera_ahrs pan_pot camera``) with the faulted ones wrapped;
    a ``wind_gust`` fault wraps ``world.wind`` in place (the deck's still air and CONDOR's wind are
    ``world.wind`` too)."""
    faults = list(faults or ())
    if not faults:
        return dict(sensors)
    out = apply_faults(dict(sensors), faults, rng)
    if any(f.kind == "wind_gust" for f in faults):
        world.wind = GustyWind(world.wind, faults)
    return out


# ---------------------------------------------------------------------- build-time faults of the maps
def water_area(geo, centre_ne, size_ne):
    """A copy of the ``GeoImage`` with a ``size_ne`` rectangle at ``centre_ne`` replaced by still water
    (the rural map's pond grey with a smooth 40 m shading: no texture to track or register)."""

    r = geo.resolution_m
    h, w = geo.shape
    rows = np.arange(h)[:, None]
    cols = np.arange(w)[None, :]
    north = geo.north0 - rows * r
    east = geo.east0 + cols * r
    inside = (np.abs(north - centre_ne[0]) <= size_ne[0] / 2) & (np.abs(east - centre_ne[1]) <= size_ne[1] / 2)
    water = 62.0 + 3.0 * np.sin(2 * np.pi * north / 40.0) * np.cos(2 * np.pi * east / 40.0)
    img = geo.image.copy()
    img[inside] = np.clip(np.rint(water), 0, 255).astype(np.uint8)[inside]
    out = GeoImage(img, geo.north0, geo.east0, r, name=geo.name + "-water")
    out.origin_geodetic = geo.origin_geodetic
    return out


def shifted(geo, offset_ne):
    """The ``GeoImage`` georeferenced ``offset_ne`` metres off (its content claims to lie there)."""

    out = GeoImage(geo.image, geo.north0 + offset_ne[0], geo.east0 + offset_ne[1], geo.resolution_m,
                   name=geo.name + "-offset")
    out.origin_geodetic = geo.origin_geodetic
    return out


def map_faults(geo, faults, which: str):
    """``which = "world"``: the ground with the ``feature_poor`` areas; ``"reference"``: the navigator's
    map with the ``map_offset`` shifts."""
    for f in faults or ():
        if which == "world" and f.kind == "feature_poor":
            geo = water_area(geo, f.centre_m, f.size_m)
        elif which == "reference" and f.kind == "map_offset":
            geo = shifted(geo, f.offset_m)
    return geo
