"""MavlinkLink against a bare pymavlink peer on 127.0.0.1: HEARTBEAT identity, TIMESYNC as responder,
SET_MESSAGE_INTERVAL after the autopilot appears, a GCS not taken for the autopilot."""

import time

import pytest

from tests.io.mavlink_helpers import free_udp_port, receive
from visnav.io.mavlink_link import MavlinkLink, mavutil
from visnav.io.mavlink_messages import mavlink

pytestmark = pytest.mark.realtime  # paced to the wall clock: run apart from the CPU-heavy suite (Makefile)


def test_link_identity_timesync_answer_and_intervals():
    port = free_udp_port()
    notes = []
    link = MavlinkLink(f"udpin:127.0.0.1:{port}", notify=notes.append)
    peer = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=7, source_component=1,
                                      dialect="common")
    try:
        link.request_intervals({mavlink.MAVLINK_MSG_ID_HIGHRES_IMU: 100.0, mavlink.MAVLINK_MSG_ID_ATTITUDE: 40.0})
        peer.mav.send(peer.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 4))
        for _ in range(20):
            link.tick()
            link.poll(0.01)
        assert link.target_system is None  # a ground station is not the autopilot
        peer.mav.send(peer.mav.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 4))
        peer.mav.send(peer.mav.timesync_encode(0, 123_456_789))
        t_before = time.monotonic_ns()
        got = []
        for _ in range(220):  # ~2.2 s: past one 1 Hz HEARTBEAT period and the 1.5 s link timeout
            link.tick()
            link.poll(0.01)
            got += receive(peer, ["HEARTBEAT", "TIMESYNC", "COMMAND_LONG"], 50, timeout_s=0.0)
        assert (link.target_system, link.target_component) == (7, 1)
        # the peer sent one HEARTBEAT only: the watch declared the link lost 1.5 s later
        assert not link.link_ok and link.link_lost_count == 1 and any("autopilot link lost" in n for n in notes)
        assert link.mav.srcSystem == 7  # we joined the vehicle's system id
        hb = [m for m in got if m.get_type() == "HEARTBEAT"][-1]
        assert (hb.type, hb.autopilot, hb.get_srcComponent()) == (mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
                                                                 mavlink.MAV_AUTOPILOT_INVALID, 197)
        answers = [m for m in got if m.get_type() == "TIMESYNC" and m.ts1 == 123_456_789]
        assert len(answers) == 1 and t_before - 1e9 < answers[0].tc1 < time.monotonic_ns()
        requests = [m for m in got if m.get_type() == "TIMESYNC" and m.tc1 == 0]
        assert requests  # and we ask for the peer's clock
        cmds = {int(m.param1): m.param2 for m in got if m.get_type() == "COMMAND_LONG"
                and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL}
        assert cmds == {mavlink.MAVLINK_MSG_ID_HIGHRES_IMU: 10_000.0, mavlink.MAVLINK_MSG_ID_ATTITUDE: 25_000.0}
        assert any("autopilot 7/1 seen" in n for n in notes)
    finally:
        peer.close()
        link.close()
