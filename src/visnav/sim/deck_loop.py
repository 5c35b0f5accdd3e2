"""Closed-loop ship-deck landing (seed 003): sensors -> latency queue -> navigator -> mission -> controller -> Y6.

One dynamics step of ``run.dt_s``; every block at an integer divisor of it (``sim/clock.rate_divisor``):
the autopilot attitude and the IMU (``sensors/imu.RollPitchAhrs``, ``AccelGyro``) at ``imu.rate_hz``,
the LED camera (``sensors/led_camera.LedCamera``, a time-stamped ``Frame``) at ``camera.rate_hz``, the
mission (``mission/deck.DeckMission``) and the controller (``control/deck.DeckController``) at 50 Hz.
Each measurement is stamped with the instant it describes and delivered after its sensor's latency
through a heap (as ``sim/loop.py``); the navigator (``navigation/deck.DeckNavigator``) finds the blobs
itself. Gear contact (the gear point crossing the deck plane: ``landed`` on the plate, ``missed`` off
it) and the truth streams stay here.

Truth reaches the navigator only as the explicit, logged ``NavInit`` of the thesis' Vicon start
(``filter.init = "truth"``: the motion-capture sensor's relative state plus noise of its sigmas,
``sensors/deck_observer.py``) and the mission only through the same sensor (restarts from the Vicon,
and the safety pilot's view with ``start.pilot = "truth"``).
"""

from __future__ import annotations

import heapq
import itertools
import time

import numpy as np

from visnav.control.deck import DeckController
from visnav.estimation import deck as dm
from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import AttitudeThrustCommand, NavInit, RelativeStateSample, VehicleState
from visnav.mission.deck import DeckMission
from visnav.navigation.deck import DeckNavConfig, DeckNavigator
from visnav.sensors.base import TruthHistory
from visnav.sensors.deck_observer import RelativeStateSensor
from visnav.sensors.imu import AccelGyro, RollPitchAhrs
from visnav.sensors.led_camera import LedCamera
from visnav.sim.clock import rate_divisor
from visnav.sim.log import FlightLog
from visnav.sim.loop import RunResult
from visnav.sim.streams import DECK_STREAMS
from visnav.vehicles.base import Environment
from visnav.vehicles.multirotor import Multirotor, MultirotorParams
from visnav.world.deck import DeckMotion, DeckWorld, relative_state

#: the mission and controller rate [Hz]
CONTROL_HZ = 50.0
#: 1-sigma of the thesis' Vicon start (position, attitude, velocity, deck rates), per axis
VICON_SIGMA = np.repeat([0.03, np.radians(3), 0.05, np.radians(2)], 3)


