"""Builds the pad landing (seed 002 ch. 6) for the R-MAX loop (registered as ``pad-landing`` in
``app/missions.py``): the pad board in the world, the pan-tilt camera on its spring platform, the split-rate
IMU, the navigator and the mission of ``mission/pad.py``. Here, not in ``mission/``, because it builds
sensors and world (DESIGN §1).
"""

from __future__ import annotations

import math

import numpy as np

from visnav.geometry.pad import PadLayout
from visnav.mission.pad import PadLandingMission
from visnav.analysis.pad_report import pad_metrics
from visnav.app.rmax_parts import rmax_parts
from visnav.control.rmax import RmaxPositionController
from visnav.geometry.camera import PinholeCamera
from visnav.sensors.imu import Imu
from visnav.sensors.pad_camera import PadCamera
from visnav.sensors.pantilt import PanTiltUnit, SpringPlatform
from visnav.sensors.split_imu import SplitRateImu
from visnav.world.pad import pad_board


def build(ctx):
    sc, record = ctx.scenario, ctx.record
    cfg = sc.mission
    cc, fc = sc.sensors.camera, sc.navigation
    pc, pt, pf = sc.world.pad, cc.pantilt, cc.platform
    world = ctx.textured_world()  # the ground around the pad (the board is drawn over it)
    rng = [np.random.default_rng(s) for s in np.random.SeedSequence([sc.run.seed, 15]).spawn(5)]
    layout = PadLayout(tuple(pc.legs_m), tuple(pc.ring_ratio), tuple(pc.inner_ratio))
    shadow = (pc.shadow_direction_deg, pc.shadow_offset_m, pc.shadow_gain) if pc.shadow else None
    board = pad_board(layout, pc.resolution_m, rng[0], shadow=shadow)
    cam = PinholeCamera.ideal(cc.width, cc.height, cc.focal_px)
    ptu = PanTiltUnit(pan=0.0, tilt=math.radians(pt.initial_tilt_deg),
                      pan_limits=tuple(math.radians(a) for a in pt.pan_limits_deg),
                      tilt_limits=tuple(math.radians(a) for a in pt.tilt_limits_deg),
                      max_rate=math.radians(pt.max_rate_dps), servo_gain=pt.servo_gain,
                      encoder_resolution=math.radians(pt.encoder_resolution_deg), lever_arm=tuple(cc.lever_arm_m),
                      head_offset=tuple(cc.head_offset_m))
    platform = SpringPlatform(pf.misalignment_deg, pf.natural_hz, pf.damping)
    camera = PadCamera(cam, board, ptu, platform, rng[1], rate_hz=cc.rate_hz, noise_sigma=cc.noise_sigma,
                       latency_s=cc.latency_s, blackout_height_m=cfg.blackout_height_m, blackout_s=cfg.blackout_s,
                       lighting_change_s=pc.lighting_change_s, lighting_gain=pc.lighting_gain, recorder=record)
    s = sc.sensors.imu
    imu = Imu(rng[2], rate_hz=fc.gyro_hz, accel_noise=s.accel_noise, gyro_noise=s.gyro_noise, accel_bias=s.accel_bias,
              gyro_bias=s.gyro_bias, attitude_noise_deg=s.attitude_noise_deg, latency_s=s.latency_s, delay_s=s.delay_s)
    nav = ctx.navigator("pad", camera=cam, ptu=ptu, layout=layout)
    mission = PadLandingMission(cfg, recorder=record)
    # GPS-free: the split-rate IMU (with the attitude solution) and the pan-tilt camera only
    return rmax_parts(ctx, world=world, sensors={"imu": SplitRateImu(imu, fc.accel_hz), "camera": camera}, navigator=nav,
                      mission=mission, controller=RmaxPositionController(), metrics=pad_metrics,
                      start_position=mission.start_position(), start_yaw=0.0, camera_model=cam)
