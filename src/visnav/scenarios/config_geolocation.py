"""Scenario config of the ground-target geo-location mission (seed 002 ch. 7): ``mission.type =
"mav-geolocation"`` (figure-eight, operator); its map and truck are ``[world.geo_map]``, ``[world.truck]``, the
path controller ``[control.mav]``. Its aircraft is ``[vehicle] kind = "mav"``, its camera
``[sensors.camera] kind = "mav-camera"`` on ``[sensors.gimbal] kind = "mav-gimbal"``, the autopilot's downlinked
state ``[sensors.telemetry] kind = "mav-telemetry"``, its navigator ``[navigation] kind = "geolocation"``
(``--set navigation.hough=false``).
"""

from __future__ import annotations

from typing import Literal, Optional

from pydantic import Field

from visnav.scenarios.base import _M
from visnav.world.appearance import ANOTHER_DAY


class MavMapConfig(_M):
    """The ground and its geo-referenced image (``[world.geo_map]``)."""

    file: Optional[str] = Field(None, description="geo-referenced image (PNG + world file, GeoTIFF); "
                                "none: the procedural rural world")
    rural_size_m: float = Field(400.0, ge=150.0, le=2000.0)
    rural_seed: int = Field(11, ge=0, description="the procedural map (fixed across run seeds)")
    ref_gain: float = Field(0.85, ge=0.3, le=1.5, description="reference = another sensor, another day")
    ref_offset: float = Field(20.0, ge=-100.0, le=100.0)
    ref_gamma: float = Field(1.15, ge=0.5, le=2.0)
    ref_blur_m: float = Field(0.3, ge=0.0, le=3.0)
    change_m: float = Field(0.0, ge=0.0, le=10.0, description="the reference shows another day "
                            "(world/appearance.py): texture finer than this (Gaussian sigma) changes where it is "
                            "relief; 0 (default): the frames are drawn from the reference's own day; "
                            f"{ANOTHER_DAY['scale_m']}: the registrability map's model")
    change_keep: float = Field(ANOTHER_DAY["keep"], ge=0.0, le=1.0, description="correlation the relief's fine "
                               "texture keeps between the reference and the flight")
    relief_level: float = Field(ANOTHER_DAY["relief_level"], gt=0.0, le=100.0, description="fine-texture rms "
                                "[grey levels] above which unoriented texture counts as relief")
    relief_shift_m: float = Field(ANOTHER_DAY["shift_m"], ge=0.0, le=20.0, description="rms displacement of the "
                                  "relief (parallax, shadows)")
    relief_corr_m: float = Field(ANOTHER_DAY["corr_m"], gt=0.0, le=100.0, description="correlation length of "
                                 "that displacement")


class MavTargetConfig(_M):
    """The truck (``[world.truck]``)."""

    north_m: float = Field(0.0, ge=-5000.0, le=5000.0, description="from the map's centre")
    east_m: float = Field(0.0, ge=-5000.0, le=5000.0, description="from the map's centre")
    heading_deg: float = Field(30.0, ge=-180.0, le=180.0)
    length_m: float = Field(7.0, ge=1.0, le=20.0)
    width_m: float = Field(2.5, ge=0.5, le=10.0)


class MavAirframeConfig(_M):
    kind: Literal["mav"] = "mav"
    mass_kg: float = Field(0.434, ge=0.2, le=2.0, description="PingWing, Table 7.1")
    span_m: float = Field(1.1, ge=0.3, le=3.0, description="the issue's 12-15 m/s airframe (wing area 0.079 m^2 "
                          "kept for any span: vehicles/fixedwing.py micro_params); 0.41: the PingWing of §7.4.1 "
                          "(scenario mav-geolocation-pingwing)")
    airspeed_mps: float = Field(13.0, ge=11.0, le=25.0, description="cruise; the motor constant follows it (about "
                                "55 % throttle in cruise); 19: the PingWing's, §7.4.1")


class MavCameraConfig(_M):
    kind: Literal["mav-camera"] = "mav-camera"
    width_px: int = Field(720, ge=160, le=1920, description="grabbed (§7.4.3)")
    height_px: int = Field(576, ge=120, le=1080)
    process_width_px: int = Field(360, ge=80, le=1920, description="registered at half size (§7.4.3)")
    process_height_px: int = Field(288, ge=60, le=1080)
    hfov_deg: float = Field(53.0, ge=20.0, le=120.0, description="f = 3.6 mm on a 1/4 inch CCD (Table 7.2)")
    k1: float = Field(-0.22, ge=-0.6, le=0.3)
    k2: float = Field(0.06, ge=-0.3, le=0.3)
    frame_hz: float = Field(5.0, ge=0.5, le=25.0, description="frames with the target saved at about 5 Hz")
    frame_phase_s: Optional[float] = Field(None, ge=0.0, le=2.0, description="first frame's instant (modulo the "
                                           "frame period); none: drawn per flight (the grabber and the autopilot "
                                           "run on independent clocks); 0.1: rounds 1-3")
    noise_sigma: float = Field(4.0, ge=0.0, le=40.0, description="analogue video link noise")


