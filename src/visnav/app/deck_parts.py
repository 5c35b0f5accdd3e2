"""The ship-deck landing's parts (seed 003) for the one loop (``app/loop.py``): Y6 multirotor, LED camera, IMU.

Every block on the dynamics grid (``sensor_grid``, ``sim/clock.rate_divisor``): the autopilot attitude and
the IMU (``sensors/imu.RollPitchAhrs``, ``AccelGyro``) at ``imu.rate_hz``, the LED camera
(``sensors/led_camera.LedCamera``, a time-stamped ``Frame``) at ``camera.rate_hz``, the mission
(``mission/deck.DeckMission``) and the controller (``control/deck.DeckController``) at 50 Hz, the log at
every step. The navigator (``navigation/deck.DeckNavigator``) finds the blobs itself. ``DeckContact``: the
ground effect over the deck, gear contact (the gear point crossing the deck plane: ``landed`` on the
plate, ``missed`` off it) and the truth streams.

Truth reaches the navigator only as the explicit NavInit of the thesis' Vicon start (``filter.init =
"truth"``: the motion-capture sensor's relative state plus noise of its sigmas,
``sensors/deck_observer.py``; the navigator logs its start itself, ``nav_init``) and the mission only
through the same sensor (restarts from the Vicon, and the safety pilot's view with ``start.pilot = "truth"``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from visnav.control.deck import DeckController
from visnav.estimation import deck as dm
from visnav.geometry.camera import PinholeCamera
from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import NavInit, RelativeStateSample, VehicleState
from visnav.mission.deck import DeckMission
from visnav.navigation.deck import DeckNavConfig, DeckNavigator
from visnav.sensors.deck_observer import RelativeStateSensor
from visnav.sensors.imu import AccelGyro, RollPitchAhrs
from visnav.sensors.led_camera import LedCamera
from visnav.sim.clock import rate_divisor
from visnav.sim.parts import Hooks, IntegrityStatus, MissionParts, Routing, Timing, VehicleTruth
from visnav.sim.streams import DECK_STREAMS
from visnav.vehicles.base import Environment
from visnav.vehicles.multirotor import Multirotor, MultirotorParams
from visnav.world.wind import SteadyWind, Wind
from visnav.world.deck import DeckMotion, DeckWorld
from visnav.analysis.deck_metrics import deck_metrics
from visnav.analysis.integrity_metrics import integrity_metrics

#: the mission and controller rate [Hz]
CONTROL_HZ = 50.0
#: 1-sigma of the thesis' Vicon start (position, attitude, velocity, deck rates), per axis
VICON_SIGMA = np.repeat([0.03, np.radians(3), 0.05, np.radians(2)], 3)


@dataclass(frozen=True)
class TrueCalibration:
    """What the real system is, against the calibration the filter assumes (issue 30): the true lights (deck frame),
    camera intrinsics and rotation body -> camera, and the IMU's starting biases. Drawn once per run from a
    generator of its own (``seed``, so that turning one error off leaves the others' draws unchanged)."""

    lights: np.ndarray
    camera: PinholeCamera
    T_cam: np.ndarray
    accel_bias: np.ndarray
    gyro_bias: np.ndarray
    rng: np.random.Generator  # the bias random walk's steps
    deck_tilt: tuple = (0.0, 0.0)  # the deck's departure from level, roll and pitch [rad]

    @classmethod
    def draw(cls, sc) -> "TrueCalibration":
        rng = np.random.default_rng([int(sc.run.seed), 3003])
        n = rng.standard_normal((4 + len(sc.world.deck.lights_m), 3))  # every draw made, whatever the sigmas
        c, imu = sc.sensors.camera, sc.sensors.imu
        lights = np.asarray(sc.world.deck.lights_m, float) + sc.world.deck.light_survey_error_m * n[4:]
        nominal = c.pinhole()
        f = nominal.fx * (1.0 + c.focal_error_frac * n[0, 0])
        pp = c.principal_point_error_px * n[0, 1:]
        camera = replace(nominal, fx=f, fy=f * nominal.fy / nominal.fx, cx=nominal.cx + pp[0], cy=nominal.cy + pp[1])
        # the camera turned by a small rotation of its own axes: T_cam,true = R(delta) T_cam
        T_cam = Rotation.from_rotvec(np.radians(c.misalignment_deg) * n[1]).as_matrix() @ c.rotation()
        tilt_n = np.random.default_rng([int(sc.run.seed), 3005]).standard_normal(2)  # its own: the others unchanged
        tilt = np.radians(sc.world.deck.level_error_deg) * tilt_n
        return cls(lights, camera, T_cam, imu.accel_bias_mps2 * n[2], np.radians(imu.gyro_bias_deg_s) * n[3],
                   np.random.default_rng([int(sc.run.seed), 3004]), tuple(tilt.tolist()))


@dataclass(frozen=True)
class DeckExtras:
    """What tests read of a deck run besides its parts."""

    landing_point: np.ndarray  # where the gear should touch, deck frame [m]
    frame_steps: int  # dynamics steps per camera frame
    params: MultirotorParams


class MultirotorTruth(VehicleTruth):
    """The Y6's true state on the dynamics grid, as the ``VehicleState`` the sensors read."""

    def state(self, t: float) -> VehicleState:
        s = self.vehicle.state
        return VehicleState(t=t, position=s.position.copy(), velocity=s.velocity.copy(), euler=s.euler.copy(),
                            body_rates=np.asarray(s.body_rates, float).copy(),
                            specific_force=np.asarray(s.specific_force, float).copy())


class DeckContact:
    """The Y6 over the moving deck: the deck's state at the step (``world.motion``), the gear's height over
    the deck plane (ground effect, contact), the touchdown and the truth streams (relative state, vehicle, deck)."""

    def __init__(self, vehicle: Multirotor, world: DeckWorld, truth: MultirotorTruth, mission, nav, params, cfg,
                 record) -> None:
        self.vehicle, self.world, self.truth, self.mission, self.nav = vehicle, world, truth, mission, nav
        self.params, self.cfg, self.record = params, cfg, record
        self.landing_point = np.asarray(cfg.guidance.landing_point_m, float)
        self._t, self._ds = None, None
        self._gear_h = None
        self.status = IntegrityStatus(record)

    def deck(self, t: float):
        if t != self._t:
            self._t, self._ds = t, self.world.motion.state(t)
        return self._ds

    def gear_height(self, ds) -> float:
        """Height of the gear above the deck plane, along the deck normal (kept for the last vehicle and deck
        states: the log, the contact check and the environment ask for the same step's)."""
        s = self.vehicle.state
        last = self._gear_h
        if last is None or last[0] is not s or last[1] is not ds:
            last = self._gear_h = (s, ds, float(-(ds.C[:, 2] @ (self.vehicle.gear_point() - ds.position))))
        return last[2]

    def environment(self, k: int, t: float) -> Environment:
        p = self.params
        # the air of the lab is still (world.wind: zero) unless a wind_gust fault wraps it (sensors/faults.py)
        return Environment(wind_ned=self.world.wind.velocity_ned(t, 0.0),
                           rotor_height_m=self.gear_height(self.deck(t)) + p.gear_offset + p.rotor_height)

    def contact(self, t: float) -> bool:
        ds = self.deck(t)
        if self.gear_height(ds) > 0.0:
            return False
        s = self.vehicle.state
        gear = self.vehicle.gear_point()
        w_n = ds.C @ ds.body_rates
        v_point = ds.velocity + np.cross(w_n, gear - ds.position)
        rel = s.velocity - v_point
        zb, zd = euler_to_dcm(s.euler)[:, 2], ds.C[:, 2]
        g_d = ds.C.T @ (gear - ds.position)
        pos_err = float(np.hypot(*(g_d[:2] - self.landing_point[:2])))  # from the desired landing location
        on = bool(np.all(np.abs(g_d[:2]) <= self.world.size_m / 2))  # on the square plate
        speed = float(np.linalg.norm(rel))
        self.record("touchdown", t, rel_speed=speed, pos_err=pos_err, on_deck=on, gear_deck_m=g_d[:2].copy(),
                    att_mismatch=float(np.degrees(np.arccos(np.clip(zb @ zd, -1, 1)))))
        self.mission.on_touchdown(t, on, f"gear contact at {speed:.2f} m/s")
        return True

    def log(self, step) -> None:
        t, cmd = step.t, step.command
        ds = self.deck(t)
        x_true = self.world.relative(self.truth.latest, ds)
        est = step.estimate  # the loop's estimate of this step (the mission's and the controller's)
        if est is None or est.t != t:
            est = self.nav.estimate(t)
        x, P = est.state, est.covariance
        err = dm.residual_x(x_true[None, :], x[None, :])[0]
        try:
            nees = float(err @ np.linalg.solve(P, err))
        except np.linalg.LinAlgError:
            nees = float("nan")
        s = self.vehicle.state
        record = self.record
        record("truth", t, position=x_true[0:3], euler=x_true[3:6], velocity=x_true[6:9], deck_rates=x_true[9:12])
        record("estimate", t, position=x[0:3], euler=x[3:6], velocity=x[6:9], deck_rates=x[9:12],
               sigma=np.sqrt(np.maximum(np.diag(P), 0.0)), nees=nees, mode=self.mission.mode)
        record("vehicle", t, position=s.position.copy(), euler=s.euler.copy(), velocity=s.velocity.copy(),
               gear_height=self.gear_height(ds))
        record("deck", t, position=ds.position, euler=ds.euler)
        record("command", t, roll=cmd.roll, pitch=cmd.pitch, yaw_rate=cmd.yaw_rate, throttle=cmd.throttle)
        self.status(t, step.health, self.mission.mode)  # the navigator's integrity (issue #18)


def build(ctx) -> MissionParts:
    sc, record = ctx.scenario, ctx.record
    wrap = ctx.navigator_wrapper or (lambda nav: nav)
    cfg = sc.mission
    dt = sc.run.dt_s
    rng = ctx.rng  # 8 generators of the run's seed (as the R-MAX loop's)
    d, c = sc.world.deck, sc.sensors.camera
    true = TrueCalibration.draw(sc)  # the filter keeps the nominal calibration (DeckNavConfig.from_mission)
    motion = (DeckMotion.static(tilt=true.deck_tilt) if d.motion == "static"
              else DeckMotion.from_sea_state(d.sea_state, rng[0], d.sinusoids, d.motion_scale, tilt=true.deck_tilt))
    world = DeckWorld(motion, true.lights, d.size_m, c.extra_blobs_deck_m, c.hide_light, c.hide_after_s)
    world.wind = Wind(SteadyWind(0.0, 0.0))  # still air (a wind_gust fault adds its gust)

    v = sc.vehicle
    params = MultirotorParams(mass=v.mass_kg, thrust_to_weight=v.thrust_to_weight,
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
    vehicle = Multirotor(params, motion.state(0.0).position + rel, yaw=yaw0)
    truth = MultirotorTruth(vehicle, dt, horizon_s=1.0)
    truth.advance(0.0)

    # sensors, in the order they are sampled at one instant (attitude before the IMU sample it rotates)
    imu = sc.sensors.imu
    accel_gyro = AccelGyro(rng[4], imu.accel_noise_mps2, imu.gyro_noise_rad_s, rate_hz=imu.rate_hz,
                           accel_bias=true.accel_bias, gyro_bias=true.gyro_bias,
                           accel_bias_walk=imu.accel_bias_walk_mps2_sqrt_s,
                           gyro_bias_walk=np.radians(imu.gyro_bias_walk_deg_s_sqrt_s), bias_rng=true.rng)
    sensors = {"ahrs": RollPitchAhrs(rng[5], imu.attitude_noise_deg, rate_hz=imu.rate_hz,
                                     leveled_on=accel_gyro if imu.ahrs_leveled_on_accel else None),
               "imu": accel_gyro,
               "camera": LedCamera(true.camera, true.T_cam, np.asarray(c.position_m, float), rng[2],
                                   noise_gray=c.noise_gray, centroid_noise_px=c.centroid_noise_px, jitter_rng=rng[6],
                                   rate_hz=c.rate_hz, time_offset_s=c.time_offset_s)}
    frame_steps = rate_divisor(c.rate_hz, dt)
    mocap = None
    if sc.navigation.init == "truth":  # the thesis' Vicon (start and restarts)
        mocap = sensors["mocap"] = RelativeStateSensor(rng[3], VICON_SIGMA, CONTROL_HZ, source="mocap")
    if st.pilot == "truth":  # the safety pilot before the hand-over
        sensors["pilot"] = RelativeStateSensor(rng[7], np.r_[[st.pilot_position_noise_m] * 3, np.zeros(9)], CONTROL_HZ,
                                               source="pilot")

    nav = wrap(DeckNavigator(DeckNavConfig.from_mission(sc, frame_steps * dt), recorder=record))
    # the navigator's start (it logs it, nav_init, as it logs its restarts): the Vicon's view, or eq. 5.12-5.17
    if mocap is not None:
        seen = mocap.sample(0.0, truth, world)
        nav.initialize(NavInit(t=0.0, source="truth+noise", state=seen.state, covariance=np.diag(VICON_SIGMA**2)))
    else:
        nav.initialize(NavInit(t=0.0, source="static"))
    d_ctrl = rate_divisor(CONTROL_HZ, dt)
    mission = DeckMission(cfg, nav, filter_cfg=sc.navigation, hold_point=rel, gear_offset=params.gear_offset, period_s=d_ctrl * dt,
                          recorder=record, deck=d, gains=sc.control.deck)
    hov = params.hover_throttle
    controller = DeckController(cfg.guidance, sc.control.deck, v.max_tilt_deg, params.gear_offset, cfg.guidance.overshoot_moving_m,
                                hover_throttle_1m=hov,
                                hover_throttle_ground=hov / params.ground_effect(v.gear_offset_m + params.rotor_height),
                                rate_hz=1.0 / (d_ctrl * dt), recorder=record)
    deck = DeckContact(vehicle, world, truth, mission, nav, params, cfg, record)
    return MissionParts(
        world=world, sensors=sensors, navigator=nav, mission=mission, controller=controller, vehicle=vehicle,
        truth=truth, logger=deck.log, metrics=deck_metrics, streams=DECK_STREAMS,
        timing=Timing(mission_hz=1.0 / (d_ctrl * dt), sensor_grid=True, log_hz=1.0 / dt, end_inclusive=True),
        hooks=Hooks(environment=deck.environment, contact=deck.contact),
        routing=Routing(observers={RelativeStateSample: mission.observe}),
        extra_metrics=(integrity_metrics,), extras=DeckExtras(deck.landing_point, frame_steps, params))
