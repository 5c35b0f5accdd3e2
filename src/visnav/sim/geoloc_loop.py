"""Ground-target geo-location flight (seed 002 ch. 7): a 434 g fixed-wing MAV with a nadir camera on a
pitch-roll gimbal flies a figure-eight at 70 m over a truck; frames (720x576) and 5 Hz telemetry go to
the ground station, where ``GeolocationNavigator`` tracks the truck, registers each frame to the
reference image and combines the samples by recursive least squares.

Rates: dynamics ``run.dt_s`` (100 Hz), autopilot 50 Hz, telemetry ``telemetry.rate_hz`` (5 Hz),
frames ``camera.frame_hz`` (5 Hz, half a telemetry period out of phase), log 10 Hz. Truth reaches the
sensors (renderer, gimbal, telemetry), the operator's click and the log only.
"""

from __future__ import annotations

import heapq
import itertools
import math
import time

import numpy as np

from visnav.control.fixedwing import FixedWingAutopilot, InnerGains
from visnav.geometry.camera import PinholeCamera
from visnav.guidance.figure_eight import FigureEight
from visnav.measurements import Frame, OperatorClick, TurnReference
from visnav.navigation.fixedwing import AutopilotNavigator
from visnav.scenarios.config_fixedwing import build_autopilot_sensors
from visnav.sim.clock import rate_divisor
from visnav.vehicles.base import Environment
from visnav.mission.geolocation import GeolocationMission
from visnav.navigation.geolocation import GeolocationNavigator
from visnav.sensors.base import TruthHistory
from visnav.sensors.camera import CameraRenderer
from visnav.sensors.gimbal import PitchRollGimbal
from visnav.sensors.telemetry import AutopilotTelemetry
from visnav.sim.fixedwing_common import AircraftAir, scenario_wind, trimmed_aircraft
from visnav.sim.log import FlightLog
from visnav.sim.streams import GEOLOC_STREAMS
from visnav.vehicles.fixedwing import micro_params, trim
from visnav.world.appearance import another_day
from visnav.world.maps import GeoImage, degrade_reference
from visnav.world.scene import World
from visnav.world.targets import paste_truck


def mission_map(cfg) -> GeoImage:
    """The map of ``mission.map``: a geo-referenced file, or the procedural rural world."""
    if cfg.map.file:
        return GeoImage.load(cfg.map.file)
    from visnav.world.rural import rural_map

    return rural_map(cfg.map.rural_size_m, 0.25, np.random.default_rng(cfg.map.rural_seed))


def map_centre(geo: GeoImage) -> np.ndarray:
    n0, n1, e0, e1 = geo.extent_ned()
    return np.array([(n0 + n1) / 2, (e0 + e1) / 2])


def mav_camera(c) -> PinholeCamera:
    """1/4 inch CCD, f = 3.6 mm: 53 deg across the grabbed width; radial distortion k1, k2."""
    f = (c.width_px / 2) / math.tan(math.radians(c.hfov_deg) / 2)
    return PinholeCamera(c.width_px, c.height_px, f, f, (c.width_px - 1) / 2, (c.height_px - 1) / 2,
                         (c.k1, c.k2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))


