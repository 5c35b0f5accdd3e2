"""The pad navigator under IMU faults (issue #18, navigation/pad.py): a gyro bias step is flagged against the
autopilot's attitude and the attitude is then held by it; fixes that are all gated out while they agree with
each other re-initialise the filter on them; fixes that disagree, or a frozen link, do not."""

from __future__ import annotations

import math

import numpy as np

from visnav.measurements import AttitudeSample, ImuSample, PanTiltFrame
from visnav.navigation.pad import PadNavigator
from visnav.scenarios.config_pad import PadFilterConfig
from visnav.vision.pad import PadDetection, PadPose

TILT = math.pi / 2  # looking straight down


class _Mount:
    pan_limits = (-3.0, 3.0)
    tilt_limits = (0.0, 2.0)
    lever_arm = (0.0, 0.0, 0.0)


class _Ptu:
    mount = _Mount()
    head_offset = (0.0, 0.0, 0.0)

    def point_at(self, t, pan, tilt):  # (a head that does not move: the command is only kept)
        self.commanded = (t, pan, tilt)


class _Detector:
    """Gives the pose set in ``position`` (the camera centre in the pad frame = NED) with a 1 cm sigma."""

    K = np.array([[640.0, 0, 320], [0, 640.0, 240], [0, 0, 1]])

    def __init__(self):
        self.position = np.zeros(3)

    def detect(self, image):
        R = np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])  # (only logged: the vision attitude)
        pose = PadPose(position=self.position.copy(), R=R, t=np.zeros(3), cov=np.eye(3) * 1e-4, cov6=np.eye(6),
                       config=0, rms_px=0.1, sigma_px=0.1)
        return PadDetection(rings=[], pose=pose)


def _nav(**cfg):
    det = _Detector()
    nav = PadNavigator(PadFilterConfig(**cfg), det, _Ptu())
    return nav, det


def _fly(nav, det, t0, t1, truth, gyro_bias=np.zeros(3), accel_bias=np.zeros(3), frames=True, image=None, log=None):
    """Hover: IMU + autopilot attitude at 200 Hz, a frame every 50 ms whose pose is ``truth(t)``."""
    rng = np.random.default_rng(int(t0 * 1000))
    for k in range(round(t0 * 200), round(t1 * 200)):
        t = k / 200
        nav.update(ImuSample(t, np.array([0.0, 0.0, -9.81]) + accel_bias + 0.01 * rng.standard_normal(3),
                             gyro_bias + 1e-3 * rng.standard_normal(3)))
        nav.update(AttitudeSample(t, np.radians(0.03) * rng.standard_normal(3)))
        if frames and k % 10 == 0:
            det.position = truth(t) + 0.003 * rng.standard_normal(3)
            img = image if image is not None else rng.integers(0, 255, (8, 8), dtype=np.uint8)
            nav.update(PanTiltFrame(t, img, pan=0.0, tilt=TILT))
            if log is not None:
                log.append((t, nav.rejected, nav.reinits))
    return t


def _still(t):
    return np.array([0.5, -0.3, -10.0])


def test_gyro_bias_step_is_flagged_and_the_autopilot_attitude_holds():
    """Gyros 0.5 deg/s off on every axis (the fault campaign's step) from 3 s: flagged within 1 s against the
    autopilot's attitude, which is fused from then on; the attitude stays within 0.2 deg, the fixes are
    accepted all along; without the step nothing is flagged."""
    nav, det = _nav()
    _fly(nav, det, 0.0, 3.0, _still)
    assert not nav.ahrs_aid and nav.gyro_check is not None and nav.rejected == 0
    assert nav.health(3.0).integrity == "ok"
    bias = np.radians([0.5, 0.5, 0.5])
    t = 3.0
    while not nav.ahrs_aid and t < 5.0:
        t = _fly(nav, det, t, t + 0.05, _still, gyro_bias=bias) + 0.005
    assert nav.ahrs_aid and 3.0 < t <= 4.0  # flagged within 1 s
    h = nav.health(t)
    assert h.integrity == "degraded" and "gyros turned" in h.integrity_reason
    _fly(nav, det, t, 10.0, _still, gyro_bias=bias)
    assert np.max(np.abs(nav.kf.x.euler)) < np.radians(0.2)
    assert nav.rejected == 0 and nav.reinits == 0
    assert np.linalg.norm(nav.estimate(10.0).position - _still(10.0)) < 0.02
    # the gyro bias states learnt the fault
    assert np.allclose(nav.kf.x.gyro_bias, bias, atol=np.radians(0.1))
    assert nav.health(10.0).integrity == "ok"  # a window of fixes agrees with the filter again