class MavGimbalConfig(_M):
    kind: Literal["mav-gimbal"] = "mav-gimbal"
    lag_s: float = Field(0.1, ge=0.0, le=2.0)
    leak: float = Field(0.05, ge=0.0, le=1.0)
    bias_deg: float = Field(1.5, ge=0.0, le=10.0, description="1-sigma mount misalignment per axis")
    jitter_deg: float = Field(0.5, ge=0.0, le=5.0)
    deadband_deg: float = Field(1.0, ge=0.0, le=10.0, description="servo dead band + gear backlash, full width "
                                "per axis (a micro servo's 8 us dead band on 1000 us for 90 deg = 0.7 deg, plus "
                                "backlash: 1 deg assumed)")
    travel_deg: float = Field(45.0, ge=5.0, le=90.0, description="servo travel +- per axis (assumed)")
    ahrs_turn_gain: float = Field(0.3, ge=0.0, le=1.0, description="share of the bank the autopilot's AHRS "
                                  "loses in a sustained turn (the gimbal counters the estimate)")
    ahrs_tau_s: float = Field(8.0, gt=0.0, le=120.0)
    ahrs_bias_deg: float = Field(3.0, ge=0.0, le=15.0, description="1-sigma per axis (roll, pitch) of the "
                                 "autopilot's attitude-estimate bias, drawn once per flight (§7.2: 'biases in "
                                 "the MAV's attitude estimation'; 3 deg: MEMS accelerometer levelling, assumed)")


class MavTelemetryConfig(_M):
    kind: Literal["mav-telemetry"] = "mav-telemetry"
    rate_hz: float = Field(5.0, ge=1.0, le=50.0, description="§7.4: MAV state at 5 Hz")
    gps_sigma_m: float = Field(0.7, ge=0.0, le=10.0)
    gps_bias_m: float = Field(3.0, ge=0.0, le=20.0, description="1-sigma per axis")
    gps_delay_s: float = Field(0.2, ge=0.0, le=1.0)
    gps_rate_hz: float = Field(4.0, ge=0.0, le=20.0, description="GPS fixes held between updates (§7.4.2: "
                               "4 Hz u-blox); 0: a fix at every sample")
    link_delay_s: float = Field(0.3, ge=0.0, le=1.5, description="autopilot -> image computer transport "
                                "(modem, ground control computer, Ethernet, Fig. 7.5), unknown to the ground "
                                "station (§7.1: synchronising video and flight data; 0.3 s assumed)")
    vel_sigma_mps: float = Field(0.4, ge=0.0, le=3.0)
    baro_bias_m: float = Field(2.0, ge=0.0, le=20.0)
    baro_noise_m: float = Field(0.3, ge=0.0, le=5.0)
    extra_heading_deg: float = Field(0.0, ge=0.0, le=45.0, description="uniform +- added to the heading")


class MavControlConfig(_M):
    """The MAV's path controller (``[control.mav]``): L1 guidance and the bank limit."""

    l1_m: float = Field(30.0, ge=10.0, le=150.0, description="L1 guidance distance: 2.3 s ahead at 13 m/s (45 m, "
                        "2.4 s at the PingWing's 19 m/s)")
    bank_limit_deg: float = Field(35.0, ge=10.0, le=50.0)


class MavRegistrationConfig(_M):
    kind: Literal["geolocation"] = "geolocation"
    hough: bool = True
    check_rotation: bool = False
    rotation_refine_deg: float = Field(0.75, ge=0.0, le=5.0, description="beyond the thesis: +- step of the "
                                       "rotation refined after the match (0: none)")
    scale_search: float = Field(0.06, ge=0.0, le=0.3, description="beyond the thesis: +- relative height "
                                "searched around the baro (0: baro scale only, as the thesis)")
    rotation_search_deg: float = Field(45.0, ge=0.0, le=90.0, description="beyond the thesis: where Algorithm 1 "
                                       "is not applied, correlate over headings within +- this of the telemetry "
                                       "heading (0: keep the telemetry heading, as the thesis)")
    rotation_search_step_deg: float = Field(7.5, gt=0.5, le=30.0)
    median_px: int = Field(5, ge=1, le=15)
    search_radius_m: float = Field(25.0, ge=5.0, le=200.0)
    min_quality: float = Field(0.05, ge=0.0, le=1.0, description="1 - second/first peak below this: no sample")
    quality_ref: float = Field(0.5, gt=0.0, le=1.0, description="quality below this inflates the sample's "
                               "variance by (quality_ref / quality)^2 (at most 25x)")
    sigma_m: float = Field(1.5, ge=0.1, le=50.0)
    map_sigma_m: float = Field(10.0, ge=0.5, le=200.0)
    gate_prob: float = Field(0.999, ge=0.0, lt=1.0, description="chi-square gate (0: none, as the thesis)")
    telemetry_sync: Literal["hold", "interpolate"] = Field(
        "hold", description="the telemetry a frame is registered and ray-cast with: 'hold' the last sample that had "
        "arrived when the frame was grabbed (§7.4.3: images and 'corresponding telemetry' recorded simultaneously); "
        "'interpolate' the samples around the frame interpolated to its time (rounds 1-3)")
    false_match_m: float = Field(5.0, ge=1.0, le=50.0, description="a sample farther than this is a false match")


class GeolocationMissionConfig(_M):
    type: Literal["mav-geolocation"] = "mav-geolocation"
    experiment: Literal["figure_eight", "single_frame"] = "figure_eight"
    altitude_m: float = Field(70.0, ge=30.0, le=300.0)
    half_length_m: float = Field(80.0, ge=40.0, le=400.0, description="figure-eight half length = each lobe's "
                                 "width, at least the turn diameter at the bank limit downwind (13 + 4 m/s at 35 deg: "
                                 "84 m; the PingWing's 19 + 4 m/s: 154 m, 160 in mav-geolocation-pingwing)")
    axis_deg: Optional[float] = Field(None, ge=-180.0, le=180.0, description="long axis from north; none: "
                                      "along the map's longer side")
    click_sigma_px: float = Field(3.0, ge=0.0, le=30.0, description="operator's click error")
    max_samples: int = Field(40, ge=1, le=100000, description="stop once this many samples are in")
