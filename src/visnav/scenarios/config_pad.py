"""Config of the WITAS vision landing on the three-circle pad (seed 002 ch. 6): ``mission.type = "pad-landing"``.

The mission holds the approach and the black-out (``--set mission.blackout_height_m=5``); the pad, its shadow and
lighting are ``[world.pad]``;
the camera on its pan-tilt unit and spring platform is ``[sensors.camera] kind = "pantilt-camera"``
(``sensors.camera.pantilt.*``, ``sensors.camera.platform.*``), the filter with its IMU rates ``[navigation] kind =
"pad"``. Dimensions and their reasons: docs/pad.md.
"""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import Field, model_validator

from visnav.scenarios.base import _M
from visnav.scenarios.config_integrity import PadIntegrityConfig
from visnav.geometry.pad import PadLayout


class PadGeometryConfig(_M):
    legs_m: list[float] = Field(default_factory=lambda: [4.4, 2.2, 1.2, 0.58])
    ring_ratio: list[float] = Field(default_factory=lambda: [0.20, 0.15, 0.20, 0.15])
    inner_ratio: list[float] = Field(default_factory=lambda: [0.50, 0.50, 0.65, 0.65])
    resolution_m: float = Field(0.002, ge=0.0005, le=0.05, description="board texture [m/px]")
    shadow: bool = False
    shadow_direction_deg: float = Field(45.0, ge=-360, le=360)
    shadow_offset_m: float = Field(0.8, ge=-10, le=10, description="shadow edge from the pad centre")
    shadow_gain: float = Field(0.45, ge=0.05, le=1.0)
    lighting_change_s: Optional[float] = Field(None, ge=0, description="frame grey x lighting_gain from then on")
    lighting_gain: float = Field(0.6, ge=0.1, le=2.0)

    @model_validator(mode="after")
    def _layout(self):
        PadLayout(tuple(self.legs_m), tuple(self.ring_ratio), tuple(self.inner_ratio))
        return self


class PanTiltConfig(_M):
    pan_limits_deg: list[float] = Field(default_factory=lambda: [-170.0, 170.0])
    tilt_limits_deg: list[float] = Field(default_factory=lambda: [10.0, 125.0])
    max_rate_dps: float = Field(90.0, gt=0, le=720)
    servo_gain: float = Field(8.0, gt=0, le=100, description="1/s")
    encoder_resolution_deg: float = Field(0.05, ge=0, le=2)
    initial_tilt_deg: float = Field(90.0, ge=0, le=135)


class PlatformConfig(_M):
    misalignment_deg: list[float] = Field(default_factory=lambda: [1.5, -1.2, 0.0],
                                          description="constant camera platform roll, pitch, yaw vs the body")
    natural_hz: float = Field(6.0, gt=0.5, le=100)
    damping: float = Field(0.2, gt=0, le=2)


class PadCameraConfig(_M):
    kind: Literal["pantilt-camera"] = "pantilt-camera"
    width: int = Field(640, ge=160, le=2048)
    height: int = Field(480, ge=120, le=2048)
    focal_px: float = Field(640.0, gt=50, le=10000)
    rate_hz: float = Field(20.0, ge=1, le=60, description="frames processed per second (§6.2: 20 Hz)")
    noise_sigma: float = Field(2.0, ge=0, le=50, description="grey levels")
    latency_s: float = Field(0.05, ge=0, le=1.0, description="exposure to pose (stamped correctly)")
    lever_arm_m: list[float] = Field(default_factory=lambda: [0.3, 0.0, -0.45],
                                     description="pan-tilt axes from the skid reference point, body FRD")
    head_offset_m: list[float] = Field(default_factory=lambda: [0.0, 0.0, 0.05],
                                       description="camera centre from the pan-tilt axes, camera frame")
    pantilt: PanTiltConfig = PanTiltConfig()
    platform: PlatformConfig = PlatformConfig()


