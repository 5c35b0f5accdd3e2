"""Integrity-monitor blocks of the navigators and the ``[[faults]]`` list of a scenario (issue #18).

``IntegrityBlock``: the settings of ``estimation/integrity.IntegrityMonitor`` a navigator reads from its own
configuration (``navigation.integrity`` of the PALACE, WITAS and pad
navigators); the defaults differ per navigator (alert limit, stale time) and are set by the subclasses.

``FaultConfig``: one injected fault (``sensors/faults.py`` documents every kind and its parameters)::

    [[faults]]
    kind = "camera_blackout"
    start_s = 50.0
    duration_s = 5.0
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from visnav.scenarios.base import _M
from visnav.estimation.integrity import IntegrityConfig


class IntegrityBlock(_M):
    window: int = Field(20, ge=1, le=1000, description="updates per stream in the windowed chi-square test")
    alpha: float = Field(0.001, gt=0, lt=0.5, description="two-sided level of the windowed NIS test")
    max_rejected_share: float = Field(0.3, ge=0, le=1, description="degraded above this share of gated-out updates")
    probability: float = Field(0.999, gt=0, lt=1, description="containment probability of the HPL")
    alert_limit_m: float = Field(math.inf, gt=0, description="unusable when the HPL exceeds it")
    stale_s: float = Field(math.inf, gt=0, description="unusable when no update was accepted for this long")
    short_window: int = Field(0, ge=0, le=1000, description="> 0: the HPL's inflation k^2 also from the mean NIS "
                              "of the last this-many horizontal updates (reacts within a few fixes; 0: off)")

    def monitor_config(self):
        return IntegrityConfig(window=self.window, alpha=self.alpha, max_rejected_share=self.max_rejected_share,
                               probability=self.probability, alert_limit_m=self.alert_limit_m,
                               stale_s=self.stale_s, short_window=self.short_window)


class GpsCheckBlock(IntegrityBlock):
    """The GPS walk-off check's keys (navigators that fly on GPS before vision: PALACE, WITAS)."""

    gps_check_alpha: float = Field(1e-7, gt=0, lt=0.5, description="GPS walk-off onset: level of the GPS-inertial "
                                   "velocity test (chi-square(2); navigation/integrity.GpsInertialCheck)")
    gps_check_window_s: float = Field(1.0, gt=0, le=30, description="its window: GPS velocity change vs the "
                                      "integrated acceleration over this long")
    gps_velocity_sigma_mps: float = Field(0.03, gt=0, le=5, description="1-sigma GPS velocity noise per axis "
                                          "(the receiver: 0.02 m/s)")
    gps_check_accel_sigma_mps2: float = Field(0.05, gt=0, le=5, description="1-sigma error of the navigation-frame "
                                              "acceleration (accelerometer, attitude) per axis")


class PalaceIntegrityConfig(GpsCheckBlock):
    """PALACE: landing on a point (1 m), MPE at 10 Hz and GPS at 10 Hz."""

    alert_limit_m: float = Field(4.0, gt=0, description="unusable when the HPL exceeds it")
    stale_s: float = Field(1.0, gt=0, description="unusable when no update was accepted for this long")
    # the MPE error the filter cannot see (its fixes follow the tracked point): the ground reference's error
    # when it was set and the tracker's drift since (seed 000 §4.1), added to the HPL's covariance
    reference_sigma_m: float = Field(0.05, ge=0, le=10, description="1-sigma horizontal error of the MPE ground "
                                     "reference when it is set (GPS fix or estimate)")
    mpe_drift_mps: float = Field(0.015, ge=0, le=1, description="1-sigma horizontal drift of MPE per second "
                                 "since the ground reference was set (fault-free campaign: 0.2-0.5 m in 25 s)")


class GyroCheckBlock(IntegrityBlock):
    """The gyro / autopilot-attitude check's keys (navigators with a strapdown INS beside the R-MAX's own attitude
    solution: WITAS, pad; ``navigation/integrity.GyroAttitudeCheck``)."""

    gyro_check: bool = Field(True, description="test the navigation gyros against the autopilot's attitude "
                             "solution; on a failure (a gyro bias step) the gyros are excluded: WITAS goes on with the "
                             "position filter on the autopilot's attitude, the pad filter fuses the autopilot's "
                             "attitude (navigation/integrity.GyroAttitudeCheck)")
    gyro_check_alpha: float = Field(1e-7, gt=0, lt=0.5, description="level of the gyro test (chi-square(3))")
    gyro_check_window_s: float = Field(1.0, gt=0, le=30, description="the gyro test's window: the rotation "
                                       "integrated from the gyros vs the autopilot's over this long")
    gyro_check_attitude_sigma_deg: float = Field(0.05, gt=0, le=10, description="1-sigma noise of the "
                                                 "autopilot's attitude per axis (the simulated one: 0.03 deg)")