class GeolocationSimulation:
    def __init__(self, scenario) -> None:
        self.sc = sc = scenario
        self.cfg = cfg = sc.mission
        self.log = FlightLog(schema=GEOLOC_STREAMS)
        self.dt = sc.run.dt_s
        self.rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(12)]
        rng = self.rng
        geo = mission_map(cfg)
        t = cfg.target
        self.target = map_centre(geo) + np.array([t.north_m, t.east_m])
        n0, n1, e0, e1 = geo.extent_ned()
        if not (n0 < self.target[0] < n1 and e0 < self.target[1] < e1):
            raise ValueError(f"mission.target ({t.north_m}, {t.east_m}) m from the map centre is off the map "
                             f"({n1 - n0:.0f} x {e1 - e0:.0f} m)")
        frames_map = paste_truck(geo, self.target, t.length_m, t.width_m, math.radians(t.heading_deg))
        m = cfg.map
        day = another_day(geo, rng[11], m.change_m, m.change_keep, m.relief_level, m.relief_shift_m, m.relief_corr_m)
        self.reference = degrade_reference(day, geo.resolution_m, m.ref_gain, m.ref_offset, m.ref_gamma, m.ref_blur_m)
        c, ctl = cfg.camera, cfg.control
        va = cfg.airframe.airspeed_mps
        self.wind = scenario_wind(sc.world, rng[0], ctl.altitude_m, va)
        self.world = World(ground=frames_map, surface="map", wind=self.wind)
        self.camera = mav_camera(c)
        self.renderer = CameraRenderer(self.camera, c.noise_sigma, rng[1])
        axis = ctl.axis_deg if ctl.axis_deg is not None else (0.0 if (n1 - n0) >= (e1 - e0) else 90.0)
        centre = self.target + rng[2].normal(0.0, 5.0, 2)  # where the operator believes the target is
        self.path = FigureEight(centre, ctl.half_length_m, math.radians(axis), ctl.l1_m)
        g = cfg.gimbal
        b = rng[3].normal(0.0, math.radians(g.bias_deg), 2)
        ab = rng[7].normal(0.0, math.radians(g.ahrs_bias_deg), 2)
        self.gimbal = PitchRollGimbal(rng[3], g.lag_s, g.leak, b[0], b[1], math.radians(g.jitter_deg),
                                      ahrs_turn_gain=g.ahrs_turn_gain, ahrs_tau_s=g.ahrs_tau_s,
                                      ahrs_bias_roll=ab[0], ahrs_bias_pitch=ab[1],
                                      deadband=math.radians(g.deadband_deg), limit=math.radians(g.travel_deg))
        tl = cfg.telemetry
        self.telemetry = AutopilotTelemetry(rng[4], tl.rate_hz, tl.gps_sigma_m, tl.gps_bias_m, 600.0, tl.gps_delay_s,
                                            tl.vel_sigma_mps, tl.baro_bias_m, tl.baro_noise_m, tl.extra_heading_deg,
                                            gps_rate_hz=tl.gps_rate_hz, link_delay_s=tl.link_delay_s)
        r = cfg.registration
        self.nav = GeolocationNavigator(self.reference, self.camera, hough=r.hough, median_px=r.median_px,
                                        search_radius_m=r.search_radius_m, min_quality=r.min_quality,
                                        registration_sigma_m=r.sigma_m, map_sigma_m=r.map_sigma_m,
                                        gate_prob=r.gate_prob or None, process_size=(c.process_width_px, c.process_height_px),
                                        check_rotation=r.check_rotation, scale_search=r.scale_search,
                                        rotation_refine_deg=r.rotation_refine_deg, quality_ref=r.quality_ref,
                                        rotation_search_deg=r.rotation_search_deg,
                                        rotation_search_step_deg=r.rotation_search_step_deg)
        self.mission = GeolocationMission(cfg, self.path, recorder=self.log.record)
        self.params = micro_params(cfg.airframe.mass_kg, cfg.airframe.span_m)
        start, heading = self.path.start_pose()
        self.vehicle = trimmed_aircraft(self.params, va, np.array([start[0], start[1], -ctl.altitude_m]), heading,
                                        self.wind)
        gains = InnerGains(bank_limit=math.radians(ctl.bank_limit_deg))
        self.autopilot = FixedWingAutopilot(gains, trim(self.params, va).controls, rate_hz=50.0)
        # the autopilot flies on its own sensors (AHRS, gyros, accelerometers, pitot) and its telemetry's baro height
        self.ap_sensors = build_autopilot_sensors(cfg.sensors, rng[8:11])
        self.ap_nav = AutopilotNavigator()
        self.air = AircraftAir(self.vehicle)
        self.truth = TruthHistory(self.dt, 2.0 + cfg.telemetry.gps_delay_s + cfg.telemetry.link_delay_s)
        self.clicked = False
        self.frames: list = []  # (t, visible, true pixel) per frame, for the metrics

    def run(self, progress=None):
        from visnav.analysis.geolocation_metrics import geolocation_metrics
        from visnav.sim.loop import RunResult

        wall0 = time.perf_counter()
        error = None
        try:
            self._run(progress)
        except Exception as exc:  # keep what we have
            error = f"{type(exc).__name__} at t={getattr(self, '_t', 0.0):.2f}s: {exc}"
            self.log.record("error", getattr(self, "_t", 0.0), message=error)
        self._log_samples()
        wall = time.perf_counter() - wall0
        return RunResult(scenario=self.sc, log=self.log, error=error,
                         metrics=geolocation_metrics(self.log, self.sc, wall_time_s=wall, error=error))

    def _log_samples(self) -> None:
        """The navigator's samples and RLS estimates, beside the true target (for the report)."""
        self.log.record("target", 0.0, position=self.target.copy())
        for s in self.nav.samples:
            self.log.record("sample", s["t"], reg=s["reg"], map=s["map"], est_reg=s["est_reg"], est_map=s["est_map"],
                            ok=s["ok"], reg_used=s["reg_used"], quality=s["quality"], peak=s["peak"],
                            hough=s["hough_applied"], heading_tel=s["heading_tel"], heading_used=s["heading_used"],
                            height_used=s["height_used"], gps=s["gps"], uv=s["uv"])
        est, est_m, h = self.nav.estimate(0.0), self.nav.estimate(0.0, "map_based"), self.nav.health(0.0)
        self.log.record("geoloc_result", getattr(self, "_t", 0.0), sim_time=getattr(self, "sim_time", math.nan),
                        est_reg=est.position, est_reg_valid=est.valid, est_map=est_m.position, est_map_valid=est_m.valid,
                        target_sigma=math.sqrt(max(np.trace(est.covariance), 0.0)) if est.valid else math.nan,
                        rejected=h.rejected_samples, reinits=h.reinitializations,
                        frames_tracked=self.nav.frames_tracked)

    def _true_pixel(self, pos: np.ndarray, C_cn: np.ndarray) -> np.ndarray:
        p = (np.array([self.target[0], self.target[1], 0.0]) - pos) @ C_cn
        return self.camera.project(p.reshape(1, 3))[0]

    def _frame(self, t: float) -> None:
        s = self.truth(t)
        C_cn = self.gimbal.camera_dcm(s.euler)
        img = self.renderer.render(s.position, C_cn, self.world)
        uv = self._true_pixel(s.position, C_cn)
        visible = bool(self.camera.in_image(uv.reshape(1, 2), margin=40.0)[0])
        if visible and not self.clicked:  # the operator clicks the truck in the first frame showing it
            self.clicked = True
            click = uv + self.rng[5].normal(0.0, self.cfg.target.click_sigma_px, 2)
            self.nav.update(OperatorClick(t, click))
            self.log.record("click", t, pixel=click, true_pixel=uv)
        self.nav.update(Frame(t=t, image=img, index=len(self.frames)))
        res = self.gimbal.residual(s.euler)
        self.frames.append((t, visible, uv))
        self.log.record("frame", t, visible=visible, true_pixel=uv, cam_roll_error=res[0], cam_pitch_error=res[1],
                        position=s.position, yaw=s.euler[2])

    def _run(self, progress) -> None:
        sc, cfg, dt, log = self.sc, self.cfg, self.dt, self.log
        n = int(round(sc.run.duration_s / dt))
        d_ctrl = rate_divisor(self.autopilot.rate_hz, dt)
        d_tel = rate_divisor(cfg.telemetry.rate_hz, dt)
        d_frame = rate_divisor(cfg.camera.frame_hz, dt)
        off_frame = d_frame // 2
        d_log = rate_divisor(10.0, dt)
        d_wind = rate_divisor(20.0, dt)
        ap_sched = [(s, rate_divisor(s.rate_hz, dt)) for s in self.ap_sensors]
        pending: list = []  # (delivery time, seq, measurement) of the autopilot's sensors
        seq = itertools.count()
        wind = self.wind.velocity_ned(0.0, 0.0)
        u = self.autopilot.trim
        ref = (0.0, cfg.control.altitude_m, cfg.airframe.airspeed_mps)
        tel = None
        info: dict = {"phi_ref": np.nan}
        log.record("mode", 0.0, mode="search", reason="figure-eight over the believed target position")
        for k in range(n):
            t = self._t = k * dt
            self.truth.push(self.vehicle.state)
            if k % d_tel == 0:
                tel = self.telemetry.sample(t, self.truth)
                self.nav.update(self.telemetry.downlink(tel))
                self.ap_nav.update(tel)  # the autopilot's own (undisturbed) sample: its baro height
                st = self.truth.latest
                log.record("telemetry", t, position=tel.position, heading=tel.heading, height=tel.height,
                           ground_speed=tel.ground_speed, true_yaw=st.euler[2],
                           true_course=math.atan2(st.velocity[1], st.velocity[0]))
                ref = self.mission.step(t, tel, self.nav.registered, self.nav.tracker.started)
                if self.mission.done:
                    break
            if k % d_frame == off_frame:
                self._frame(t)
            for sensor, d in ap_sched:
                if k % d == 0:
                    heapq.heappush(pending, (t + sensor.latency_s, next(seq), sensor.sample(t, self.truth, self.air)))
            while pending and pending[0][0] <= t + 1e-9:
                self.ap_nav.update(heapq.heappop(pending)[2])
            if k % d_ctrl == 0:
                est = self.ap_nav.estimate(t)
                u = self.autopilot.command(t, est, TurnReference(t, ref[0], None, est.airspeed, ref[1], ref[2]))
                info = self.autopilot.info
            if k % d_log == 0:
                st = self.truth.latest
                log.record("truth", t, position=st.position, velocity=st.velocity, euler=st.euler,
                           airspeed=self.vehicle.air["Va"])
                log.record("control", t, mode=self.mission.mode, psidot_ref=ref[0], phi_ref=info["phi_ref"], cross_track=getattr(self.mission, "info", {}).get(
                               "cross_track", np.nan))
                if progress is not None:
                    progress(t, n * dt)
            if k % d_wind == 0:
                wind = self.wind.velocity_ned(t, d_wind * dt, max(-self.vehicle.x[2], 1.0),
                                              max(self.vehicle.air["Va"], 1.0))
            self.gimbal.step(dt, self.vehicle.x[6:9])
            self.vehicle.step(u, dt, Environment(wind_ned=wind))
            if -self.vehicle.x[2] < 10.0:
                raise RuntimeError(f"aircraft below 10 m AGL (h = {-self.vehicle.x[2]:.1f} m)")
        self.sim_time = self._t
