"""Ground-target geo-location flight (seed 002 ch. 7), the parts of the one loop (``app/loop.py``): a 434 g
fixed-wing MAV with a nadir camera on a pitch-roll gimbal flies a figure-eight at 70 m over a truck; frames
(720x576) and 5 Hz telemetry go to the ground station, where ``GeolocationNavigator`` (the system's
navigator) tracks the truck, registers each frame to the reference image and combines the samples by
recursive least squares. The aircraft flies on its autopilot's ``AutopilotNavigator`` (the loop's
``flight_navigator``: AHRS, gyros, accelerometers, pitot, and the telemetry's baro height).

Rates (on the dynamics grid): dynamics ``run.dt_s`` (100 Hz), autopilot 50 Hz, telemetry ``telemetry.rate_hz``
(5 Hz; the ground station's mission steps on each sample, ``GroundStation``), frames ``camera.frame_hz``
(5 Hz, first frame at a step drawn within one frame period per flight: `frame_phase`), log 10 Hz. Truth reaches the sensors (renderer, gimbal,
telemetry), the operator's click and the log only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from visnav.control.fixedwing import FixedWingAutopilot, InnerGains, scaled_gains
from visnav.geometry.camera import PinholeCamera
from visnav.guidance.figure_eight import FigureEight
from visnav.measurements import Frame, OperatorClick, TelemetrySample, TurnReference
from visnav.navigation.fixedwing import AutopilotNavigator
from visnav.scenarios.config_fixedwing import build_autopilot_sensors
from visnav.sim.clock import rate_divisor
from visnav.mission.geolocation import GeolocationMission
from visnav.navigation.geolocation import GeolocationNavigator
from visnav.sensors.camera import CameraRenderer
from visnav.sensors.gimbal import PitchRollGimbal
from visnav.sensors.telemetry import AutopilotTelemetry
from visnav.sim.fixedwing_common import AircraftAir, scenario_wind, trimmed_aircraft
from visnav.app.condor_parts import floor
from visnav.sim.parts import Hooks, MissionParts, Routing, Timing, VehicleTruth
from visnav.app.rmax_parts import WindEnvironment
from visnav.sim.streams import GEOLOC_STREAMS
from visnav.vehicles.fixedwing import MICRO_REFERENCE_AIRSPEED_MPS, MICRO_REFERENCE_SPAN_M, micro_params, trim
from visnav.world.appearance import another_day
from visnav.world.maps import GeoImage, degrade_reference
from visnav.world.rural import mission_map
from visnav.world.scene import World
from visnav.world.targets import paste_truck
from visnav.analysis.geolocation_metrics import geolocation_metrics


def map_centre(geo: GeoImage) -> np.ndarray:
    n0, n1, e0, e1 = geo.extent_ned()
    return np.array([(n0 + n1) / 2, (e0 + e1) / 2])


def mav_camera(c) -> PinholeCamera:
    """1/4 inch CCD, f = 3.6 mm: 53 deg across the grabbed width; radial distortion k1, k2."""
    f = (c.width_px / 2) / math.tan(math.radians(c.hfov_deg) / 2)
    return PinholeCamera(c.width_px, c.height_px, f, f, (c.width_px - 1) / 2, (c.height_px - 1) / 2,
                         (c.k1, c.k2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))


def mission_reference(m, geo: GeoImage, seed: int) -> GeoImage:
    """The reference image the navigator registers to: the map (``m``: ``world.geo_map``) on another day
    (``world.geo_map.change_m`` > 0, ``world/appearance.another_day``, drawn from the run's 12th random stream),
    degraded (``world.geo_map.ref_*``). The registry (replay) calls it with the recording's seed and gets the loop's
    image."""
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(12)[11])
    day = another_day(geo, rng, m.change_m, m.change_keep, m.relief_level, m.relief_shift_m, m.relief_corr_m)
    return degrade_reference(day, geo.resolution_m, m.ref_gain, m.ref_offset, m.ref_gamma, m.ref_blur_m)


def frame_phase(phase_s: float | None, frame_hz: float, dt: float, rng: np.random.Generator) -> float:
    """Instant of the first frame: ``phase_s`` rounded to the step, or (None) a step drawn uniformly within one
    frame period: the grabber's clock runs independently of the autopilot's telemetry (§7.4, Fig. 7.5), so
    the telemetry sample a frame is recorded with is between 0 and one telemetry period old."""
    n = rate_divisor(frame_hz, dt)
    k = int(rng.integers(0, n)) if phase_s is None else int(round(phase_s / dt)) % n
    return k * dt


def build_navigator(sc, reference: GeoImage, camera: PinholeCamera) -> GeolocationNavigator:
    """The navigator of the scenario ``sc`` (``navigation``, the camera's processing size): used by the loop and
    by the navigator registry (``app/navigators.py``: replay)."""
    r, c = sc.navigation, sc.sensors.camera
    return GeolocationNavigator(reference, camera, hough=r.hough, median_px=r.median_px,
                                search_radius_m=r.search_radius_m, min_quality=r.min_quality,
                                registration_sigma_m=r.sigma_m, map_sigma_m=r.map_sigma_m,
                                gate_prob=r.gate_prob or None, process_size=(c.process_width_px, c.process_height_px),
                                check_rotation=r.check_rotation, scale_search=r.scale_search,
                                rotation_refine_deg=r.rotation_refine_deg, quality_ref=r.quality_ref,
                                rotation_search_deg=r.rotation_search_deg,
                                rotation_search_step_deg=r.rotation_search_step_deg,
                                telemetry_sync=r.telemetry_sync)


def log_samples(record, nav) -> None:
    """The navigator's samples and the RLS estimates after each (stream ``sample``)."""
    for s in nav.samples:
        record("sample", s["t"], reg=s["reg"], map=s["map"], est_reg=s["est_reg"], est_map=s["est_map"],
               ok=s["ok"], reg_used=s["reg_used"], quality=s["quality"], peak=s["peak"],
               hough=s["hough_applied"], heading_tel=s["heading_tel"], heading_used=s["heading_used"],
               height_used=s["height_used"], gps=s["gps"], uv=s["uv"])


class GeolocWorld(AircraftAir):
    """What the MAV's sensors see: its airspeed now (the pitot) and the ground with the truck (the camera)."""

    def __init__(self, vehicle, scene: World) -> None:
        super().__init__(vehicle)
        self.scene = scene


class TelemetrySensor:
    """The autopilot's 5 Hz telemetry (``sensors/telemetry.AutopilotTelemetry``) on the sensor contract."""

    latency_s = 0.0

    def __init__(self, telemetry: AutopilotTelemetry) -> None:
        self.telemetry, self.rate_hz = telemetry, telemetry.rate_hz

    def sample(self, t: float, truth_at, world=None) -> TelemetrySample:
        return self.telemetry.sample(t, truth_at)


class NadirCamera:
    """The gimbal camera's frames (from ``phase_s`` on, default half a frame period) and the operator, who
    clicks the truck in the first frame showing it 40 px inside the image (the click, ``click_sigma_px`` of
    noise, goes with that frame). Logs each frame beside the true pixel (stream ``frame``)."""

    latency_s = 0.0

    def __init__(self, camera, renderer, gimbal, target, frame_hz, click_sigma_px, rng, record, dt,
                 phase_s: float | None = None) -> None:
        self.camera, self.renderer, self.gimbal, self.target = camera, renderer, gimbal, target
        self.rate_hz, self.click_sigma, self.rng, self.record = frame_hz, click_sigma_px, rng, record
        self.phase_s = (rate_divisor(frame_hz, dt) // 2) * dt if phase_s is None else float(phase_s)
        self.clicked, self.frames = False, 0

    def _true_pixel(self, pos: np.ndarray, C_cn: np.ndarray) -> np.ndarray:
        p = (np.array([self.target[0], self.target[1], 0.0]) - pos) @ C_cn
        return self.camera.project(p.reshape(1, 3))[0]

    def sample(self, t: float, truth_at, world):
        s = truth_at(t)
        C_cn = self.gimbal.camera_dcm(s.euler)
        img = self.renderer.render(s.position, C_cn, world.scene)
        uv = self._true_pixel(s.position, C_cn)
        visible = bool(self.camera.in_image(uv.reshape(1, 2), margin=40.0)[0])
        out = ()
        if visible and not self.clicked:  # the operator clicks the truck in the first frame showing it
            self.clicked = True
            click = uv + self.rng.normal(0.0, self.click_sigma, 2)
            out = (OperatorClick(t, click),)
            self.record("click", t, pixel=click, true_pixel=uv)
        frame = Frame(t=t, image=img, index=self.frames)
        self.frames += 1
        res = self.gimbal.residual(s.euler)
        self.record("frame", t, visible=visible, true_pixel=uv, cam_roll_error=res[0], cam_pitch_error=res[1],
                    position=s.position, yaw=s.euler[2])
        return (*out, frame)


class GroundStation:
    """What a telemetry sample does besides reaching the autopilot's navigator: the downlinked copy to the
    geo-location navigator, the telemetry log (beside the true yaw and course), the mission's step (its
    heading-rate reference); and the reference the autopilot flies (``step(t, estimate, health)``: the loop's
    mission at the autopilot's rate)."""

    def __init__(self, telemetry, nav, mission, truth, cfg, airspeed_mps, record) -> None:
        self.telemetry, self.nav, self.geo_mission, self.truth, self.record = telemetry, nav, mission, truth, record
        self.ref = (0.0, cfg.altitude_m, airspeed_mps)

    @property
    def mode(self) -> str:
        return self.geo_mission.mode

    @property
    def done(self) -> bool:
        return self.geo_mission.done

    def on_touchdown(self, t: float) -> None:
        """A fixed wing in the air has no touchdown."""

    def start(self, t: float) -> None:
        self.record("mode", t, mode="search", reason="figure-eight over the believed target position")

    def delivered(self, t: float, m) -> None:
        if not isinstance(m, TelemetrySample):
            return
        self.nav.update(self.telemetry.downlink(m))
        st = self.truth.latest
        self.record("telemetry", t, position=m.position, heading=m.heading, height=m.height,
                    ground_speed=m.ground_speed, true_yaw=st.euler[2],
                    true_course=math.atan2(st.velocity[1], st.velocity[0]))
        self.ref = self.geo_mission.step(t, m, self.nav.registered, self.nav.tracker.started)

    def step(self, t: float, est, health):
        r = self.ref
        return TurnReference(t, r[0], None, est.airspeed, r[1], r[2]), self.geo_mission.mode


class GeolocLogger:
    """Truth and the autopilot's control at 10 Hz; after the run the navigator's samples and results."""

    def __init__(self, vehicle, station, autopilot, nav, target, record) -> None:
        self.vehicle, self.station, self.autopilot, self.nav, self.target = vehicle, station, autopilot, nav, target
        self.record = record

    def __call__(self, step) -> None:
        st, t = step.truth, step.t
        self.record("truth", t, position=st.position, velocity=st.velocity, euler=st.euler,
                    airspeed=self.vehicle.air["Va"])
        m = self.station.geo_mission
        self.record("control", t, mode=m.mode, psidot_ref=self.station.ref[0], phi_ref=self.autopilot.info["phi_ref"],
                    cross_track=getattr(m, "info", {}).get("cross_track", np.nan))

    def finish(self, t: float, completed: bool) -> None:
        """The navigator's samples and RLS estimates, beside the true target (for the report)."""
        nav, record = self.nav, self.record
        record("target", 0.0, position=self.target.copy())
        log_samples(record, nav)
        est, est_m, h = nav.estimate(0.0), nav.estimate(0.0, "map_based"), nav.health(0.0)
        record("geoloc_result", t, sim_time=t if completed else math.nan,
               est_reg=est.position, est_reg_valid=est.valid, est_map=est_m.position, est_map_valid=est_m.valid,
               target_sigma=math.sqrt(max(np.trace(est.covariance), 0.0)) if est.valid else math.nan,
               rejected=h.rejected_samples, reinits=h.reinitializations, frames_tracked=nav.frames_tracked)


@dataclass(frozen=True)
class GeolocExtras:
    """What tests read of a geo-location flight besides its parts."""

    target: np.ndarray  # the truck's position, north and east [m]


def build(ctx) -> MissionParts:
    sc, record = ctx.scenario, ctx.record
    cfg = sc.mission
    dt = sc.run.dt_s
    rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(12)]
    geo = mission_map(sc.world.geo_map)
    t = sc.world.truck
    target = map_centre(geo) + np.array([t.north_m, t.east_m])
    n0, n1, e0, e1 = geo.extent_ned()
    if not (n0 < target[0] < n1 and e0 < target[1] < e1):
        raise ValueError(f"world.truck ({t.north_m}, {t.east_m}) m from the map centre is off the map "
                         f"({n1 - n0:.0f} x {e1 - e0:.0f} m)")
    frames_map = paste_truck(geo, target, t.length_m, t.width_m, math.radians(t.heading_deg))
    reference = mission_reference(sc.world.geo_map, geo, sc.run.seed)
    c, ctl = sc.sensors.camera, sc.control.mav
    va = sc.vehicle.airspeed_mps
    wind = scenario_wind(sc.world, rng[0], cfg.altitude_m, va)
    scene = World(ground=frames_map, surface="map", wind=wind)
    camera = mav_camera(c)
    renderer = CameraRenderer(camera, c.noise_sigma, rng[1])
    axis = cfg.axis_deg if cfg.axis_deg is not None else (0.0 if (n1 - n0) >= (e1 - e0) else 90.0)
    centre = target + rng[2].normal(0.0, 5.0, 2)  # where the operator believes the target is
    path = FigureEight(centre, cfg.half_length_m, math.radians(axis), ctl.l1_m)
    g = sc.sensors.gimbal
    b = rng[3].normal(0.0, math.radians(g.bias_deg), 2)
    ab = rng[7].normal(0.0, math.radians(g.ahrs_bias_deg), 2)
    gimbal = PitchRollGimbal(rng[3], g.lag_s, g.leak, b[0], b[1], math.radians(g.jitter_deg),
                             ahrs_turn_gain=g.ahrs_turn_gain, ahrs_tau_s=g.ahrs_tau_s,
                             ahrs_bias_roll=ab[0], ahrs_bias_pitch=ab[1],
                             deadband=math.radians(g.deadband_deg), limit=math.radians(g.travel_deg))
    tl = sc.sensors.telemetry
    telemetry = AutopilotTelemetry(rng[4], tl.rate_hz, tl.gps_sigma_m, tl.gps_bias_m, 600.0, tl.gps_delay_s,
                                   tl.vel_sigma_mps, tl.baro_bias_m, tl.baro_noise_m, tl.extra_heading_deg,
                                   gps_rate_hz=tl.gps_rate_hz, link_delay_s=tl.link_delay_s)
    nav = build_navigator(sc, reference, camera)
    if ctx.navigator_wrapper is not None:
        nav = ctx.navigator_wrapper(nav)
    mission = GeolocationMission(cfg, path, airspeed_mps=va, recorder=record)
    params = micro_params(sc.vehicle.mass_kg, sc.vehicle.span_m, va)
    start, heading = path.start_pose()
    vehicle = trimmed_aircraft(params, va, np.array([start[0], start[1], -cfg.altitude_m]), heading, wind)
    # the CONDOR inner-loop gains, tuned on the 1.1 m airframe at 13 m/s (rounds 1-4), carried to this one by
    # its control power (the PingWing's surfaces move it 6-40x faster; unscaled, the 50 Hz loops diverge)
    ref = micro_params(sc.vehicle.mass_kg, MICRO_REFERENCE_SPAN_M, MICRO_REFERENCE_AIRSPEED_MPS)
    gains = scaled_gains(InnerGains(bank_limit=math.radians(ctl.bank_limit_deg)), params, va, ref,
                         MICRO_REFERENCE_AIRSPEED_MPS)
    autopilot = FixedWingAutopilot(gains, trim(params, va).controls, rate_hz=50.0)
    # the autopilot flies on its own sensors (AHRS, gyros, accelerometers, pitot) and its telemetry's baro height
    ap_sensors = build_autopilot_sensors(sc.sensors, rng[8:11])
    ap_nav = AutopilotNavigator()
    truth = VehicleTruth(vehicle, dt, 2.0 + tl.gps_delay_s + tl.link_delay_s)
    truth.advance(0.0)
    station = GroundStation(telemetry, nav, mission, truth, cfg, va, record)
    # in this order at one step: telemetry, frame (with the operator's click), the autopilot's sensors
    sensors = {"telemetry": TelemetrySensor(telemetry),
               "camera": NadirCamera(camera, renderer, gimbal, target, c.frame_hz, cfg.click_sigma_px, rng[5], record, dt,
                                     frame_phase(c.frame_phase_s, c.frame_hz, dt, rng[6]))}
    sensors.update({f"autopilot{i}": x for i, x in enumerate(ap_sensors)})
    logger = GeolocLogger(vehicle, station, autopilot, nav, target, record)
    environment = WindEnvironment(lambda: wind, dt, lambda: max(-vehicle.x[2], 1.0),
                                  lambda: max(vehicle.air["Va"], 1.0), initial=wind.velocity_ned(0.0, 0.0))
    return MissionParts(
        world=GeolocWorld(vehicle, scene), sensors=sensors, navigator=nav, mission=station, controller=autopilot,
        vehicle=vehicle, truth=truth, logger=logger, metrics=geolocation_metrics, streams=GEOLOC_STREAMS,
        timing=Timing(mission_hz=autopilot.rate_hz, sensor_grid=True, log_hz=10.0),
        hooks=Hooks(environment=environment, world_step=lambda dt: gimbal.step(dt, vehicle.x[6:9]),
                    after_step=floor(vehicle, 10.0), start=station.start, finish=logger.finish),
        routing=Routing(observers={OperatorClick: nav.update, Frame: nav.update}, on_delivered=station.delivered,
                        flight_navigator=ap_nav),
        camera_model=camera, extras=GeolocExtras(target))