class WitasIntegrityConfig(GpsCheckBlock, GyroCheckBlock):
    """WITAS homing: back within 30 m of home (the issue's unsafe homing), PMF -> KF updates at 5 Hz."""

    alert_limit_m: float = Field(30.0, gt=0, description="unusable when the HPL exceeds it")
    stale_s: float = Field(5.0, gt=0, description="unusable when no update was accepted for this long")
    pmf_in_hpl: bool = Field(True, description="add the point-mass filter's covariance (largest eigenvalue per "
                             "axis) to the HPL's: the KF fuses the PMF mean every frame as if its errors were "
                             "independent, they are not")
    handover_check: bool = Field(True, description="compare the PMF fixes with the odometry from the GPS hand-over; "
                                 "a persistent offset (map offset, spoofed start) is latched: degraded, HPL + offset, "
                                 "the Kalman filter kept in the hand-over frame (navigation/integrity.HandoverCheck)")
    handover_alpha: float = Field(1e-4, gt=0, lt=0.5, description="level of the hand-over test (chi-square(2))")
    handover_updates: int = Field(3, ge=1, le=100, description="registrations in a row above the bound to latch")
    # issue #30: an accelerometer bias the ESKF takes for a tilt (navigation/integrity.TiltCheck)
    frame_ahead_s: float = Field(0.1, gt=0, le=10, description="a frame stamped more than this ahead of the newest "
                                 "IMU sample (a camera clock jump; the camera's latency is 0.05 s) is a camera gap: "
                                 "not fused, degraded while it lasts (issue #30)")
    tilt_check: bool = Field(True, description="compare the ESKF's roll / pitch with the autopilot's attitude "
                             "solution; a lasting difference (an accelerometer bias taken for a tilt) -> degraded, "
                             "HPL + what it can have built, the autopilot's attitude fused from then on and the "
                             "bias states opened (they learn the bias)")
    tilt_check_deg: float = Field(1.5, gt=0, le=90, description="the tilt difference that flags (fault-free "
                                  "campaign: below 0.8 deg; a 0.3 m/s^2 bias: 1.7 deg per axis)")
    tilt_check_persist_s: float = Field(1.0, ge=0, le=30, description="for at least this long")
    tilt_fault_accel_bias_sigma_mps2: float = Field(0.5, gt=0, le=10, description="1-sigma accelerometer bias "
                                                    "the bias states are opened to on a flag")
    tilt_fault_accel_bias_noise: float = Field(0.02, ge=0, le=10, description="accelerometer bias random walk "
                                               "of the ESKF after a flag, m/s^2/sqrt(s) (the bias may end or change)")
    tilt_aid_sigma_deg: float = Field(0.2, gt=0, le=10, description="1 sigma of the autopilot's roll / pitch "
                                      "fused after a flag (its heading: 10 deg, the compass holds it)")


class PadIntegrityConfig(GyroCheckBlock):
    """Pad landing: within 1 m of the pad centre, vision fixes at 20 Hz."""

    alert_limit_m: float = Field(1.0, gt=0, description="unusable when the HPL exceeds it")
    stale_s: float = Field(1.0, gt=0, description="unusable when no update was accepted for this long")
    short_window: int = Field(5, ge=0, le=1000, description="> 0: the HPL's inflation k^2 also from the mean NIS "
                              "of the last this-many vision fixes (a 0.3 m/s^2 accelerometer bias step moves the "
                              "estimate 0.1 m in 0.6 s, before the 20-fix window's mean rises; issue #30)")
    attitude_check_deg: float = Field(2.0, gt=0, le=180, description="the filter's attitude more than this from "
                                      "the autopilot's (10 Hz) -> an IMU fault taken into the attitude: the autopilot's "
                                      "attitude is fused from then on (navigation/pad.py)")


FAULT_KINDS = ("camera_blackout", "camera_frozen", "camera_brightness", "camera_blur", "imu_gyro_bias",
               "imu_accel_bias", "imu_drop", "clock_jump", "range_dropout", "range_stuck", "gps_spoof",
               "map_offset", "feature_poor", "wind_gust")