class PadFilterConfig(_M):
    kind: Literal["pad"] = "pad"
    gyro_hz: float = Field(200.0, ge=20, le=1000)
    accel_hz: float = Field(66.0, ge=10, le=1000)
    output_hz: float = Field(50.0, ge=1, le=1000)
    gyro_bias_states: bool = Field(True, description="15 states (gyro biases) instead of appendix A's 12")
    accel_noise: float = Field(0.008, ge=0, le=5, description="m/s^2/sqrt(Hz)")
    gyro_noise: float = Field(3e-4, ge=0, le=1, description="rad/s/sqrt(Hz)")
    accel_bias_noise: float = Field(2e-4, ge=0, le=1)
    gyro_bias_noise: float = Field(1e-5, ge=0, le=1)
    init_position_sigma_m: float = Field(0.1, gt=0, le=100)
    init_velocity_sigma_mps: float = Field(0.3, gt=0, le=100)
    init_attitude_sigma_deg: float = Field(1.0, gt=0, le=30)
    position_floor_m: float = Field(0.002, ge=0, le=1, description="added to the vision sigma")
    range_floor: float = Field(8e-4, ge=0, le=0.1, description="vision sigma floor per m of range")
    gate_probability: float = Field(0.9999, gt=0, le=1)
    fix_timeout_s: float = Field(0.3, gt=0, le=10)
    track_deadband_deg: float = Field(1.0, ge=0, le=20)
    sigma_floor_px: float = Field(0.05, gt=0, le=5)
    cov_inflation: float = Field(1.5, gt=0, le=20)
    # IMU faults (issue #18): a filter that gates out every fix while the fixes agree with each other is the
    # one that is wrong (navigation/pad.py, docs/pad.md "IMU faults")
    reinit_fixes: int = Field(8, ge=0, le=100, description="this many fixes in a row gated out that agree with "
                              "each other (one smooth track) -> the filter is re-initialised on them (0: never)")
    reinit_alpha: float = Field(1e-3, gt=0, lt=0.5, description="level of the agreement test: chi-square of the "
                                "fixes about a constant-acceleration track fitted to them")
    reinit_accel_bias_sigma_mps2: float = Field(0.5, gt=0, le=10, description="1-sigma accelerometer bias the "
                                                "re-initialised filter starts with (it learns the faulty bias)")
    reinit_gyro_bias_sigma_dps: float = Field(1.0, gt=0, le=100, description="1-sigma gyro bias [deg/s] after "
                                              "a re-initialisation or a failed gyro check")
    fault_accel_bias_noise: float = Field(0.1, ge=0, le=10, description="accelerometer bias random walk "
                                          "[m/s^3/sqrt(Hz)] from an IMU fault's flag until a window of fixes agrees "
                                          "with the filter again (the bias states learn the fault)")
    ahrs_sigma_deg: float = Field(0.1, gt=0, le=10, description="1-sigma of the autopilot's attitude fused at "
                                  "ahrs_hz once an IMU fault is flagged (the gyro check or a re-initialisation)")
    ahrs_hz: float = Field(50.0, gt=0, le=1000, description="rate of those attitude updates")
    integrity: PadIntegrityConfig = PadIntegrityConfig()


class PadMissionConfig(_M):
    type: Literal["pad-landing"] = "pad-landing"
    start_ne_m: list[float] = Field(default_factory=lambda: [3.0, -2.0])
    start_height_m: float = Field(20.0, ge=2, le=60)
    settle_s: float = Field(2.0, ge=0, le=60, description="hover after the first fix before the approach")
    approach_speed_mps: float = Field(0.8, gt=0, le=5)
    descent_rate_mps: float = Field(0.7, gt=0, le=3)
    slow_height_m: float = Field(3.0, ge=0, le=30, description="below it the sink rate is final_rate_mps")
    final_rate_mps: float = Field(0.3, gt=0, le=1.5)
    gate_height_m: float = Field(1.3, ge=0, le=10, description="hold here until centred (0: no gate)")
    gate_tolerance_m: float = Field(0.08, gt=0, le=5, description="horizontal error and speed [m/s] to pass")
    gate_time_s: float = Field(1.0, ge=0, le=30, description="centred this long")
    gate_max_s: float = Field(8.0, ge=0, le=60, description="descend anyway after this long")
    flare_height_m: float = Field(0.35, ge=0, le=5)
    integrity_unusable_s: float = Field(0.5, ge=0, le=30, description="navigator integrity unusable this long ...")
    integrity_abort_height_m: float = Field(2.0, ge=0, le=60, description="... above this height: go around "
                                            "(climb back to start_height_m, approach again when ok); below: land "
                                            "on dead reckoning")
    max_go_arounds: int = Field(2, ge=0, le=20, description="more go-arounds -> abort (hold, mission over)")
    flare_rate_mps: float = Field(0.12, gt=0, le=1.5)
    blackout_height_m: Optional[float] = Field(None, ge=0, le=60, description="vision black-out from this height")
    blackout_s: float = Field(3.0, ge=0, le=60)
    timeout_s: float = Field(150.0, gt=0, le=3600)
