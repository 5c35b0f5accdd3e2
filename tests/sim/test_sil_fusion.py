"""The SIL autopilot's own navigation solution (app/sil.py ``ExternalFusion``, ``SilLink.estimate``): the bridge's
ODOMETRY fused at the instant it describes and carried to the present with the autopilot's IMU, as PX4's EKF2 /
ArduPilot's EKF3 fuse an external vision source on their delayed horizon. No bridge, no wall-clock pacing:
the measurements are handed to the link by hand and the ODOMETRY goes through pymavlink's encoder and parser."""

import numpy as np
import pytest

from visnav.estimation.position_filter import G
from visnav.geometry.frames import LocalTangentPlane
from visnav.geometry.rotations import euler_to_dcm
from visnav.io import mavlink_messages as mm
from visnav.io.camera_source import FrameStreamServer
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import AttitudeSample, ImuSample, NavEstimate
from visnav.app.sil import ORIGIN, ExternalFusion, SilLink, free_port

P0, V0 = np.array([3.0, -2.0, -5.0]), np.array([1.0, 0.5, 0.2])
A = np.array([0.3, -0.2, 0.5])  # constant kinematic acceleration NED [m/s^2]
EULER = np.array([0.1, -0.05, 0.7])  # a constant attitude: the specific force is rotated into NED


def truth(t):
    return P0 + V0 * t + 0.5 * A * t * t, V0 + A * t


def specific_force():
    return euler_to_dcm(EULER).T @ (A - np.array([0.0, 0.0, G]))  # f = C^T (a - g)


def test_fusion_is_exact_under_constant_acceleration_and_shifts_by_the_innovation():
    f = ExternalFusion()
    dt = 0.01
    for k in range(1, 121):  # IMU at 100 Hz up to 1.2 s; the estimate describing 0.1 s is fused at 0.2 s
        f.imu(k * dt, A)
        if k == 20:
            f.fuse(0.1, *truth(0.1))
    p, v = f.at(1.25)
    assert np.allclose(p, truth(1.25)[0], atol=1e-9) and np.allclose(v, truth(1.25)[1], atol=1e-9)
    # an estimate that disagrees at its instant ts by (dp, dv) moves the present by dp + dv (t - ts), v by dv
    dp, dv = np.array([0.4, -0.1, 0.2]), np.array([-0.3, 0.2, 0.1])
    p1, v1 = truth(1.0)
    f.fuse(1.0, p1 + dp, v1 + dv)
    p, v = f.at(1.25)
    assert np.allclose(p, truth(1.25)[0] + dp + dv * 0.25, atol=1e-9)
    assert np.allclose(v, truth(1.25)[1] + dv, atol=1e-9)
    assert f.fused == 2


def _odometry(link: SilLink, ts: float, quality: int = 100):
    """ODOMETRY describing sim time ``ts`` (truth), through pymavlink's encoder and parser."""
    p, v = truth(ts)
    est = NavEstimate(t=ts, position=p, velocity=v, attitude=EULER, covariance=np.eye(6) * 0.01, valid=True,
                      source="mpe")
    msg = mm.encode_odometry(link.mav, est, link.boot_us(ts), 0, quality)
    parsed = mavlink.MAVLink(None).parse_buffer(msg.pack(link.mav))
    assert parsed and parsed[0].get_type() == "ODOMETRY"
    return parsed[0]


@pytest.fixture
def link():
    lk = SilLink(free_port(), FrameStreamServer(), LocalTangentPlane(*ORIGIN), pace=False)
    lk.start_clock()
    yield lk
    lk.close()


def test_sil_link_carries_a_delayed_estimate_through_a_camera_gap_with_the_imu(link):
    """The estimate the controller flies on, 1.1 s after the last ODOMETRY (the camera switched off for the
    final descent) while the vehicle accelerates: the IMU carries it (holding the message's velocity, as the
    stand-in did before, is 0.55 m/s and 0.30 m off here)."""
    link.update(AttitudeSample(t=0.0, euler=EULER))
    assert not link.estimate(0.0).valid  # nothing from the bridge yet
    f = specific_force()
    for k in range(1, 121):
        t = k * 0.01
        link.update(ImuSample(t=t, accel=f, gyro=np.zeros(3)))
        if k == 15:  # arrives 50 ms after the instant it describes, later than the IMU sample of 0.15 s
            link._receive(_odometry(link, 0.1))
        if k == 16:
            link._receive(_odometry(link, 0.12, quality=0))  # quality 0: not fused
        if k == 20:  # stamped ahead of the autopilot's IMU (a simulation behind the wall clock): it waits
            link._receive(_odometry(link, 0.5))
        if k in (49, 51):  # fused once the IMU has reached 0.5 s (the stamp is whole microseconds)
            assert link.fusion.fused == (1 if k == 49 else 2)
    est = link.estimate(1.2)
    p, v = truth(1.2)
    assert est.valid  # the newest message (0.5 s) is valid
    assert np.max(np.abs(est.position - p)) < 1e-4 and np.max(np.abs(est.velocity - v)) < 1e-4
    assert np.allclose(est.attitude, EULER)  # the autopilot's own attitude
    assert link.fusion.fused == 2


def test_sil_camera_streams_while_the_mission_needs_no_frames():
    """In-process PALACE renders no frames below 1 m (the mission's camera gate); behind the bridge the camera
    is the companion computer's and streams on, else the bridge would see a camera stall in the final descent."""
    from visnav.scenarios.schema import load_scenario
    from visnav.app.missions import make_simulation
    from visnav.app.sil import sil_simulation

    sc = load_scenario("palace-landing")
    gate = make_simulation(sc).parts.routing.gates["camera"]  # the in-process economy this test is about
    gate.__self__.mode = "final"
    assert gate(60.0) is False
    sim = sil_simulation(sc)
    try:
        assert "camera" not in sim.parts.routing.gates and "camera" in sim.sensors
    finally:
        sim.sil_link.close()
