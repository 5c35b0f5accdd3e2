"""CONDOR closed loop (seed 004 ch. 6-7): fixed wing + gimbal camera + vision radius + orbit controller.

The loop is the block diagram: sensors -> latency queue -> ``CondorNavigator`` -> ``CondorMission``
-> ``FixedWingAutopilot`` -> ``FixedWingModel``. Dynamics at ``run.dt_s`` (100 Hz); autopilot sensors
(AHRS, gyros + accelerometers, pitot, baro) and the camera's AHRS at 50 Hz, compass 10 Hz, GPS 5 Hz; the
gimbal camera and the pan potentiometer at ``camera.frame_hz`` (7.5 Hz, §4); mission and autopilot at 50 Hz;
log at 10 Hz. The navigator's ground-station half turns frames into radius fixes, which cross the
telemetry uplink (``sensors/link.Link``: latency + drops) back to its on-board half. The operator
re-centres the tent with the gimbal from the tracked pixel. Truth reaches only the sensors, the
log, the operator's first click on the tent and the surveyed tent position (``NavInit``, logged).
``experiment = "ground_test"`` runs the static test of ch. 4 instead (sim/condor_ground.py).
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
import numpy as np

from visnav.control.fixedwing import FixedWingAutopilot, InnerGains
from visnav.measurements import Frame, NavInit, OperatorClick
from visnav.mission.condor import CondorMission, GroundTestMission
from visnav.scenarios.config_fixedwing import build_autopilot_sensors
from visnav.sensors.baro import Baro, Compass
from visnav.sensors.condor_camera import GimbalCamera, TargetCamera, condor_camera, target_outline
from visnav.sensors.gimbal import CameraAhrs, Gimbal, PanPotentiometer
from visnav.sensors.gps import Gps
from visnav.sensors.link import Link
from visnav.sim.clock import rate_divisor
from visnav.sim.condor_parts import build_navigator  # noqa: F401  (also imported from here)
from visnav.sim.fixedwing_common import AircraftAir, scenario_wind, trimmed_aircraft
from visnav.sim.log import FlightLog
from visnav.sim.streams import CONDOR_GROUND_STREAMS, CONDOR_STREAMS
from visnav.vehicles.base import Environment
from visnav.vehicles.fixedwing import FixedWingParams, trim


class CondorWorld(AircraftAir):
    """What CONDOR's sensors see besides the aircraft's state: the gimbal (its true pan, tilt and the
    camera's attitude), the tent's outline, and the aircraft's airspeed at the current step."""

    def __init__(self, gimbal: Gimbal, outline: np.ndarray, vehicle) -> None:
        super().__init__(vehicle)
        self.gimbal, self.outline = gimbal, outline


class CurrentTruth:
    """``truth_at`` for sensors that describe the current step (every CONDOR sensor: no unknown delay):
    the vehicle's state now, built only at the steps where something samples it."""

    def __init__(self, vehicle) -> None:
        self.vehicle, self.now = vehicle, 0.0

    def __call__(self, t: float):
        if abs(t - self.now) > 1e-9:
            raise ValueError(f"CONDOR truth is asked for t={t:.4f}s at step t={self.now:.4f}s: a sensor that "
                             f"describes another instant needs sensors/base.TruthHistory")
        return self.vehicle.state


class CondorSimulation:
    def __init__(self, scenario, navigator_wrapper=None) -> None:
        """``navigator_wrapper(nav) -> nav``, when given, wraps the navigator the loop and the mission talk to."""
        self.sc = sc = scenario
        self._wrap = navigator_wrapper or (lambda nav: nav)
        self.cfg = cfg = sc.mission
        self.log = FlightLog(schema=CONDOR_GROUND_STREAMS if cfg.experiment == "ground_test" else CONDOR_STREAMS)
        self.mission = GroundTestMission()
        self.dt = sc.run.dt_s
        self.rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(14)]
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
        outline = target_outline(self.target[:2], cfg.target.length_m, cfg.target.width_m,
                                 math.radians(cfg.target.heading_deg))
        g = cfg.gimbal
        self.gimbal = Gimbal(math.pi / 2, -math.atan2(h, o.loiter_radius_m), math.radians(g.pan_rate_deg_s),
                             math.radians(g.tilt_rate_deg_s), g.roll_leak, math.radians(g.roll_bias_deg))
        self.world = CondorWorld(self.gimbal, outline, self.vehicle)
        a, sn = cfg.altimeter, cfg.sensors
        # order matters at equal time stamps: the camera's AHRS, pot and baro reach the ground station before the frame
        self.sensors = [
            *build_autopilot_sensors(sn, rng[8:11]),
            Baro(rng[4], a.rate_hz, a.noise_m, 0.0, t_outside_c=a.t_outside_c, c0=a.c0, c1=a.c1),
            Compass(rng[11], sn.compass.rate_hz, sn.compass.noise_deg, sn.compass.bias_deg),
            Gps(rng[12], sn.gps.rate_hz, cfg.gps_noise_m, sn.gps.velocity_noise_mps, sn.gps.latency_s),
            CameraAhrs(rng[2], math.radians(g.ahrs_noise_deg), math.radians(g.ahrs_bias_tilt_deg),
                       math.radians(g.ahrs_bias_roll_deg), g.ahrs_accel_gain, g.ahrs_tau_s, g.ahrs_noise_tau_s,
                       g.ahrs_lag_s, rate_hz=g.ahrs_rate_hz),
            PanPotentiometer(rng[3], math.radians(g.pot_noise_deg), rate_hz=c.frame_hz),
            GimbalCamera(self.renderer, c.frame_hz),
        ]
        lk = cfg.link
        self.link = Link(rng[5], lk.latency_s, lk.drop_prob, lk.outage_rate_hz, lk.outage_s)
        self.nav = self._wrap(build_navigator(cfg, self.camera))
        ctl = cfg.control
        gains = InnerGains(kp_phi=ctl.kp_phi, kd_phi=ctl.kd_phi, kp_psi=ctl.kp_psi,
                           bank_limit=math.radians(ctl.bank_limit_deg))
        self.autopilot = FixedWingAutopilot(gains, self.trim_level.controls, rate_hz=50.0)
        self.mission = CondorMission(cfg, self.nav, recorder=self.log.record)
        self.truth = CurrentTruth(self.vehicle)
        self._queue: list = []
        self._seq = itertools.count()

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

                run_ground_test(self.cfg, self.rng[6], self.log)
                self.mission.finish(0.0)
            else:
                self._run_orbit(progress)
        except Exception as exc:  # keep what we have
            t = getattr(self, "_t", 0.0)
            error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
            self.log.record("error", t, message=error)
        except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
            interrupted = True
        wall = time.perf_counter() - wall0
        return RunResult(scenario=self.sc, log=self.log, metrics=condor_metrics(self.log, self.sc, wall_time_s=wall, error=error),
                         error=error, interrupted=interrupted)

    def _push(self, t_deliver: float, m) -> None:
        heapq.heappush(self._queue, (t_deliver, next(self._seq), m))

    def _deliver(self, t: float) -> None:
        """Everything due by ``t`` to the navigator; radius fixes it makes go up the telemetry link."""
        q = self._queue
        while q and q[0][0] <= t + 1e-9:
            m = heapq.heappop(q)[2]
            self.nav.update(m)
            if isinstance(m, Frame):
                self._after_frame(m)
            for fix in self.nav.pop_uplink():
                t_del = self.link.transmit(t, fix)
                self.log.record("uplink", fix.t, sent_at=t, delivered=t_del is not None, radius=fix.range)
                if t_del is not None:
                    self._push(t_del, fix)

    def _after_frame(self, f: Frame) -> None:
        """Log the ground station's result beside truth; the operator re-centres the tent (§2.4)."""
        rec, cam = self.nav.last_vision, self.camera
        s = self.truth(f.t)
        _, tilt, roll = self.gimbal.camera_attitude(s.euler)
        r_true = float(math.hypot(*(s.position[:2] - self.target[:2])))
        self.log.record("vision", f.t, radius=rec["radius"], true_radius=r_true, valid=rec["valid"],
                        tracked=rec["tracked"], X=rec["X"], Y=rec["Y"], tilt_error=rec["tilt"] - tilt,
                        roll_error=rec["roll"] - roll, cam_roll=roll, cam_tilt=tilt, pan_pot=rec["pan_pot"],
                        pan=self.gimbal.pan, bearing=rec["bearing"], reason=rec["reason"])
        if rec["tracked"]:
            k = self.cfg.gimbal.operator_gain_per_s / self.cfg.camera.frame_hz
            self.gimbal.command(self.gimbal.pan + k * math.atan(rec["X"] / cam.fx),
                                self.gimbal.tilt + k * math.atan(rec["Y"] / cam.fy))

    def _run_orbit(self, progress) -> None:
        sc, dt, log = self.sc, self.dt, self.log
        n = int(round(sc.run.duration_s / dt))
        d_ctrl = rate_divisor(self.autopilot.rate_hz, dt)
        d_log = rate_divisor(10.0, dt)
        d_wind = rate_divisor(20.0, dt)
        sched = [(s, rate_divisor(s.rate_hz, dt)) for s in self.sensors]
        # the tent's surveyed position (the loiter's centre) and the operator's first click on it (§2.4)
        self.nav.initialize(NavInit(0.0, "survey", position=self.target.copy()))
        log.record("nav_init", 0.0, source="survey", position=self.target.copy())
        x = self.vehicle.x
        pan, tilt, roll = self.gimbal.camera_attitude(x[6:9])
        uv0 = self.renderer.project(x[0:3], pan, tilt, roll, self.target[None])[0]
        self.nav.update(OperatorClick(0.0, uv0))
        log.record("click", 0.0, pixel=uv0)
        self.mission.start(0.0)
        wind = self.wind.velocity_ned(0.0, 0.0)
        u = self.trim_level.controls
        for k in range(n):
            t = self._t = k * dt
            self.truth.now = t
            for sensor, d in sched:
                if k % d == 0:
                    m = sensor.sample(t, self.truth, self.world)
                    if m is not None:
                        self._push(t + sensor.latency_s, m)
            self._deliver(t)
            if k % d_ctrl == 0:
                est = self.nav.estimate(t)
                ref, mode = self.mission.step(t, est, self.nav.health(t))
                u = self.autopilot.command(t, est, ref)
            if k % d_log == 0:
                st = self.vehicle.state
                info = self.autopilot.info
                log.record("truth", t, position=st.position, velocity=st.velocity, euler=st.euler,
                           body_rates=st.body_rates, airspeed=self.vehicle.air["Va"], beta=self.vehicle.air["beta"])
                log.record("control", t, mode=self.mission.mode, **self.mission.info, phi_ref=info["phi_ref"],
                           psidot=info["psidot"], bank_hold=info["bank_hold"], aileron=u.aileron,
                           elevator=u.elevator, rudder=u.rudder, throttle=u.throttle)
                e = self.nav.estimate(t)
                log.record("estimate", t, position=e.position, euler=e.attitude, valid=e.valid, source=e.source,
                           radius=e.radius, radius_valid=e.radius_valid, airspeed=e.airspeed, height=e.height)
                if progress is not None:
                    progress(t, n * dt)
            if k % d_wind == 0:
                wind = self.wind.velocity_ned(t, d_wind * dt, max(-self.vehicle.x[2], 1.0),
                                              max(self.vehicle.air["Va"], 1.0))
            self.gimbal.step(dt)
            self.vehicle.step(u, dt, Environment(wind_ned=wind))
            if -self.vehicle.x[2] < 5.0:
                raise RuntimeError(f"aircraft below 5 m AGL (h = {-self.vehicle.x[2]:.1f} m)")