_CAMERA = ("camera_blackout", "camera_frozen", "camera_brightness", "camera_blur")
_IMU = ("imu_gyro_bias", "imu_accel_bias", "imu_drop")
#: mission type -> the fault kinds its simulation injects (the others are an error: nothing would happen)
FAULTS_APPLY = {
    "palace": _CAMERA + _IMU + ("clock_jump", "range_dropout", "range_stuck", "gps_spoof", "wind_gust"),
    "hover": _CAMERA + _IMU + ("clock_jump", "range_dropout", "range_stuck", "gps_spoof", "wind_gust"),
    "pfcm": _IMU + ("clock_jump", "gps_spoof", "wind_gust"),
    "witas-homing": _CAMERA + _IMU + ("clock_jump", "gps_spoof", "map_offset", "feature_poor", "wind_gust"),
    "pad-landing": _CAMERA + _IMU + ("clock_jump", "wind_gust"),
    # the deck: LED camera (an image), IMU (accelerometers + gyros alone; the roll/pitch AHRS is "ahrs"),
    # a gust in the (otherwise still) air of the lab
    "deck": _CAMERA + _IMU + ("clock_jump", "wind_gust"),
    # CONDOR: gimbal camera, the autopilot's IMU (gyros + accelerometers), GPS (loiter and fallback)
    "condor": _CAMERA + _IMU + ("clock_jump", "gps_spoof", "wind_gust"),
}


def check_faults_apply(mission_type: str, faults) -> None:
    """ValueError (one line) when a fault does not apply to the mission."""
    ok = FAULTS_APPLY.get(mission_type, ())
    bad = sorted({f.kind for f in faults} - set(ok))
    if bad:
        raise ValueError(f"faults {', '.join(bad)} do not apply to mission.type {mission_type!r}; "
                         f"it takes: {', '.join(ok) or 'none'}")


class FaultConfig(_M):
    """One fault: ``kind``, when (``start_s``, ``duration_s``; build-time faults of the map ignore the
    window), and the parameters of its kind (the others are unused)."""

    kind: Literal[FAULT_KINDS]  # type: ignore[valid-type]
    start_s: float = Field(0.0, ge=0, le=7200)
    duration_s: float = Field(math.inf, gt=0, description="inf: to the end of the run")
    sensor: Literal["", "imu", "gps", "laser", "sonar", "camera", "baro", "compass"] = Field(
        "", description="clock_jump / range_dropout / range_stuck: the stream (default: camera / laser)")
    gain: float = Field(1.6, gt=0, le=10, description="camera_brightness: image gain")
    offset_dn: float = Field(40.0, ge=-255, le=255, description="camera_brightness: added grey levels")
    blur_px: int = Field(9, ge=2, le=101, description="camera_blur: length of the motion-blur kernel")
    blur_deg: float = Field(0.0, ge=-360, le=360, description="camera_blur: direction in the image (0: along x)")
    bias: list[float] = Field(default_factory=lambda: [0.0, 0.0, 0.0],
                              description="imu_gyro_bias [deg/s] / imu_accel_bias [m/s^2], body FRD")
    drop_probability: float = Field(1.0, gt=0, le=1, description="imu_drop: share of samples lost")
    jump_s: float = Field(0.2, ge=-10, le=10, description="clock_jump: added to the stream's time stamps")
    walk_mps: float = Field(0.5, ge=0, le=20, description="gps_spoof: walk-off speed of the spoofed fix")
    walk_deg: float = Field(90.0, ge=-360, le=360, description="gps_spoof: walk-off direction from north")
    lost_after: bool = Field(True, description="gps_spoof: GPS lost when the walk-off ends")
    offset_m: list[float] = Field(default_factory=lambda: [20.0, 0.0],
                                  description="map_offset: the reference map shifted north, east [m]")
    centre_m: list[float] = Field(default_factory=lambda: [0.0, 0.0],
                                  description="feature_poor: centre of the water area, north, east [m]")
    size_m: list[float] = Field(default_factory=lambda: [60.0, 60.0],
                                description="feature_poor: extent of the water area, north, east [m]")
    speed_mps: float = Field(6.0, ge=0, le=30, description="wind_gust: gust speed added to the wind")
    from_deg: float = Field(90.0, ge=-360, le=360, description="wind_gust: direction the gust comes from")
    label: str = Field("", description="name in campaign tables (default: the kind)")

    @model_validator(mode="after")
    def _check(self):
        if self.kind in ("imu_gyro_bias", "imu_accel_bias") and len(self.bias) != 3:
            raise ValueError(f"faults: {self.kind}.bias must have 3 values (body x, y, z)")
        for name in ("offset_m", "centre_m", "size_m"):
            if len(getattr(self, name)) != 2:
                raise ValueError(f"faults: {self.kind}.{name} must have 2 values (north, east)")
        if self.kind in ("range_dropout", "range_stuck") and self.sensor not in ("", "laser", "sonar"):
            raise ValueError(f"faults: {self.kind}.sensor must be 'laser' or 'sonar', got {self.sensor!r}")
        if self.kind == "feature_poor" and min(self.size_m) <= 0:
            raise ValueError("faults: feature_poor.size_m must be positive")
        return self

    @property
    def name(self) -> str:
        return self.label or self.kind

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s

    def active(self, t: float) -> bool:
        return self.start_s <= t < self.end_s
