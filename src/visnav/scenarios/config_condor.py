"""Scenario config of the CONDOR missions (seed 004): fixed wing + gimbal camera orbit, ground test.

``mission.type = "condor"``; ``mission.experiment`` picks the static ground test of Tables 4.1-4.2
or the closed-loop orbit of ch. 6-7 (``--set control.condor.orbit.logic=coordinated``). Its aircraft is
``[vehicle] kind = "fixedwing"``, its camera ``[sensors.camera] kind = "gimbal-camera"`` on ``[sensors.gimbal]
kind = "condor-gimbal"``, its video and telemetry link ``[sensors.link] kind = "link"``, its navigator
``[navigation] kind = "condor"``.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from visnav.scenarios.base import _M


class AirframeConfig(_M):
    kind: Literal["fixedwing"] = "fixedwing"
    airspeed_mps: float = Field(17.0, ge=15.0, le=18.0, description="Skywalker cruise (seed 004)")
    mass_kg: float = Field(5.0, ge=2.0, le=15.0)


class CondorCameraConfig(_M):
    kind: Literal["gimbal-camera"] = "gimbal-camera"
    width_px: int = Field(640, ge=160, le=1920)
    height_px: int = Field(480, ge=120, le=1080)
    hfov_deg: float = Field(53.0, ge=30.0, le=120.0, description="across the processed frame")
    k1: float = Field(-0.25, ge=-0.6, le=0.3, description="radial distortion (OpenCV k1)")
    k2: float = Field(0.05, ge=-0.3, le=0.3)
    crop_dx_px: float = Field(12.0, ge=-60.0, le=60.0, description="optical centre right of the image centre")
    crop_dy_px: float = Field(-7.0, ge=-60.0, le=60.0, description="optical centre below (+) the image centre")
    frame_hz: float = Field(7.5, ge=1.0, le=30.0, description="image processing rate (§4: 7.5 images/s)")
    noise_sigma: float = Field(4.0, ge=0.0, le=30.0)


class TargetConfig(_M):
    """The blue tent (``[world.tent]``)."""

    length_m: float = Field(3.0, ge=0.5, le=20.0)
    width_m: float = Field(2.0, ge=0.5, le=20.0)
    north_m: float = Field(0.0, ge=-1000.0, le=1000.0)
    east_m: float = Field(0.0, ge=-1000.0, le=1000.0)
    heading_deg: float = Field(20.0, ge=-180.0, le=180.0)


class GimbalConfig(_M):
    kind: Literal["condor-gimbal"] = "condor-gimbal"
    pan_rate_deg_s: float = Field(60.0, gt=0.0, le=360.0)
    tilt_rate_deg_s: float = Field(30.0, gt=0.0, le=360.0)
    roll_leak: float = Field(0.05, ge=0.0, le=1.0, description="fraction of the aircraft bank left on the camera")
    roll_bias_deg: float = Field(-1.0, ge=-20.0, le=20.0)
    ahrs_noise_deg: float = Field(0.15, ge=0.0, le=5.0)
    ahrs_noise_tau_s: float = Field(1.0, ge=0.0, le=60.0, description="correlation time of the AHRS noise (0: white)")
    ahrs_bias_tilt_deg: float = Field(0.0, ge=-5.0, le=5.0)
    ahrs_bias_roll_deg: float = Field(0.0, ge=-5.0, le=5.0)
    ahrs_accel_gain: float = Field(0.2, ge=0.0, le=1.0, description="share of unexplained acceleration in the attitude")
    ahrs_tau_s: float = Field(3.0, gt=0.0, le=60.0)
    ahrs_lag_s: float = Field(0.0, ge=0.0, le=10.0, description="lag of the AHRS behind quick tilts (Fig. 4.2)")
    ahrs_rate_hz: float = Field(50.0, gt=0.0, le=500.0, description="output rate of the camera AHRS (its filter steps at it)")
    pot_noise_deg: float = Field(1.0, ge=0.0, le=10.0)
    operator_gain_per_s: float = Field(0.6, ge=0.0, le=5.0, description="how fast the operator re-centres the tent")


class LinkConfig(_M):
    kind: Literal["link"] = "link"
    latency_s: float = Field(0.33, ge=0.0, le=2.0)
    drop_prob: float = Field(0.1, ge=0.0, le=0.9)
    outage_rate_hz: float = Field(0.01, ge=0.0, le=1.0)
    outage_s: float = Field(1.0, ge=0.0, le=10.0)


class VisionConfig(_M):
    method: Literal["exact", "thesis"] = "exact"
    lut: Literal["full", "thesis", "none"] = "full"
    board_distance_m: float = Field(2.0, ge=0.5, le=20.0)
    board_spacing_m: float = Field(0.04, ge=0.005, le=0.5)


class CondorNavigationConfig(_M):
    """What the navigator assumes (``navigation/condor.py``), never taken from the world; ``vision``: its image
    processing (radius method, look-up table)."""

    kind: Literal["condor"] = "condor"

    gps_gain: float = Field(0.3, gt=0.0, le=1.0, description="complementary filter weight of a GPS fix")
    radius_sigma_pct: float = Field(1.0, gt=0.0, le=20.0, description="vision radius noise the integrity test assumes")
    heading_sigma_deg: float = Field(3.0, gt=0.0, le=30.0, description="bearing error the protection level assumes "
                                     "(compass calibration residual and noise, pan pot, vision bearing; issue #18: "
                                     "seed 1's cross-range error was -3.0 +- 1.9 deg)")
    carry_sigma_mps: float = Field(5.0, gt=0.0, le=50.0, description="drift rate of the vision position carried "
                                   "from its fix at airspeed along the compass heading (the unknown wind, the turn), "
                                   "1 sigma per axis, for the protection level")
    gps_accel_mps2: float = Field(3.0, ge=0.0, le=50.0, description="acceleration the GPS smoother does not see "
                                  "(the loiter's v^2/R), for the protection level")
    radius_alpha: float = Field(0.5, gt=0.0, le=1.0, description="radius filter alpha")
    radius_beta: float = Field(0.1, ge=0.0, le=1.0, description="radius filter beta")
    radius_stale_s: float = Field(3.0, gt=0.0, le=30.0, description="radius held this long across dropouts")
    vision: VisionConfig = VisionConfig()


class OrbitConfig(_M):
    """The orbit the mission asks for (``[mission.orbit]``): GPS loiter, switch to vision, fallbacks."""

    radius_m: float = Field(110.0, ge=30.0, le=500.0, description="desired vision orbit radius")
    loiter_radius_m: float = Field(120.0, ge=30.0, le=500.0, description="GPS loiter before the switch")
    switch_time_s: float = Field(60.0, ge=0.0, le=3600.0)
    transition_s: float = Field(40.0, ge=0.0, le=600.0, description="excluded from the orbit error")
    integrity_unusable_s: float = Field(2.0, ge=0.0, le=60.0, description="vision orbit: navigator integrity "
                                        "unusable this long -> back to the GPS loiter (issue #18)")
    integrity_ok_s: float = Field(5.0, ge=0.0, le=600.0, description="... and back to vision after this long ok")
    max_fallbacks: int = Field(2, ge=0, le=100, description="GPS fallbacks before the vision orbit is given up")


class OrbitGainsConfig(_M):
    """The orbit controller (``[control.condor.orbit]``, guidance/orbit.py): its logic and gains."""

    logic: Literal["original", "modified", "coordinated"] = "coordinated"
    kp_original: float = Field(0.001, ge=0.0, le=0.1, description="rad/s per m (eq. 5.1, low as in flight 1)")
    kd_original: float = Field(0.01, ge=0.0, le=0.5)
    kp_modified: float = Field(0.012, ge=0.0, le=0.1)
    kd_modified: float = Field(0.06, ge=0.0, le=0.5)
    base_limit: float = Field(0.4, ge=0.0, le=1.0, description="eq. 5.2 limit (+-40 %)")


class CondorControlConfig(_M):
    """CONDOR's controller gains (``[control.condor]``): the orbit logic and the inner loops (eq. 5.5-5.6)."""

    orbit: OrbitGainsConfig = OrbitGainsConfig()
    kp_phi: float = Field(2.0, ge=0.0, le=10.0)
    kd_phi: float = Field(0.15, ge=0.0, le=5.0)
    kp_psi: float = Field(0.6, ge=0.0, le=10.0)
    bank_limit_deg: float = Field(35.0, ge=5.0, le=60.0)


class GroundTestConfig(_M):
    tables: Literal["4.1", "4.2", "both"] = "both"
    pixel_noise_px: float = Field(0.5, ge=0.0, le=10.0)
    height_error_m: float = Field(0.0, ge=-1.0, le=1.0, description="static error of the measured height")


class CondorMissionConfig(_M):
    """What the CONDOR aircraft is asked to do; the tent is ``[world.tent]``, the gains ``[control.condor]``."""

    type: Literal["condor"] = "condor"
    experiment: Literal["orbit", "ground_test"] = "orbit"
    altitude_m: float = Field(100.0, ge=20.0, le=500.0)
    orbit: OrbitConfig = OrbitConfig()
    ground_test: GroundTestConfig = GroundTestConfig()
