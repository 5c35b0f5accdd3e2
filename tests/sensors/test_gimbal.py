"""CONDOR gimbal, camera AHRS, potentiometer, barometer (eq. 2.1), telemetry link, camera + tent rendering."""

import math

import numpy as np
import pytest

from visnav.geometry.camera import PinholeCamera
from visnav.sensors.condor_camera import TargetCamera, condor_camera, target_outline
from types import SimpleNamespace

from visnav.measurements import VehicleState
from visnav.sensors.baro import Baro
from visnav.sensors.gimbal import CameraAhrs, Gimbal, PanPotentiometer, camera_dcm, centred_coords, project_points
from visnav.sensors.link import Link
from visnav.vision.rectification import altimeter_correction

CAM = PinholeCamera.ideal(640, 480, 600.0)


def test_camera_axis_points_along_pan_and_tilt():
    pan, tilt = math.radians(30), math.radians(-40)
    d = np.array([math.cos(tilt) * math.cos(pan), math.cos(tilt) * math.sin(pan), -math.sin(tilt)])
    uv = project_points(CAM, [0, 0, -100], pan, tilt, 0.2, [np.array([0, 0, -100]) + 50 * d])
    np.testing.assert_allclose(uv[0], [CAM.cx, CAM.cy], atol=1e-9)


def test_roll_is_a_2d_rotation_of_the_image():
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(60, 160, 20), rng.uniform(-40, 40, 20), np.zeros(20)])
    X0, Y0 = centred_coords(CAM, project_points(CAM, [0, 0, -100], 0.1, -0.7, 0.0, pts))
    phi = math.radians(8)
    X1, Y1 = centred_coords(CAM, project_points(CAM, [0, 0, -100], 0.1, -0.7, phi, pts))
    # right side down: image content turns counter-clockwise (Y up): (X1, Y1) = R(phi) (X0, Y0)
    np.testing.assert_allclose(X1, math.cos(phi) * X0 - math.sin(phi) * Y0, atol=1e-6)
    np.testing.assert_allclose(Y1, math.sin(phi) * X0 + math.cos(phi) * Y0, atol=1e-6)
    assert np.allclose(camera_dcm(0.3, -0.5, 0.1) @ camera_dcm(0.3, -0.5, 0.1).T, np.eye(3))


def test_gimbal_slew_and_roll_leak():
    g = Gimbal(0.0, -1.0, math.radians(60), math.radians(30), 0.1, math.radians(-1))
    g.command(math.radians(90), math.radians(-20))
    for _ in range(50):
        g.step(0.01)
    assert g.pan == pytest.approx(math.radians(30), abs=1e-9)  # 0.5 s at 60 deg/s
    assert g.tilt == pytest.approx(-1.0 + math.radians(15), abs=1e-9)
    pan, tilt, roll = g.camera_attitude([math.radians(20), 0.0, 1.0])
    assert roll == pytest.approx(0.1 * math.radians(20) - math.radians(1))
    assert pan == pytest.approx(1.0 + g.pan)
    g.command(math.nan, 0.0)  # ignored
    assert g.pan_cmd == pytest.approx(math.radians(90))


def test_ahrs_converges_to_the_acceleration_error():
    ahrs = CameraAhrs(np.random.default_rng(1), 0.0, 0.0, 0.0, accel_gain=0.5, tau_s=2.0)
    a = np.array([2.0, 0.0, 0.0])  # forward acceleration along the camera's pan (north)
    for _ in range(2000):
        ahrs.step(0.01, a, 0.0)
    tilt, roll = ahrs.read(-0.7, 0.0)
    assert tilt - (-0.7) == pytest.approx(0.5 * math.atan2(2.0, 9.81) * (1 - 0.995**2000), rel=1e-9)
    assert roll == pytest.approx(0.0, abs=1e-12)
    # after 1 tau from rest: 1 - 1/e of it
    ahrs2 = CameraAhrs(np.random.default_rng(1), 0.0, 0.0, 0.0, accel_gain=1.0, tau_s=2.0)
    for _ in range(200):
        ahrs2.step(0.01, np.array([0.0, 3.0, 0.0]), 0.0)
    assert ahrs2.err[1] == pytest.approx(-math.atan2(3.0, 9.81) * (1 - (1 - 0.005) ** 200), rel=1e-9)


def _truth(h=100.0):
    s = VehicleState(0.0, np.array([0.0, 0.0, -h]), np.zeros(3), np.zeros(3), np.zeros(3), np.array([0, 0, -9.81]))
    return lambda t: s


