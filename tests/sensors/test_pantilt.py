"""Pan-tilt unit, spring platform, split-rate IMU, the pad camera (sensors/pantilt.py, split_imu.py,
pad_camera.py) and the tracking geometry of navigation/pad.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from visnav.geometry.rotations import euler_to_dcm
from visnav.measurements import VehicleState
from visnav.navigation.pad import pointing_angles
from visnav.sensors.imu import Imu
from visnav.sensors.pantilt import PanTiltUnit, SpringPlatform
from visnav.sensors.split_imu import SplitRateImu


def _state(t, rates=(0.0, 0.0, 0.0), euler=(0.0, 0.0, 0.0)):
    return VehicleState(t=t, position=np.array([0.0, 0.0, -10.0]), velocity=np.zeros(3), euler=np.array(euler, float),
                        body_rates=np.array(rates, float), specific_force=np.array([0.0, 0.0, -9.81]))


def test_ptu_rate_and_angle_limits():
    ptu = PanTiltUnit(pan=0.0, tilt=math.radians(90), max_rate=math.radians(60), servo_gain=50.0,
                      tilt_limits=(math.radians(10), math.radians(120)))
    ptu.point_at(0.0, math.radians(90), math.radians(200))  # tilt beyond its limit
    ptu.advance(0.5)
    pan, tilt = ptu.angles
    assert pan == pytest.approx(math.radians(30), abs=1e-9)  # rate-limited: 60 deg/s x 0.5 s
    assert math.radians(118) < tilt <= math.radians(120)  # the clamped target, nearly reached
    ptu.advance(3.0)
    assert ptu.angles[0] == pytest.approx(math.radians(90), abs=1e-6)
    assert ptu.angles[1] == pytest.approx(math.radians(120), abs=1e-9)


def test_ptu_encoders_are_quantised():
    ptu = PanTiltUnit(pan=0.12345, tilt=1.0, encoder_resolution=math.radians(0.1))
    p, t = ptu.encoders()
    q = math.radians(0.1)
    assert abs(p - 0.12345) <= q / 2 and abs(round(p / q) * q - p) < 1e-12
    assert abs(t - 1.0) <= q / 2


def test_camera_offset_includes_the_head_offset():
    ptu = PanTiltUnit(pan=0.0, tilt=math.pi / 2, lever_arm=(0.3, 0.0, -0.45), head_offset=(0.0, 0.0, 0.05))
    # looking straight down the optical axis is body z: the camera sits 5 cm below the axes
    assert np.allclose(ptu.camera_offset_body(), [0.3, 0.0, -0.40], atol=1e-12)


def test_platform_deflection_closed_form():
    """A step of body rate omega0 at t = 0: delta(t) solves delta'' + 2 z w delta' + w^2 delta = 0 with
    delta(0) = 0, delta'(0) = -omega0 (the platform keeps its attitude while the body turns)."""
    w0, zeta, om = 2 * math.pi * 5.0, 0.3, 0.2
    pl = SpringPlatform((0, 0, 0), natural_hz=5.0, damping=zeta, step_s=0.001)
    pl.advance(0.0, lambda t: _state(t))
    pl.advance(0.2, lambda t: _state(t, rates=(om, 0.0, 0.0)))
    wd = w0 * math.sqrt(1 - zeta**2)
    tt = pl.t
    expect = -om / wd * math.exp(-zeta * w0 * tt) * math.sin(wd * tt)
    assert pl.deflection[0] == pytest.approx(expect, abs=2e-4 * om)
    pl.advance(5.0, lambda t: _state(t, rates=(om, 0.0, 0.0)))
    # steady turn: the platform turns with the body again, no deflection left
    assert abs(pl.deflection[0]) < 1e-9


def test_platform_misalignment_rotation():
    pl = SpringPlatform((1.5, -1.2, 0.0))
    assert np.allclose(pl.rotation(), euler_to_dcm(np.radians([1.5, -1.2, 0.0])))


def test_split_rate_imu_holds_the_accelerometer():
    imu = Imu(np.random.default_rng(1), rate_hz=200.0, accel_noise=0.1, gyro_noise=0.01)
    s = SplitRateImu(imu, accel_hz=66.0)
    acc, gyr = [], []
    for k in range(400):
        m, _ = s.sample(k / 200.0, lambda t: _state(t))
        acc.append(m.accel.copy())
        gyr.append(m.gyro.copy())
    acc, gyr = np.array(acc), np.array(gyr)
    new_acc = np.r_[True, np.any(np.diff(acc, axis=0) != 0, axis=1)]
    new_gyr = np.r_[True, np.any(np.diff(gyr, axis=0) != 0, axis=1)]
    assert new_gyr.all()
    assert new_acc.sum() == pytest.approx(2.0 * 66.0, abs=3)  # 2 s of accelerometer instants


@pytest.mark.parametrize("pan,tilt", [(0.3, 1.2), (-2.0, 0.6), (0.1, 1.9)])
def test_pointing_angles_recover_the_axis(pan, tilt):
    ptu = PanTiltUnit(pan=pan, tilt=tilt, tilt_limits=(0.0, 2.2))
    axis = ptu.mount.R_cam_to_body[:, 2]
    p, t = pointing_angles(axis, (pan + 0.05, tilt - 0.05), 2.2)
    ptu2 = PanTiltUnit(pan=p, tilt=t, tilt_limits=(0.0, 2.2))
    assert np.allclose(ptu2.mount.R_cam_to_body[:, 2], axis, atol=1e-12)
    assert abs(p - pan) < 1e-9 and abs(t - tilt) < 1e-9  # the solution nearer the current angles
