"""Config of the WITAS GPS-denied homing mission (seed 002 ch. 5): ``mission.type = "witas-homing"``.

The mission holds the loop; the world and reference maps are ``[world.witas_map]``; the vision navigator (odometry, point-mass
filter, registration, Kalman filter) is ``[navigation] kind = "witas"`` (``--set navigation.pmf_size_m=200``);
its downward camera, barometer and optional compass are ``[sensors.camera] kind = "camera"``,
``[sensors.baro] kind = "baro"`` and ``[sensors.compass] kind = "compass"`` (``config_sensors.py``).
"""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import Field

from visnav.scenarios.base import _M
from visnav.scenarios.config_integrity import WitasIntegrityConfig


class WitasPathConfig(_M):
    """A closed rounded-rectangle loop from home (the middle of the west leg, or of the north leg for ccw) back home."""

    size_north_m: float = Field(320.0, ge=40, le=5000)
    size_east_m: float = Field(200.0, ge=40, le=5000)
    corner_radius_m: float = Field(30.0, ge=5, le=500)
    altitude_m: float = Field(60.0, ge=10, le=500)
    speed_mps: float = Field(8.0, gt=0, le=20)
    accel_mps2: float = Field(1.0, gt=0, le=5)
    margin_m: float = Field(35.0, ge=0, le=1000, description="loop to map edge, with --map")
    direction: Literal["cw", "ccw"] = "cw"


class WitasMapConfig(_M):
    """World map (procedural rural, or ``file``: any geo-referenced image) and the navigator's
    reference map derived from it (coarser, other brightness and contrast, blurred)."""

    file: Optional[str] = None
    resolution_m: float = Field(0.25, ge=0.05, le=2, description="procedural world resolution")
    pond: bool = True
    reference_resolution_m: float = Field(1.0, ge=0.1, le=10)
    reference_gain: float = Field(0.8, gt=0, le=3)
    reference_offset: float = Field(25.0, ge=-200, le=200)
    reference_gamma: float = Field(1.2, gt=0.2, le=5)
    reference_blur_m: float = Field(1.0, ge=0, le=20)


class WitasFilterConfig(_M):
    """The vision navigator (Fig. 5.3): odometry + registration -> PMF -> Kalman filter."""

    kind: Literal["witas"] = "witas"

    backend: Literal["eskf", "ahrs"] = Field("eskf", description="eskf: 12-state INS error filter; "
                                             "ahrs: position filter on the autopilot's attitude")
    ins_rate_hz: float = Field(50.0, ge=10, le=400, description="INS integration rate (50 Hz in §5.9.1)")
    odometry_hz: float = Field(5.0, ge=1, le=25)
    registration_every: int = Field(2, ge=1, le=100, description="register every n-th odometry frame")
    max_features: int = Field(50, ge=8, le=500)
    ransac: bool = True
    sigma_px: float = Field(1.0, gt=0, le=10, description="feature noise for the RANSAC threshold")
    min_inliers: int = Field(8, ge=4, le=100)
    odometry_gate_m: float = Field(0.5, gt=0, le=100, description="reject a step this far (+ 15 % of it) from the filter's")
    pmf_size_m: float = Field(80.0, ge=10, le=400)
    pmf_resolution_m: float = Field(1.0, ge=0.25, le=10)
    pmf_sigma0_m: float = Field(10.0, gt=0, le=200, description="PMF prior at GPS loss")
    process_noise_m: float = Field(0.3, ge=0, le=20, description="odometry noise per step, 1 sigma")
    process_noise_frac: float = Field(0.03, ge=0, le=1, description="... plus this fraction of the step")
    ncc_gain: float = Field(12.0, gt=0, le=200, description="likelihood = floor + exp(gain (C - max C))")
    likelihood_floor: float = Field(0.02, ge=0, le=1)
    min_peak_ncc: float = Field(0.3, ge=-1, le=1, description="weaker correlation peaks give no update")
    min_template_std: float = Field(4.0, ge=0, le=100)
    window_sigmas: float = Field(3.0, gt=0, le=10)
    window_min_m: float = Field(6.0, ge=1, le=200)
    window_max_m: float = Field(40.0, ge=1, le=500)
    kf_position_sigma_m: float = Field(2.0, gt=0, le=100, description="thesis: constant 2 m (§5.8.4)")
    use_pmf_covariance: bool = False
    baro_sigma_m: float = Field(4.0, gt=0, le=100, description="thesis: 4 m vertical")
    compass_sigma_deg: float = Field(2.0, gt=0, le=45)
    init_attitude_error_deg: list[float] = Field(default_factory=lambda: [0.0, 0.0, 0.0],
                                                 description="roll, pitch, heading error at GPS loss")
    kf_gate_probability: float = Field(1.0, gt=0, le=1, description="chi-square gate of the PMF -> KF and baro / "
                                       "compass updates of the eskf backend (1: none, as the thesis)")
    integrity: WitasIntegrityConfig = WitasIntegrityConfig()


class WitasMissionConfig(_M):
    type: Literal["witas-homing"] = "witas-homing"
    path: WitasPathConfig = WitasPathConfig()
    gps_loss_s: float = Field(8.0, ge=0, le=3600, description="GPS lost from this time on")
    settle_s: float = Field(10.0, ge=0, le=120)
    hold_s: float = Field(3.0, ge=0, le=600)
    home_radius_m: float = Field(10.0, gt=0, le=100, description="returned_home: within this of home")
