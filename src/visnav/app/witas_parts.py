"""Builds the WITAS homing mission for the R-MAX loop (registered as ``witas-homing`` in ``app/missions.py``):
the world (procedural rural map, or ``world.witas_map.file``), the navigator's degraded reference map, the
downward camera, the barometer (and compass), the navigator and the PFCM mission over the loop of
``mission/witas.py``. Here, not in ``mission/``, because it builds world and sensors (DESIGN §1).
"""

from __future__ import annotations

import numpy as np

from visnav.guidance.hermite import HermitePath
from visnav.log_schema import register_stream
from visnav.mission.witas import loop_waypoints
from visnav.world.witas_map import make_ground, mission_rngs, reference_map  # noqa: F401  (re-exported)
from visnav.analysis.witas_metrics import witas_metrics
from visnav.app.navigators import NAVIGATORS
from visnav.app.rmax_parts import rmax_parts
from visnav.control.rmax_path import PathFollowingController
from visnav.mission.pfcm import PfcmMission, path_loop_gains
from visnav.scenarios.schema import PfcmControlConfig, PfcmMissionConfig
from visnav.sensors.baro import Compass, baro_sensor
from visnav.sensors.camera import Camera
from visnav.sensors.faults import map_faults
from visnav.world.scene import World

register_stream("note", message=("text", "", "how the scenario was set up (e.g. the loop shrunk to fit the map)"))
register_stream("witas_setup", t=("s", "simulation time", "written once at the start"),
                waypoints=("m", "NED world (origin at the scenario's home)", "loop waypoints"),
                loop_length=("m", "", "length of the loop path"),
                home=("m", "NED world (origin at the scenario's home)", "home (the first waypoint)"),
                map_extent=("m", "NED: north min, north max, east min, east max", "extent of the ground map"),
                reference_resolution=("m/px", "", "resolution of the degraded reference map"))


def build(ctx):
    sc, record = ctx.scenario, ctx.record
    cfg = sc.mission
    pc, cc, mc = cfg.path, sc.sensors.camera, sc.world.witas_map
    rng = mission_rngs(sc.run.seed)
    ground, (sn, se, r, centre) = make_ground(pc, mc, sc.run.seed, cc)
    ground = map_faults(ground, sc.faults, "world")  # [[faults]] feature_poor (issue #18)
    world = World(ground=ground, surface="grass", wind=ctx.scenario_wind(), detail=None)
    reference = map_faults(reference_map(mc, ground), sc.faults, "reference")  # map_offset
    P, T = loop_waypoints(sn, se, r, pc.altitude_m, centre, pc.direction)
    path = HermitePath.from_waypoints(P, T, scale="arc")
    notes = []
    if (sn, se) != (pc.size_north_m, pc.size_east_m):  # the map is smaller than the loop asked for: say so
        r0 = min(pc.corner_radius_m, 0.45 * min(pc.size_north_m, pc.size_east_m))
        full = HermitePath.from_waypoints(*loop_waypoints(pc.size_north_m, pc.size_east_m, r0, pc.altitude_m,
                                                          centre, pc.direction), scale="arc")
        note = (f"the WITAS loop was shrunk to fit the map {mc.file}: {pc.size_north_m:.0f} m x {pc.size_east_m:.0f} m "
                f"-> {sn:.0f} m x {se:.0f} m, loop length {full.length:.0f} m -> {path.length:.0f} m")
        notes.append(note)
        record("note", 0.0, message=note)
    record("witas_setup", 0.0, waypoints=P, loop_length=path.length, home=P[0], map_extent=np.array(
        ground.extent_ned()), reference_resolution=reference.resolution_m)
    # IMU and GPS (lost at gps_loss_s), camera, barometer and (when the file names it) compass of [sensors]
    std = ctx.rmax_sensors(camera=False)
    gps = std["gps"]
    gps.jam_start_s, gps.jam_end_s = cfg.gps_loss_s, None
    model, mount = NAVIGATORS["witas"].camera(sc)
    sensors = {"imu": std["imu"], "gps": gps,
               "camera": Camera(model, mount, rng[1], capture_hz=cc.capture_hz, process_hz=sc.navigation.odometry_hz,
                                noise_sigma=cc.noise_sigma, latency_s=cc.latency_s, delay_s=cc.delay_s),
               "baro": baro_sensor(sc.sensors.baro, rng[2])}
    if "compass" in sc.sensors:
        c = sc.sensors.compass
        sensors["compass"] = Compass(rng[3], c.rate_hz, c.noise_deg, c.bias_deg)
    nav = ctx.navigator("witas", camera=model, mount=mount, reference=reference)
    # the eq. 4.25 gains without the eq. 4.26 inner roll loop: with it (stiffer lateral loop) seeds 1-8 gave
    # odometry drift median 0.88 % (max 1.92) against 0.67 % (1.35) and PMF max 2.98 m (4.53) against
    # 3.22 m (3.86), home error 0.84 against 1.06 m (docs/results-witas.md)
    pf = PfcmMissionConfig(v_cruise_mps=pc.speed_mps, accel_mps2=pc.accel_mps2, settle_s=cfg.settle_s,
                           hold_s=cfg.hold_s, end_tolerance_m=1.0)
    mission = PfcmMission(pf, recorder=record, path=path)
    controller = PathFollowingController(path_loop_gains(pf, PfcmControlConfig(roll_compensator=False)), recorder=record)
    return rmax_parts(ctx, world=world, sensors=sensors, navigator=nav, mission=mission, controller=controller,
                      metrics=witas_metrics, start_position=mission.start_position(), start_yaw=mission.start_yaw,
                      camera_model=model, mount=mount, notes=notes)