class DeckSimulation:
    def __init__(self, scenario, navigator_wrapper=None):
        """``navigator_wrapper(nav) -> nav``, when given, wraps the navigator the loop and the mission talk to."""
        self.sc = sc = scenario
        wrap = navigator_wrapper or (lambda nav: nav)
        cfg = self.cfg = sc.mission
        self.dt = dt = sc.run.dt_s
        self.log = log = FlightLog(schema=DECK_STREAMS)
        rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(8)]
        d, c = cfg.deck, cfg.camera
        motion = (DeckMotion.static() if d.motion == "static"
                  else DeckMotion.from_sea_state(d.sea_state, rng[0], d.sinusoids, d.motion_scale))
        self.world = DeckWorld(motion, d.lights_m, d.size_m, c.extra_blobs_deck_m, c.hide_light, c.hide_after_s)
        self.landing_point = np.asarray(cfg.guidance.landing_point_m, float)

        v = cfg.vehicle
        self.params = MultirotorParams(mass=v.mass_kg, thrust_to_weight=v.thrust_to_weight,
                                       attitude_omega=v.attitude_bandwidth_rad_s, attitude_zeta=v.attitude_damping,
                                       thrust_tau=v.thrust_time_constant_s, drag=v.drag_per_s, gear_offset=v.gear_offset_m)
        # start: behind the deck (azimuth 180 deg +- heading offset), camera pointing at the deck
        st = cfg.start
        dist = rng[1].uniform(st.distance_min_m, st.distance_max_m)
        elev = np.radians(rng[1].uniform(st.elevation_min_deg, st.elevation_max_deg))
        az = np.pi + np.radians(rng[1].uniform(-st.heading_offset_max_deg, st.heading_offset_max_deg))
        if d.motion == "moving":  # §5.3.5: nominally 1 m above and 1 m behind the deck
            dist, elev, az = np.sqrt(2.0), np.radians(45.0), np.pi
        rel = dist * np.array([np.cos(elev) * np.cos(az), np.cos(elev) * np.sin(az), -np.sin(elev)])
        yaw0 = np.arctan2(-rel[1], -rel[0]) + np.radians(rng[1].uniform(-5, 5))
        self.vehicle = Multirotor(self.params, motion.state(0.0).position + rel, yaw=yaw0)
        self.history = TruthHistory(dt, horizon_s=1.0)
        self.history.push(self._truth(0.0))

        # sensors, in the order they are sampled at one instant (attitude before the IMU sample it rotates)
        imu = cfg.imu
        self.ahrs = RollPitchAhrs(rng[5], imu.attitude_noise_deg, rate_hz=imu.rate_hz)
        self.imu = AccelGyro(rng[4], imu.accel_noise_mps2, imu.gyro_noise_rad_s, rate_hz=imu.rate_hz)
        self.camera = LedCamera(c.pinhole(), c.rotation(), np.asarray(c.position_m, float), rng[2],
                                noise_gray=c.noise_gray, centroid_noise_px=c.centroid_noise_px, jitter_rng=rng[6],
                                rate_hz=c.rate_hz)
        self.frame_steps = rate_divisor(c.rate_hz, dt)
        sensors = [self.ahrs, self.imu, self.camera]
        self.mocap = self.pilot = None
        if cfg.filter.init == "truth":  # the thesis' Vicon (start and restarts)
            self.mocap = RelativeStateSensor(rng[3], VICON_SIGMA, CONTROL_HZ, source="mocap")
            sensors.append(self.mocap)
        if st.pilot == "truth":  # the safety pilot before the hand-over
            self.pilot = RelativeStateSensor(rng[7], np.r_[[st.pilot_position_noise_m] * 3, np.zeros(9)], CONTROL_HZ,
                                             source="pilot")
            sensors.append(self.pilot)
        self.sensors = [(s, rate_divisor(s.rate_hz, dt)) for s in sensors]

        self.nav = wrap(DeckNavigator(DeckNavConfig.from_mission(cfg, self.frame_steps * dt), recorder=log.record))
        if self.mocap is not None:
            seen = self.mocap.sample(0.0, self.history, self.world)
            init = NavInit(t=0.0, source="truth+noise", state=seen.state, covariance=np.diag(VICON_SIGMA**2))
        else:
            init = NavInit(t=0.0, source="static")  # eq. 5.12-5.17
        self.nav.initialize(init)
        d_ctrl = rate_divisor(CONTROL_HZ, dt)
        self.control_steps = d_ctrl
        self.mission = DeckMission(cfg, self.nav, hold_point=rel, gear_offset=self.params.gear_offset,
                                   period_s=d_ctrl * dt, recorder=log.record)
        hov = self.params.hover_throttle
        self.controller = DeckController(cfg.guidance, v.max_tilt_deg, self.params.gear_offset,
                                         cfg.guidance.overshoot_moving_m, hover_throttle_1m=hov,
                                         hover_throttle_ground=hov / self.params.ground_effect(
                                             v.gear_offset_m + self.params.rotor_height),
                                         rate_hz=1.0 / (d_ctrl * dt), recorder=log.record)
        self._queue: list = []
        self._seq = itertools.count()

    # --- truth ---------------------------------------------------------------------------------
    def _truth(self, t: float) -> VehicleState:
        s = self.vehicle.state
        return VehicleState(t=t, position=s.position.copy(), velocity=s.velocity.copy(), euler=s.euler.copy(),
                            body_rates=np.asarray(s.body_rates, float).copy(),
                            specific_force=np.asarray(s.specific_force, float).copy())

    def _gear_height(self, ds) -> float:
        """Height of the gear above the deck plane, along the deck normal."""
        return float(-(ds.C[:, 2] @ (self.vehicle.gear_point() - ds.position)))

    # --- the loop ------------------------------------------------------------------------------
    def run(self, progress=None) -> RunResult:
        from visnav.analysis.deck_metrics import deck_metrics

        sc, dt, log = self.sc, self.dt, self.log
        n = int(round(sc.run.duration_s / dt))
        cmd = AttitudeThrustCommand(0.0, 0.0, 0.0, 0.0, self.params.hover_throttle)
        wall0 = time.perf_counter()
        error = None
        interrupted = False
        t = 0.0
        q = self._queue
        try:
            for k in range(n + 1):
                t = k * dt
                if k > 0:
                    self.history.push(self._truth(t))
                for s, div in self.sensors:  # sensors -> latency queue
                    if k % div == 0:
                        m = s.sample(t, self.history, self.world)
                        heapq.heappush(q, (m.t + s.latency_s, next(self._seq), m))
                while q and q[0][0] <= t + 1e-9:  # deliveries -> navigator (and the observers -> mission)
                    m = heapq.heappop(q)[2]
                    if isinstance(m, RelativeStateSample):
                        self.mission.observe(m)
                    else:
                        self.nav.update(m)
                if k % self.control_steps == 0:
                    est = self.nav.estimate(t)
                    ref, _ = self.mission.step(t, est, self.nav.health(t))
                    cmd = self.controller.command(t, est, ref)
                ds = self.world.motion.state(t)
                self._log(t, ds, cmd)
                if self._contact(t, ds):
                    break
                rotor_h = self._gear_height(ds) + self.params.gear_offset + self.params.rotor_height
                self.vehicle.step(cmd, dt, Environment(rotor_height_m=rotor_h))
                if progress is not None:
                    progress(t, sc.run.duration_s)
        except Exception as exc:  # noqa: BLE001 - keep what the run has
            error = f"{type(exc).__name__} at t={t:.2f}s: {exc}"
            log.record("error", t, message=error)
        except KeyboardInterrupt:  # Ctrl-C: stop here and keep what the run has
            interrupted = True
        wall = time.perf_counter() - wall0
        metrics = deck_metrics(log, sc, wall_time_s=wall, error=error)
        return RunResult(scenario=sc, log=log, metrics=metrics, error=error, interrupted=interrupted)

    def _contact(self, t, ds) -> bool:
        if self._gear_height(ds) > 0.0:
            return False
        s = self.vehicle.state
        gear = self.vehicle.gear_point()
        w_n = ds.C @ ds.body_rates
        v_point = ds.velocity + np.cross(w_n, gear - ds.position)
        rel = s.velocity - v_point
        zb, zd = euler_to_dcm(s.euler)[:, 2], ds.C[:, 2]
        g_d = ds.C.T @ (gear - ds.position)
        pos_err = float(np.hypot(*(g_d[:2] - self.landing_point[:2])))  # from the desired landing location
        on = bool(np.all(np.abs(g_d[:2]) <= self.cfg.deck.size_m / 2))  # on the square plate
        speed = float(np.linalg.norm(rel))
        self.log.record("touchdown", t, rel_speed=speed, pos_err=pos_err, on_deck=on,
                        att_mismatch=float(np.degrees(np.arccos(np.clip(zb @ zd, -1, 1)))))
        self.mission.on_touchdown(t, on, f"gear contact at {speed:.2f} m/s")
        return True

    def _log(self, t, ds, cmd):
        x_true = relative_state(self.history.latest, ds)
        est = self.nav.estimate(t)
        x, P = est.state, est.covariance
        err = dm.residual_x(x_true[None, :], x[None, :])[0]
        try:
            nees = float(err @ np.linalg.solve(P, err))
        except np.linalg.LinAlgError:
            nees = float("nan")
        s = self.vehicle.state
        self.log.record("truth", t, position=x_true[0:3], euler=x_true[3:6], velocity=x_true[6:9], deck_rates=x_true[9:12])
        self.log.record("estimate", t, position=x[0:3], euler=x[3:6], velocity=x[6:9], deck_rates=x[9:12],
                        sigma=np.sqrt(np.maximum(np.diag(P), 0.0)), nees=nees, mode=self.mission.mode)
        self.log.record("vehicle", t, position=s.position.copy(), euler=s.euler.copy(), velocity=s.velocity.copy(),
                        gear_height=self._gear_height(ds))
        self.log.record("deck", t, position=ds.position, euler=ds.euler)
        self.log.record("command", t, roll=cmd.roll, pitch=cmd.pitch, yaw_rate=cmd.yaw_rate, throttle=cmd.throttle)