def test_pot_and_baro_noise_and_eq_2_1_inverse():
    rng = np.random.default_rng(2)
    pot = PanPotentiometer(rng, math.radians(1.0))
    world = SimpleNamespace(gimbal=SimpleNamespace(pan=0.5))
    r = np.array([pot.sample(k * 0.1, _truth(), world).pan for k in range(4000)])
    assert r.mean() == pytest.approx(0.5, abs=0.002) and r.std() == pytest.approx(math.radians(1), rel=0.05)
    baro = Baro(rng, sigma_m=0.0, bias_sigma_m=0.0, t_outside_c=25.0, c0=0.0004, c1=0.000005)
    raw = baro.sample(0.0, _truth(100.0)).altitude
    assert raw > 100.0 and altimeter_correction(raw, 25.0, 0.0004, 0.000005) == pytest.approx(100.0, abs=1e-9)
    noisy = Baro(rng, sigma_m=0.3, bias_sigma_m=0.0, t_outside_c=25.0, c0=0.0004, c1=0.000005)
    x = np.array([noisy.sample(k * 0.02, _truth(100.0)).altitude for k in range(4000)])
    assert x.mean() == pytest.approx(raw, abs=0.02) and x.std() == pytest.approx(0.3, rel=0.05)


def test_link_latency_and_drops():
    link = Link(np.random.default_rng(3), 0.33, 0.2, 0.0, 0.0)
    got = [(k / 7.5, link.transmit(k / 7.5)) for k in range(3000)]
    lat = np.array([d - t for t, d in got if d is not None])
    assert np.allclose(lat, 0.33)
    assert link.dropped / link.sent == pytest.approx(0.2, abs=0.025)
    out = Link(np.random.default_rng(4), 0.1, 0.0, 1.0, 2.0)  # outages ~ every second, 2 s long
    for k in range(100):
        out.transmit(k * 0.1)
    assert out.dropped > 50
    with pytest.raises(ValueError, match="latency"):
        Link(np.random.default_rng(0), -1.0)


def test_tent_render_centre_and_distortion():
    cam = condor_camera(640, 480, 53.0, -0.25, 0.05, 12.0, -7.0)
    assert cam.cx == pytest.approx(319.5 + 12) and cam.fx == pytest.approx(320 / math.tan(math.radians(26.5)))
    tc = TargetCamera(cam, np.random.default_rng(0))
    outline = target_outline([110.0, 0.0], 3.0, 2.0, 0.3)
    assert outline.shape == (24, 3) and np.all(outline[:, 2] == 0)
    np.testing.assert_allclose(outline[:, :2].mean(0), [110.0, 0.0], atol=1e-9)
    img = tc.render([0, 0, -100.0], 0.0, -math.atan2(100, 110), 0.0, outline)
    blue = (img[..., 2].astype(int) - np.maximum(img[..., 0], img[..., 1])) > 40
    v, u = np.nonzero(blue)
    assert 20 < blue.sum() < 400
    assert abs(u.mean() - cam.cx) < 1.0 and abs(v.mean() - cam.cy) < 1.0  # the optical centre, not the image centre
    empty = tc.render([0, 0, -100.0], math.pi, -0.7, 0.0, outline)  # looking away
    assert np.array_equal(empty, tc.background)


def test_projection_matches_opencv():
    import cv2

    cam = condor_camera(640, 480, 53.0, -0.25, 0.05, 12.0, -7.0)
    pan, tilt, roll = 1.2, math.radians(-42), math.radians(-3)
    pos = np.array([5.0, -80.0, -100.0])
    rng = np.random.default_rng(7)
    C = camera_dcm(pan, tilt, roll)
    rays = cam.unproject(np.stack([rng.uniform(20, 620, 30), rng.uniform(20, 460, 30)], 1)) @ C
    pts = pos + rays * (100.0 / rays[:, 2])[:, None]
    ours = project_points(cam, pos, pan, tilt, roll, pts)
    rvec, _ = cv2.Rodrigues(C)
    ref, _ = cv2.projectPoints(pts, rvec, -C @ pos, cam.K, np.array(cam.dist[:5]))
    np.testing.assert_allclose(ours, ref[:, 0, :], atol=1e-6)


def test_ahrs_lags_a_quick_tilt():
    """Fig. 4.2: a tilt ramp at w reads w * lag behind once the lag has settled."""
    ahrs = CameraAhrs(np.random.default_rng(1), 0.0, 0.0, 0.0, 0.0, 3.0, lag_s=0.5)
    w, dt = math.radians(20.0), 0.01
    for k in range(400):
        tilt = -0.9 + w * k * dt
        ahrs.step(dt, np.zeros(3), 0.0, tilt, 0.02)
    tilt_m, roll_m = ahrs.read(tilt, 0.02)
    assert tilt - tilt_m == pytest.approx(w * (0.5 - dt), rel=0.01)  # discrete first-order lag
    assert roll_m == pytest.approx(0.02)
    still = CameraAhrs(np.random.default_rng(1), 0.0, 0.0, 0.0, 0.0, 3.0)
    assert still.read(-0.5, 0.1) == (-0.5, 0.1)  # no lag configured: reads the attitude it is given
