"""Independent decoding: MAVSDK (C++ MAVLink implementation, through the mavsdk 4.x wheel's libcmavsdk)
reads our ODOMETRY through its telemetry API with the values we meant. Loopback UDP on 127.0.0.1 only."""

import math
import threading
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tests.io.mavlink_helpers import free_udp_port
from visnav.io import mavlink_messages as mm
from visnav.io.mavlink_link import mavutil
from visnav.measurements import NavEstimate

pytestmark = pytest.mark.realtime  # paced to the wall clock: run apart from the CPU-heavy suite (Makefile)

mavsdk = pytest.importorskip("mavsdk", reason="the mavsdk wheel is not installed (pip install 'mavsdk>=4.1')")
if not hasattr(mavsdk, "Mavsdk"):
    pytest.skip("mavsdk < 4 (the gRPC mavsdk_server API) is installed; this test uses the 4.x C library API",
                allow_module_level=True)


def test_mavsdk_reads_our_odometry():
    from mavsdk import ComponentType, Configuration, Mavsdk
    from mavsdk.plugins.telemetry import telemetry as T

    port = free_udp_port()
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    assert int(sdk.add_any_connection(f"udpin://127.0.0.1:{port}")) == 0  # SUCCESS
    tx = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1, source_component=1,
                                    dialect="common")
    stop = threading.Event()
    lock = threading.Lock()

    def autopilot_heartbeat():  # MAVSDK hands out a System once it sees an autopilot
        for _ in range(100):
            if stop.is_set():
                return
            with lock:
                tx.mav.srcComponent = 1
                tx.mav.send(tx.mav.heartbeat_encode(2, 12, 0, 0, 4))
            time.sleep(0.1)

    th = threading.Thread(target=autopilot_heartbeat, daemon=True)
    th.start()
    got = []
    try:
        system = sdk.first_autopilot(5.0)
        assert system is not None, "MAVSDK saw no autopilot on 127.0.0.1"
        # mavsdk 4.1's Python enum knows frames 0/8/16/18 only; read the raw value instead of raising
        T.Odometry.MavFrame = int
        tel = T.Telemetry(system)
        tel.subscribe_odometry(lambda o, *a: got.append(o))
        rng = np.random.default_rng(7)
        A = rng.normal(size=(6, 6))
        P = A @ A.T + np.eye(6)
        est = NavEstimate(t=3.0, position=np.array([12.5, -40.25, -30.0]), velocity=np.array([3.0, -1.0, 0.5]),
                          attitude=np.array([0.05, -0.1, 1.2]), covariance=P)
        for _ in range(40):  # bounded: 2 s at most
            with lock:
                tx.mav.srcComponent = 197  # MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY, as the bridge
                tx.mav.send(mm.encode_odometry(tx.mav, est, 987_654_321, reset_counter=4, quality=80))
            time.sleep(0.05)
            if got:
                break
    finally:
        stop.set()
        th.join(timeout=2)
        tx.close()
    assert got, "MAVSDK delivered no odometry"
    o = got[-1]
    C = Rotation.from_euler("ZYX", est.attitude[::-1]).as_matrix()
    assert o.time_usec == 987_654_321
    p = o.position_body
    np.testing.assert_allclose([p.x_m, p.y_m, p.z_m], est.position, rtol=1e-6)
    x, y, z, w = Rotation.from_matrix(C).as_quat()
    np.testing.assert_allclose([o.q.w, o.q.x, o.q.y, o.q.z], np.array([w, x, y, z]) * np.sign(w), atol=1e-6)
    v = o.velocity_body
    np.testing.assert_allclose([v.x_m_s, v.y_m_s, v.z_m_s], C.T @ est.velocity, rtol=1e-5)
    pc = o.pose_covariance.covariance_matrix
    vc = o.velocity_covariance.covariance_matrix
    Pvb = C.T @ P[3:, 3:] @ C
    assert len(pc) == len(vc) == 21
    for k, (i, j) in enumerate((i, j) for i in range(6) for j in range(i, 6)):
        want = P[i, j] if (i < 3 and j < 3) else (mm.ATTITUDE_SIGMA_RAD**2 if i == j else 0.0)
        assert pc[k] == pytest.approx(want, rel=1e-6, abs=1e-9), (k, i, j)
        if i < 3 and j < 3:
            assert vc[k] == pytest.approx(Pvb[i, j], rel=1e-5, abs=1e-9), (k, i, j)
        elif i == j:
            assert math.isnan(vc[k])
    # MAVSDK 4.1 maps frame ids it has no enum value for (LOCAL_FRD 20, BODY_FRD 12) to UNDEF (0): the frame
    # ids are checked with pymavlink (test_mavlink_messages), not here
    assert o.frame_id in (0, 20) and o.child_frame_id in (0, 12)
