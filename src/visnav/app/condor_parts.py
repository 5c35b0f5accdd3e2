"""CONDOR's parts (seed 004 ch. 6-7) for the one loop (``app/loop.py``): fixed wing + gimbal camera + vision
radius + orbit controller.

Sensors -> latency queue -> ``CondorNavigator`` -> ``CondorMission`` -> ``FixedWingAutopilot`` ->
``FixedWingModel``, every block on the dynamics grid (``run.dt_s``, 100 Hz): autopilot sensors (AHRS, gyros +
accelerometers, pitot, baro) and the camera's AHRS at 50 Hz, compass 10 Hz, GPS 5 Hz; the gimbal camera and
the pan potentiometer at ``camera.frame_hz`` (7.5 Hz, §4); mission and autopilot at 50 Hz; log at 10 Hz.
The navigator's ground-station half turns frames into radius fixes, which cross the telemetry uplink
(``sensors/link.Link``: latency + drops, the loop's ``uplink``) back to its on-board half. The operator
re-centres the tent with the gimbal from the tracked pixel (``Operator``, after each frame). Truth reaches
only the sensors, the log, the operator's first click on the tent and the surveyed tent position (``NavInit``,
logged). ``experiment = "ground_test"`` is the static test of ch. 4 (``sim/condor_ground.py``): nothing
flies, the loop's ``evaluate`` part runs it inside the same run scaffold.
"""

from __future__ import annotations

import math

import numpy as np

from visnav.control.fixedwing import FixedWingAutopilot, InnerGains
from visnav.measurements import Frame, NavInit, OperatorClick
from visnav.mission.condor import CondorMission, GroundTestMission
from visnav.navigation.condor import CondorNavigator, RadiusFilter
from visnav.scenarios.config_fixedwing import build_autopilot_sensors
from visnav.sensors.baro import Compass, baro_sensor
from visnav.sensors.condor_camera import GimbalCamera, TargetCamera, condor_camera, target_outline
from visnav.sensors.gimbal import CameraAhrs, Gimbal, PanPotentiometer
from visnav.sensors.gps import Gps
from visnav.sensors.link import Link
from visnav.sim.fixedwing_common import AircraftAir, scenario_wind, trimmed_aircraft
from visnav.sim.parts import CurrentTruth, GroundTest, Hooks, IntegrityStatus, MissionParts, Routing, Timing
from visnav.app.rmax_parts import WindEnvironment
from visnav.sim.streams import CONDOR_GROUND_STREAMS, CONDOR_STREAMS
from visnav.vehicles.fixedwing import FixedWingParams, trim
from visnav.vision.condor_pipeline import VisionRange
from visnav.analysis.condor_metrics import condor_metrics
from visnav.analysis.integrity_metrics import integrity_metrics
from visnav.sim.condor_ground import run_ground_test


class CondorWorld(AircraftAir):
    """What CONDOR's sensors see besides the aircraft's state: the gimbal (its true pan, tilt and the
    camera's attitude), the tent's outline, and the aircraft's airspeed at the current step."""

    def __init__(self, gimbal: Gimbal, outline: np.ndarray, vehicle, wind) -> None:
        super().__init__(vehicle)
        self.gimbal, self.outline = gimbal, outline
        self.wind = wind  # the scenario's wind (a wind_gust fault wraps it after the build)


def build_navigator(sc, camera) -> CondorNavigator:
    """The navigator of the scenario ``sc`` (its own tuning, ``navigation``; what it assumes of the camera,
    the altimeter's eq. 2.1 correction and the GPS)."""
    c, a, n = sc.sensors.camera, sc.sensors.baro, sc.navigation
    v = n.vision
    vision = VisionRange(camera, math.radians(c.hfov_deg), v.method, v.lut, v.board_distance_m, v.board_spacing_m)
    return CondorNavigator(vision, camera, (a.t_measured_c, a.c0, a.c1),
                           radius_filter=RadiusFilter(n.radius_alpha, n.radius_beta, n.radius_stale_s),
                           gps_gain=n.gps_gain, radius_sigma_pct=n.radius_sigma_pct,
                           heading_sigma_deg=n.heading_sigma_deg, gps_sigma_m=sc.sensors.gps.sigma_m,
                           carry_sigma_mps=n.carry_sigma_mps, gps_accel_mps2=n.gps_accel_mps2)