def test_accelerometer_bias_taken_for_a_tilt_is_flagged_by_the_attitude_check():
    """An accelerometer bias of 0.3 m/s^2 (x and y) in a still hover: the filter takes it for a tilt (its roll
    and pitch leave the autopilot's); past ``attitude_check_deg`` (2 deg) the fault is flagged, the
    autopilot's attitude is fused and the bias states learn it. (Gyro check off: the attitude check alone.)"""
    from visnav.scenarios.config_integrity import PadIntegrityConfig

    nav, det = _nav(integrity=PadIntegrityConfig(gyro_check=False))
    _fly(nav, det, 0.0, 3.0, _still)
    t = 3.0
    while not nav.ahrs_aid and t < 8.0:
        t = _fly(nav, det, t, t + 0.05, _still, accel_bias=np.array([0.3, 0.3, 0.0])) + 0.005
    assert nav.ahrs_aid and 4.0 < t < 6.0
    assert "filter attitude 2." in nav.health(t).integrity_reason
    _fly(nav, det, t, 10.0, _still, accel_bias=np.array([0.3, 0.3, 0.0]))
    assert np.max(np.abs(nav.kf.x.euler[:2])) < np.radians(0.1)
    assert np.allclose(nav.kf.x.accel_bias[:2], 0.3, atol=0.05)
    assert np.linalg.norm(nav.estimate(10.0).position - _still(10.0)) < 0.01
    assert nav.reinits == 0 and nav.health(10.0).integrity == "ok"


def test_gated_out_fixes_that_agree_reinitialise_the_filter():
    """The accelerometers miss 1 m/s^2 (x and y) from 3 s while the vehicle accelerates (in the loop the
    controller flies the filter's estimate, so the vehicle does what the accelerometers do not feel): the
    filter leaves its fixes until the gate rejects them all. ``reinit_fixes`` (8) of them in a row, one
    smooth track, re-initialise the filter on them; with the autopilot's attitude fused from then on it learns
    the bias and stays on the fixes. (Gyro check off: the re-initialisation alone.)"""
    from visnav.scenarios.config_integrity import PadIntegrityConfig

    nav, det = _nav(integrity=PadIntegrityConfig(gyro_check=False))
    log = []

    def away(t):
        return _still(t) - np.array([0.5, 0.5, 0.0]) * max(t - 3.0, 0.0) ** 2

    _fly(nav, det, 0.0, 3.0, away)
    assert nav.rejected == 0
    t = 3.0
    while nav.rejected == 0 and t < 5.0:  # not "ok" from the first gated-out fix on
        t = _fly(nav, det, t, t + 0.05, away) + 0.005
    assert nav.rejected == 1 and "1 fixes in a row gated out" in nav.health(t).integrity_reason
    _fly(nav, det, t, 10.0, away, log=log)
    assert nav.reinits >= 1 and nav.ahrs_aid
    first_reinit = next(tl for tl, _, n in log if n > 0)
    assert 3.0 < t < 5.0 and first_reinit - (t - 0.005) <= 0.35 + 1e-9  # the 8th gated-out fix in a row
    assert np.linalg.norm(nav.estimate(10.0).position - away(10.0)) < 0.06  # (24 m away at 7 m/s)
    assert np.allclose(nav.kf.x.accel_bias[:2], 1.0, atol=0.05)  # learnt
    assert nav.rejected == 8 * nav.reinits  # after a re-initialisation the fixes are taken again


def test_fixes_that_disagree_or_a_frozen_link_do_not_reinitialise():
    """Fixes that jump about (a camera fault, not a filter one) are gated out without a re-initialisation; a
    frozen link (the same image again) gives no fix at all."""
    nav, det = _nav()
    _fly(nav, det, 0.0, 3.0, _still)
    rng = np.random.default_rng(5)
    _fly(nav, det, 3.0, 5.0, lambda t: _still(t) + rng.normal(0.0, 0.5, 3))
    assert nav.rejected > 20 and nav.reinits == 0
    nav, det = _nav()
    _fly(nav, det, 0.0, 3.0, _still)
    fixes = nav.fixes
    img = np.arange(64, dtype=np.uint8).reshape(8, 8)
    _fly(nav, det, 3.0, 5.0, lambda t: _still(t) + np.array([0.0, 0.0, t - 3.0]), image=img)
    assert nav.fixes == fixes + 1 and nav.reinits == 0  # the first of the frozen frames only
    assert "frozen camera" in nav.health(5.0).integrity_reason
