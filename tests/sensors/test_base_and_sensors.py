"""TruthHistory interpolation, the laser's failure modes and the unknown-delay model."""

import numpy as np

from visnav.geometry.mounts import FixedMount
from visnav.measurements import VehicleState
from visnav.sensors.base import TruthHistory
from visnav.sensors.imu import Imu
from visnav.sensors.rangefinder import LaserRangeFinder, Sonar


def _state(t, x=0.0, h=10.0, pitch=0.0):
    return VehicleState(t=t, position=np.array([x, 0.0, -h]), velocity=np.zeros(3),
                        euler=np.array([0.0, pitch, 0.0]), body_rates=np.zeros(3),
                        specific_force=np.array([0.0, 0.0, -9.81]))


def test_truth_history_interpolates_and_clamps():
    h = TruthHistory(0.01, horizon_s=0.5)
    for k in range(200):
        h.push(_state(k * 0.01, x=k * 0.01 * 2.0))  # 2 m/s north
    assert abs(h(1.734).position[0] - 3.468) < 1e-9
    assert abs(h(1.99).position[0] - 3.98) < 1e-9
    oldest = 1.99 - (h.n - 1) * 0.01  # the buffer holds n steps
    assert abs(h(0.0).position[0] - 2 * oldest) < 1e-9  # older than the buffer: clamps to the oldest


def test_imu_unknown_delay_reports_the_past_with_todays_stamp():
    h = TruthHistory(0.01)
    for k in range(100):
        h.push(_state(k * 0.01, pitch=0.1 * k * 0.01))  # pitch ramps at 0.1 rad/s
    imu = Imu(np.random.default_rng(0), accel_noise=0, gyro_noise=0, accel_bias=0, gyro_bias=0,
              attitude_noise_deg=0, delay_s=0.1)
    _, att = imu.sample(0.9, h)
    assert att.t == 0.9
    assert abs(att.euler[1] - 0.1 * 0.8) < 1e-9


def test_laser_range_along_60deg_axis_and_min_range():
    h = TruthHistory(0.01)
    h.push(_state(0.0, h=10.0))
    mount = FixedMount.depressed(60.0)
    las = LaserRangeFinder(np.random.default_rng(0), mount, sigma0_m=0, sigma_per_m=0, dropout=0)
    r = las.sample(0.0, h)
    assert abs(r.range - 10.0 / np.sin(np.deg2rad(60))) < 1e-9 and r.beam_offset == 0
    h2 = TruthHistory(0.01)
    h2.push(_state(0.0, h=0.5))
    assert np.isnan(las.sample(0.0, h2).range)  # below 0.7 m: no return


def test_laser_searches_plus_minus_3deg_then_gives_up():
    h = TruthHistory(0.01)
    h.push(_state(0.0, h=10.0))
    mount = FixedMount.depressed(60.0)
    rng = np.random.default_rng(1)
    las = LaserRangeFinder(rng, mount, sigma0_m=0, sigma_per_m=0, dropout=0.5)
    offs = []
    for _ in range(2000):
        r = las.sample(0.0, h)
        if np.isfinite(r.range):
            off = r.beam_offset
            offs.append(off)
            # the reported range belongs to the beam that returned
            expect = 10.0 / np.sin(np.deg2rad(60) + off)
            assert abs(r.range - expect) < 1e-9
    offs = np.rad2deg(offs)
    assert np.max(np.abs(offs)) <= 3 + 1e-9
    # P(no return) = 0.5^7 (7 beams): about 16 of 2000
    assert 0 < 2000 - len(offs) < 45
    assert abs(np.mean(offs == 0) - 0.5 / (1 - 0.5**7)) < 0.05


def test_sonar_reads_height_when_level():
    h = TruthHistory(0.01)
    h.push(_state(0.0, h=1.3))
    s = Sonar(np.random.default_rng(0), sigma_m=0.0)
    assert abs(s.sample(0.0, h).range - 1.3) < 1e-12


def test_camera_unknown_delay_renders_the_past_with_todays_stamp():
    """An image ``delay_s`` older than its stamp (seed 000 §5.1: the frame paired with the attitude
    at the end of its processing) is rendered from the pose of t − delay_s."""
    from visnav.geometry.camera import PinholeCamera
    from visnav.sensors.camera import Camera

    h = TruthHistory(0.01)
    for k in range(100):
        h.push(_state(k * 0.01, x=k * 0.01 * 2.0))  # 2 m/s north
    seen = []
    cam = Camera(PinholeCamera.ideal(64, 48, 100.0), FixedMount.depressed(60.0), np.random.default_rng(0),
                 delay_s=0.05)
    cam.renderer.render = lambda cam_pos, C_cn, world: seen.append(cam_pos) or np.zeros((48, 64), np.uint8)
    frame = cam.sample(0.9, h, None)
    ref = Camera(PinholeCamera.ideal(64, 48, 100.0), FixedMount.depressed(60.0), np.random.default_rng(0))
    ref.renderer.render = cam.renderer.render
    ref.sample(0.85, h, None)
    assert frame.t == 0.9
    assert np.allclose(seen[0], seen[1]) and abs(seen[0][0] - seen[1][0]) < 1e-12
    assert not np.allclose(seen[0], FixedMount.depressed(60.0).camera_pose(h(0.9).position, np.eye(3))[0])