class Operator:
    """The ground station's operator and its log: the vision result beside truth after each frame; the
    tent re-centred with the gimbal from the tracked pixel (§2.4); the first click on the tent (the start)."""

    def __init__(self, sensors, nav, camera, renderer, gimbal, vehicle, truth, target, mission, record) -> None:
        self.sensors, self.nav, self.camera, self.renderer, self.gimbal = sensors, nav, camera, renderer, gimbal
        self.vehicle, self.truth, self.target, self.mission, self.record = vehicle, truth, target, mission, record

    def start(self, t: float) -> None:
        """The operator's first click on the tent starts the tracker; the mission starts."""
        x = self.vehicle.x
        pan, tilt, roll = self.gimbal.camera_attitude(x[6:9])
        uv0 = self.renderer.project(x[0:3], pan, tilt, roll, self.target[None])[0]
        self.nav.update(OperatorClick(t, uv0))
        self.record("click", t, pixel=uv0)
        self.mission.start(t)

    def after(self, t: float, m) -> None:
        if not isinstance(m, Frame):
            return
        rec, cam = self.nav.last_vision, self.camera
        # the truth when the frame was taken: now (CONDOR's frames arrive in the step they are taken); not at its
        # stamp, which a camera clock that jumped puts ahead (sensors/faults: clock_jump)
        s = self.truth(t)
        _, tilt, roll = self.gimbal.camera_attitude(s.euler)
        r_true = float(math.hypot(*(s.position[:2] - self.target[:2])))
        self.record("vision", m.t, radius=rec["radius"], true_radius=r_true, valid=rec["valid"],
                    tracked=rec["tracked"], X=rec["X"], Y=rec["Y"], tilt_error=rec["tilt"] - tilt,
                    roll_error=rec["roll"] - roll, cam_roll=roll, cam_tilt=tilt, pan_pot=rec["pan_pot"],
                    pan=self.gimbal.pan, bearing=rec["bearing"], reason=rec["reason"])
        if rec["tracked"]:
            k = self.sensors.gimbal.operator_gain_per_s / self.sensors.camera.frame_hz
            self.gimbal.command(self.gimbal.pan + k * math.atan(rec["X"] / cam.fx),
                                self.gimbal.tilt + k * math.atan(rec["Y"] / cam.fy))


class CondorLogger:
    """The CONDOR streams at 10 Hz: truth (with air data), control (mission + autopilot), the navigator's estimate."""

    def __init__(self, vehicle, mission, autopilot, nav, record) -> None:
        self.vehicle, self.mission, self.autopilot, self.nav, self.record = vehicle, mission, autopilot, nav, record
        self.status = IntegrityStatus(record)

    def __call__(self, step) -> None:
        t, u, record = step.t, step.command, self.record
        st = self.vehicle.state
        info = self.autopilot.info
        record("truth", t, position=st.position, velocity=st.velocity, euler=st.euler, body_rates=st.body_rates,
               airspeed=self.vehicle.air["Va"], beta=self.vehicle.air["beta"])
        record("control", t, mode=self.mission.mode, **self.mission.info, phi_ref=info["phi_ref"],
               psidot=info["psidot"], bank_hold=info["bank_hold"], aileron=u.aileron, elevator=u.elevator,
               rudder=u.rudder, throttle=u.throttle)
        # the estimate the step's health was assessed with and the controller flew on (issue #30): asked again after
        # the mission's step it is the one after a source switch, beside the health (and HPL) from before it
        e = step.estimate if step.estimate is not None and step.estimate.t == t else self.nav.estimate(t)
        record("estimate", t, position=e.position, euler=e.attitude, valid=e.valid, source=e.source,
               radius=e.radius, radius_valid=e.radius_valid, airspeed=e.airspeed, height=e.height)
        self.status(t, step.health, self.mission.mode)  # the navigator's integrity (issue #18)


def floor(vehicle, min_agl_m: float):
    """After each step: below ``min_agl_m`` the run stops with an error."""

    def check(t: float, t_prev: float) -> bool:
        if -vehicle.x[2] < min_agl_m:
            raise RuntimeError(f"aircraft below {min_agl_m:.0f} m AGL (h = {-vehicle.x[2]:.1f} m)")
        return False

    return check


