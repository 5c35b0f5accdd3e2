"""CONDOR closed loop (seed 004 ch. 6-7): fixed wing + gimbal camera + vision radius + orbit controller.

Dynamics at ``run.dt_s`` (100 Hz), autopilot at 50 Hz, image processing at ``camera.frame_hz``
(7.5 Hz, §4), log at 10 Hz. The aircraft starts on a GPS loiter of ``loiter_radius_m`` (120 m, ch. 6)
round the tent; at ``switch_time_s`` (once the vision radius is coming in) the custom mode takes over
and flies the vision orbit of ``radius_m`` (110 m) with no GPS. Truth reaches only the sensors and
the log. ``experiment = "ground_test"`` runs the static test of ch. 4 instead (sim/condor_ground.py).
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from visnav.control.fixedwing import FixedWingAutopilot, InnerGains
from visnav.guidance.orbit import OrbitGains, OrbitGuidance, RadiusFilter
from visnav.sensors.condor_camera import TargetCamera, condor_camera, target_outline
from visnav.sensors.gimbal import (Barometer, CameraAhrs, Gimbal, PanPotentiometer, TelemetryLink, centred_coords)
from visnav.sim.log import FlightLog
from visnav.sim.streams import CONDOR_GROUND_STREAMS, CONDOR_STREAMS
from visnav.sim.fixedwing_common import air_data, scenario_wind, trimmed_aircraft
from visnav.vehicles.fixedwing import FixedWingParams, trim
from visnav.vision.blob_tracker import BlobTracker
from visnav.vision.condor_pipeline import VisionRange
from visnav.vision.rectification import altimeter_correction


class CondorSimulation:
    def __init__(self, scenario) -> None:
        self.sc = sc = scenario
        self.cfg = cfg = sc.mission
        self.log = FlightLog(schema=CONDOR_GROUND_STREAMS if cfg.experiment == "ground_test" else CONDOR_STREAMS)
        self.mission = SimpleNamespace(mode="init")
        self.dt = sc.run.dt_s
        self.rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(10)]
        self.controller_name = ("none (static camera)" if cfg.experiment == "ground_test"
                                else cfg.control.orbit.logic)
        self.ground_summary: dict = {}
        self.switched_at: float | None = None
        if cfg.experiment == "orbit":
            self._build_orbit()

    # ------------------------------------------------------------------------------------ build
    def _build_orbit(self) -> None:
        sc, cfg, rng = self.sc, self.cfg, self.rng
        s = cfg.airframe.mass_kg / 13.5  # Aerosonde inertias scaled with the mass (vehicles/fixedwing.py)
        self.params = FixedWingParams(mass=cfg.airframe.mass_kg, Jx=0.8244 * s, Jy=1.135 * s, Jz=1.759 * s,
                                      Jxz=0.1204 * s)
        va = cfg.airframe.airspeed_mps
        o = cfg.control.orbit
        self.trim_level = trim(self.params, va)
        self.target = np.array([cfg.target.north_m, cfg.target.east_m, 0.0])
        h = cfg.control.altitude_m
        a0 = 0.0  # start north of the tent, flying east: a right-hand orbit, tent on the right wing
        pos = self.target + np.array([o.loiter_radius_m * math.cos(a0), o.loiter_radius_m * math.sin(a0), -h])
        self.wind = scenario_wind(sc.world, rng[0], h, va)
        self.vehicle = trimmed_aircraft(self.params, va, pos, a0 + math.pi / 2, self.wind, o.loiter_radius_m)
        c = cfg.camera
        self.camera = condor_camera(c.width_px, c.height_px, c.hfov_deg, c.k1, c.k2, c.crop_dx_px, c.crop_dy_px)
        self.renderer = TargetCamera(self.camera, rng[1], c.noise_sigma)
        self.outline = target_outline(self.target[:2], cfg.target.length_m, cfg.target.width_m,
                                      math.radians(cfg.target.heading_deg))
        g = cfg.gimbal
        self.gimbal = Gimbal(math.pi / 2, -math.atan2(h, o.loiter_radius_m), math.radians(g.pan_rate_deg_s),
                             math.radians(g.tilt_rate_deg_s), g.roll_leak, math.radians(g.roll_bias_deg))
        self.ahrs = CameraAhrs(rng[2], math.radians(g.ahrs_noise_deg), math.radians(g.ahrs_bias_tilt_deg),
                               math.radians(g.ahrs_bias_roll_deg), g.ahrs_accel_gain, g.ahrs_tau_s, g.ahrs_noise_tau_s,
                               g.ahrs_lag_s)
        self.pot = PanPotentiometer(rng[3], math.radians(g.pot_noise_deg))
        a = cfg.altimeter
        self.baro = Barometer(rng[4], a.noise_m, a.t_outside_c, a.c0, a.c1)
        lk = cfg.link
        self.link = TelemetryLink(rng[5], lk.latency_s, lk.drop_prob, lk.outage_rate_hz, lk.outage_s)
        v = cfg.vision
        self.vision = VisionRange(self.camera, math.radians(c.hfov_deg), v.method, v.lut, v.board_distance_m,
                                  v.board_spacing_m)
        self.tracker = BlobTracker()
        ctl = cfg.control
        gains = InnerGains(kp_phi=ctl.kp_phi, kd_phi=ctl.kd_phi, kp_psi=ctl.kp_psi,
                           bank_limit=math.radians(ctl.bank_limit_deg))
        self.autopilot = FixedWingAutopilot(gains, self.trim_level.controls)
        g_orig, g_mod = OrbitGains(o.kp_original, o.kd_original), OrbitGains(o.kp_modified, o.kd_modified)
        self.guidance = OrbitGuidance(o.logic, o.radius_m, va, g_orig, g_mod, o.base_limit)
        # the GPS loiter knows its ground speed: base rate V_GS / R_loiter from a 0.5 s mean of it
        self.loiter = OrbitGuidance("coordinated", o.loiter_radius_m, va, g_orig,
                                    OrbitGains(o.kp_modified, o.kd_modified), o.base_limit, v_avg_tau_s=0.5)
        self.radius = RadiusFilter()
        self.mission.mode = "gps_loiter"

    # ------------------------------------------------------------------------------------ run
    def run(self, progress=None):
        from visnav.analysis.condor_metrics import condor_metrics
        from visnav.sim.loop import RunResult

        wall0 = time.perf_counter()
        error = None
        interrupted = False
        try:
            if self.cfg.experiment == "ground_test":
                from visnav.sim.condor_ground import run_ground_test

                self.ground_summary = run_ground_test(self.cfg, self.rng[6], self.log)
                self.mission.mode = "done"
            else:
                self._run_orbit(progress)
        except Exception as exc:  # keep what we have
            t = getattr(self, "_t", 0.0)
            error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
            self.log.record("error", t, message=error)
        except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
            interrupted = True
        wall = time.perf_counter() - wall0
        return RunResult(scenario=self.sc, log=self.log, metrics=condor_metrics(self, wall, error), error=error,
                         interrupted=interrupted)

    def _frame(self, t: float, x: np.ndarray) -> None:
        """One image: render, track, rectify, send through the link; the operator re-centres the tent."""
        cfg, cam = self.cfg, self.camera
        pan, tilt, roll = self.gimbal.camera_attitude(x[6:9])
        pos = x[0:3]
        img = self.renderer.render(pos, pan, tilt, roll, self.outline)
        tr = self.tracker.track(img)
        r_true = float(math.hypot(*(pos[:2] - self.target[:2])))
        tilt_m, roll_m = self.ahrs.read(tilt, roll)
        h_bar = self.baro.read(-pos[2])
        pan_pot = self.pot.read(self.gimbal.pan)
        R, valid, reason, Xm, Ym, bearing = math.nan, False, "target not tracked", math.nan, math.nan, math.nan
        if tr.ok:
            Xm, Ym = (float(a) for a in centred_coords(cam, np.array([tr.u, tr.v])))
            a = cfg.altimeter
            est = self.vision.estimate(Xm, Ym, h_bar, tilt_m, roll_m, a.t_measured_c, a.c0, a.c1)
            valid, reason = est.valid, est.reason
            if est.valid:
                R, bearing = est.ground_range, est.bearing
                self.link.send(t, (t, R, bearing, pan_pot), 1.0 / cfg.camera.frame_hz)
            k = cfg.gimbal.operator_gain_per_s / cfg.camera.frame_hz
            self.gimbal.command(self.gimbal.pan + k * math.atan(Xm / cam.fx),
                                self.gimbal.tilt + k * math.atan(Ym / cam.fy))
        self.log.record("vision", t, radius=R, true_radius=r_true, valid=valid, tracked=tr.ok, X=Xm, Y=Ym,
                        tilt_error=tilt_m - tilt, roll_error=roll_m - roll, cam_roll=roll, cam_tilt=tilt,
                        pan_pot=pan_pot, pan=self.gimbal.pan, bearing=bearing, reason=reason)
        self._last_vision = (R, bearing, pan_pot) if valid else getattr(self, "_last_vision", None)

    def _run_orbit(self, progress) -> None:
        sc, cfg, dt, log = self.sc, self.cfg, self.dt, self.log
        o, ctl = cfg.control.orbit, cfg.control
        va_des = cfg.airframe.airspeed_mps
        n = int(round(sc.run.duration_s / dt))
        d_ctrl = max(1, int(round(1.0 / (50.0 * dt))))
        d_frame = max(1, int(round(1.0 / (cfg.camera.frame_hz * dt))))
        d_log = max(1, int(round(0.1 / dt)))
        d_wind = max(1, int(round(0.05 / dt)))
        rng = self.rng[7]
        # the operator frames the tent and starts the tracker on it (§2.4)
        x = self.vehicle.x
        pan, tilt, roll = self.gimbal.camera_attitude(x[6:9])
        uv0 = self.renderer.project(x[0:3], pan, tilt, roll, self.target[None])[0]
        self.tracker.start(*uv0)
        log.record("mode", 0.0, mode="gps_loiter",
                   reason=f"GPS loiter at {o.loiter_radius_m:.0f} m, tracker started on the tent")
        wind = self.wind.velocity_ned(0.0, 0.0)
        u = self.trim_level.controls
        v_prev = self.vehicle.velocity_ned()
        accel = np.zeros(3)
        ctrl_log: dict = {}
        h_meas = -float(x[2])
        for k in range(n):
            t = self._t = k * dt
            x = self.vehicle.x
            if k % d_frame == 0:
                self._frame(t, x)
            if k % d_ctrl == 0:
                for (tm, R, _, _) in self.link.receive(t):
                    self.radius.update(tm, R)
                st = self.vehicle.state
                air = self.vehicle.air
                va_meas = float(air["Va"] + rng.normal(0.0, 0.2))
                psidot = (x[10] * math.sin(x[6]) + x[11] * math.cos(x[6])) / math.cos(x[7])
                # what the camera AHRS cannot explain: acceleration minus the airspeed-based centripetal term
                comp = psidot * air["Va"] * np.array([-math.sin(x[8]), math.cos(x[8]), 0.0])
                _, cam_tilt, cam_roll = self.gimbal.camera_attitude(x[6:9])
                self.ahrs.step(d_ctrl * dt, accel - comp, x[8] + self.gimbal.pan, cam_tilt, cam_roll)
                a = cfg.altimeter
                h_meas = altimeter_correction(self.baro.read(-x[2]), a.t_measured_c, a.c0, a.c1)
                m = air_data(self.vehicle, h_meas, va_meas)
                if self.mission.mode == "gps_loiter" and t >= o.switch_time_s and not self.radius.stale(t):
                    self.mission.mode = "vision_orbit"
                    self.switched_at = t
                    log.record("mode", t, mode="vision_orbit", reason="custom mode switched on (vision radius in)")
                if self.mission.mode == "gps_loiter":
                    rel = st.position[:2] - self.target[:2] + rng.normal(0.0, cfg.gps_noise_m, 2) * 0.1
                    R = float(np.hypot(*rel))
                    vel = st.velocity[:2] + rng.normal(0.0, 0.1, 2)
                    Rdot = float(rel @ vel / max(R, 1.0))
                    gs = float(np.hypot(*vel))
                    ref = self.loiter.update(d_ctrl * dt, R, Rdot, gs)
                else:
                    R, Rdot = self.radius.predict(t)
                    ref = self.guidance.update(d_ctrl * dt, R, Rdot, va_meas)
                    if self.radius.stale(t):  # no vision: hold the base rate (never a NaN to the controller)
                        ref = {**ref, "psidot_ref_ail": ref["base"], "err": 0.0,
                               "psidot_ref_rud": None if ref["psidot_ref_rud"] is None else ref["base"]}
                u, info = self.autopilot.command(d_ctrl * dt, m, ref["psidot_ref_ail"], ref["psidot_ref_rud"],
                                                 ref["v_bank"], ctl.altitude_m, va_des)
                ctrl_log = {"R": R, "Rdot": Rdot, "base": ref["base"], "err": ref["err"],
                            "psidot_ref": ref["psidot_ref_ail"], "phi_ref": info["phi_ref"],
                            "psidot": info["psidot"], "bank_hold": info["bank_hold"],
                            "aileron": u.aileron, "elevator": u.elevator, "rudder": u.rudder, "throttle": u.throttle}
            if k % d_log == 0:
                st = self.vehicle.state
                log.record("truth", t, position=st.position, velocity=st.velocity, euler=st.euler,
                           body_rates=st.body_rates, airspeed=self.vehicle.air["Va"], beta=self.vehicle.air["beta"])
                log.record("control", t, mode=self.mission.mode, **ctrl_log)
                log.record("estimate", t, **self._position_estimate(st, h_meas))
                if progress is not None:
                    progress(t, n * dt)
            if k % d_wind == 0:
                wind = self.wind.velocity_ned(t, d_wind * dt, max(-x[2], 1.0), max(self.vehicle.air["Va"], 1.0))
            self.gimbal.step(dt)
            self.vehicle.step(u, dt, wind)
            v_new = self.vehicle.velocity_ned()
            accel = (v_new - v_prev) / dt
            v_prev = v_new
            if -self.vehicle.x[2] < 5.0:
                raise RuntimeError(f"aircraft below 5 m AGL (h = {-self.vehicle.x[2]:.1f} m)")

    def _position_estimate(self, st, h_meas: float) -> dict:
        """GPS-free position relative to the tent from the last vision fix (eq. 3.23-3.24): bearing =
        heading (compass, taken as the AHRS yaw) + pan potentiometer + Psi_VB, aircraft = tent -
        R (cos b, sin b), height from the corrected barometer. Logged, not flown on (as in the thesis)."""
        lv = getattr(self, "_last_vision", None)
        if lv is None:
            return {"position": np.full(3, np.nan), "euler": st.euler, "valid": False}
        R, psi_vb, pan_pot = lv
        b = st.euler[2] + pan_pot + psi_vb
        p = self.target + np.array([-R * math.cos(b), -R * math.sin(b), -h_meas])
        return {"position": p, "euler": st.euler, "valid": True}