def build(ctx) -> MissionParts | GroundTest:
    sc, record = ctx.scenario, ctx.record
    cfg = sc.mission
    rng = [np.random.default_rng(s) for s in np.random.SeedSequence(sc.run.seed).spawn(14)]
    if cfg.experiment == "ground_test":
        mission = GroundTestMission()

        def evaluate(progress=None) -> None:
            run_ground_test(sc, rng[6], ctx.record)
            mission.finish(0.0)

        return GroundTest(mission=mission, metrics=condor_metrics, evaluate=evaluate, streams=CONDOR_GROUND_STREAMS)
    dt = sc.run.dt_s
    sn = sc.sensors
    s = sc.vehicle.mass_kg / 13.5  # Aerosonde inertias scaled with the mass (vehicles/fixedwing.py)
    params = FixedWingParams(mass=sc.vehicle.mass_kg, Jx=0.8244 * s, Jy=1.135 * s, Jz=1.759 * s, Jxz=0.1204 * s)
    va = sc.vehicle.airspeed_mps
    o, tent = cfg.orbit, sc.world.tent
    trim_level = trim(params, va)
    target = np.array([tent.north_m, tent.east_m, 0.0])
    h = cfg.altitude_m
    a0 = 0.0  # start north of the tent, flying east: a right-hand orbit, tent on the right wing
    pos = target + np.array([o.loiter_radius_m * math.cos(a0), o.loiter_radius_m * math.sin(a0), -h])
    wind = scenario_wind(sc.world, rng[0], h, va)
    vehicle = trimmed_aircraft(params, va, pos, a0 + math.pi / 2, wind, o.loiter_radius_m)
    c = sn.camera
    camera = condor_camera(c.width_px, c.height_px, c.hfov_deg, c.k1, c.k2, c.crop_dx_px, c.crop_dy_px)
    renderer = TargetCamera(camera, rng[1], c.noise_sigma)
    outline = target_outline(target[:2], tent.length_m, tent.width_m, math.radians(tent.heading_deg))
    g = sn.gimbal
    gimbal = Gimbal(math.pi / 2, -math.atan2(h, o.loiter_radius_m), math.radians(g.pan_rate_deg_s),
                    math.radians(g.tilt_rate_deg_s), g.roll_leak, math.radians(g.roll_bias_deg))
    world = CondorWorld(gimbal, outline, vehicle, wind)
    # order matters at equal time stamps: the camera's AHRS, pot and baro reach the ground station before the frame
    ap = build_autopilot_sensors(sn, rng[8:11])
    sensors = dict(zip(("ahrs", "imu", "pitot"), ap))  # (the names [[faults]] target: imu)
    sensors.update({
        "baro": baro_sensor(sn.baro, rng[4]),
        "compass": Compass(rng[11], sn.compass.rate_hz, sn.compass.noise_deg, sn.compass.bias_deg),
        "gps": Gps(rng[12], **sn.gps.model_dump(exclude={"kind"})),
        "camera_ahrs": CameraAhrs(rng[2], math.radians(g.ahrs_noise_deg), math.radians(g.ahrs_bias_tilt_deg),
                                  math.radians(g.ahrs_bias_roll_deg), g.ahrs_accel_gain, g.ahrs_tau_s,
                                  g.ahrs_noise_tau_s, g.ahrs_lag_s, rate_hz=g.ahrs_rate_hz),
        "pan_pot": PanPotentiometer(rng[3], math.radians(g.pot_noise_deg), rate_hz=c.frame_hz),
        "camera": GimbalCamera(renderer, c.frame_hz),
    })
    lk = sn.link
    link = Link(rng[5], lk.latency_s, lk.drop_prob, lk.outage_rate_hz, lk.outage_s)
    nav = build_navigator(sc, camera)
    if ctx.navigator_wrapper is not None:
        nav = ctx.navigator_wrapper(nav)
    ctl = sc.control.condor
    gains = InnerGains(kp_phi=ctl.kp_phi, kd_phi=ctl.kd_phi, kp_psi=ctl.kp_psi, bank_limit=math.radians(ctl.bank_limit_deg))
    autopilot = FixedWingAutopilot(gains, trim_level.controls, rate_hz=50.0)
    mission = CondorMission(cfg, ctl.orbit, nav, airspeed_mps=va, recorder=record)
    truth = CurrentTruth(vehicle)
    operator = Operator(sn, nav, camera, renderer, gimbal, vehicle, truth, target, mission, record)
    environment = WindEnvironment(lambda: world.wind, dt, lambda: max(-vehicle.x[2], 1.0),
                                  lambda: max(vehicle.air["Va"], 1.0), initial=wind.velocity_ned(0.0, 0.0))
    return MissionParts(
        world=world, sensors=sensors, navigator=nav, mission=mission, controller=autopilot, vehicle=vehicle,
        truth=truth, logger=CondorLogger(vehicle, mission, autopilot, nav, record), metrics=condor_metrics,
        streams=CONDOR_STREAMS, timing=Timing(mission_hz=autopilot.rate_hz, sensor_grid=True, log_hz=10.0),
        hooks=Hooks(environment=environment, world_step=gimbal.step, after_step=floor(vehicle, 5.0),
                    start=operator.start),
        routing=Routing(uplink=link, on_delivered=operator.after),
        nav_init=NavInit(0.0, "survey", position=target.copy()), camera_model=camera,
        extra_metrics=(integrity_metrics,))
