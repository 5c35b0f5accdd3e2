"""Mission requests reaching the navigator behind the bridge (COMMAND_LONG MAV_CMD_USER_1): applied once per
sequence number, acknowledged with the right result, health sent after each; a code without a mapping
refused with one line. No sockets: the link's send is captured."""

import time

import numpy as np

from tests.io.bridge_fixtures import GpsFollowNavigator, offline_link
from visnav.io import mavlink_messages as mm
from visnav.app.bridge import Bridge, BridgeConfig, NavRequest
from visnav.io.mavlink_messages import mavlink
from visnav.measurements import Health, NavCommand


class _Nav(GpsFollowNavigator):
    def __init__(self):
        super().__init__()
        self.commands = []

    def command(self, cmd):
        if cmd.args.get("source") == "mpe" and not self.commands:
            raise ValueError("no track to take MPE from")
        self.commands.append(cmd)

    def health(self, t=None):
        return Health(source="gps", tracking_pending=bool(self.commands))


def _bridge():
    link, sent = offline_link()
    notes = []
    br = Bridge(link, None, _Nav(), BridgeConfig(send_health=True), notify=notes.append)
    sent.clear()
    return link, br, sent, notes


def _acks(sent):
    return [(m.result, m.result_param2) for m in sent if m.get_type() == "COMMAND_ACK"]


def test_requests_applied_once_acked_and_health_follows():
    link, br, sent, notes = _bridge()
    try:
        tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        track = NavCommand(0.0, "request-tracking", {"target_ned": np.array([3.0, -4.0, 0.0]), "init_from": "gps"})
        # the way the reader thread sees it: decoded from the COMMAND_LONG
        msg = mavlink.MAVLink(None).parse_buffer(mm.encode_nav_command(tx, track, 1, 1, 197).pack(tx))[0]
        r = br._decode(msg, 12.5)
        assert isinstance(r, NavRequest) and (r.seq, r.src) == (1, (1, 1))
        br._consume(r)
        br._consume(r)  # a retry: acknowledged again, not applied again
        refused = NavRequest(2, NavCommand(0.0, "set-source", {"source": "mpe"}), (1, 1))
        nav = br.nav
        nav.commands.clear()  # the navigator refuses MPE without a track
        br._consume(refused)
        assert _acks(sent) == [(mavlink.MAV_RESULT_ACCEPTED, 1), (mavlink.MAV_RESULT_ACCEPTED, 1),
                               (mavlink.MAV_RESULT_DENIED, 2)]
        assert br.counts["requests_applied"] == 1 and br.counts["requests_repeated"] == 1
        assert any("refused by the navigator: no track to take MPE from" in n for n in notes)
        c = [x for x in sent if x.get_type() == "DEBUG_FLOAT_ARRAY"]
        assert len(c) == 3  # health after each ACK, with the newest sequence number the navigator got
        assert [mm.decode_health(x)[1] for x in c] == [1, 1, 2]
        assert mm.decode_health(c[0])[0].tracking_pending  # the navigator's own flag after the request
        # an unknown request code: UNSUPPORTED with one line
        sent.clear()
        bad = mavlink.MAVLink(None).parse_buffer(mavlink.MAVLink_command_long_message(
            1, 197, mm.NAV_COMMAND_ID, 0, 42.0, 0, 0, 0, 0, 0, 3.0).pack(tx))[0]
        assert br._decode(bad, 13.0) is None
        assert _acks(sent) == [(mavlink.MAV_RESULT_UNSUPPORTED, 0)]
        assert any(n.startswith("mission request refused: MAV_CMD_USER_1 request code 42") for n in notes)
    finally:
        link.close()


def test_shutdown_request_ends_the_session():
    link, br, sent, notes = _bridge()
    try:
        tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        other = mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 0, 2, 0, 0, 0,
                                                     0, 0)  # addressed to the autopilot: not ours
        br._decode(mavlink.MAVLink(None).parse_buffer(other.pack(tx))[0], 1.0)
        assert not br.stop.is_set()
        ours = mavlink.MAVLink_command_long_message(1, 197, mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 0, 2, 0, 0,
                                                    0, 0, 0)
        br._decode(mavlink.MAVLink(None).parse_buffer(ours.pack(tx))[0], 1.0)
        assert br.stop.is_set() and _acks(sent) == [(mavlink.MAV_RESULT_ACCEPTED, 0)]
        t0 = time.monotonic()
        assert br.run(duration_s=5.0).get("estimates_out", 0) == 0 and time.monotonic() - t0 < 2.0  # at once
    finally:
        link.close()


def test_baro_reference_waits_for_a_fix_that_comes_after_the_first_pressure():
    """The first SCALED_PRESSURE reached the bridge before any position fix (the SIL's start): the barometric
    height must still be referenced to the origin (a fix at 60 m above it), not to the height of that moment."""
    from visnav.geometry.frames import LocalTangentPlane

    link, br, sent, notes = _bridge()
    try:
        origin = LocalTangentPlane(58.395, 15.575, 0.0)
        br.origin = origin
        tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        p60 = 1013.25 * (1.0 - 60.0 / 44330.77) ** (1.0 / 0.190263)  # ISA at 60 m above a 1013.25 hPa origin
        parse = lambda m: mavlink.MAVLink(None).parse_buffer(m.pack(tx))[0]  # noqa: E731
        baro = parse(mavlink.MAVLink_scaled_pressure_message(1_000_000, p60, 0.0, 2000))
        assert br._decode(baro, 1.0) is None and br.counts["baro_before_reference"] == 1
        lat, lon, alt = origin.ned_to_geodetic(np.array([0.0, 0.0, -60.0]))
        link.counts_in["GLOBAL_POSITION_INT"] += 1
        gps = parse(mavlink.MAVLink_global_position_int_message(1_000_050, int(round(lat * 1e7)), int(round(lon * 1e7)),
                                                                int(round(alt * 1000)), 60000, 0, 0, 0, 0))
        assert abs(br._decode(gps, 1.05).position[2] + 60.0) < 0.01
        m = br._decode(parse(mavlink.MAVLink_scaled_pressure_message(1_000_100, p60, 0.0, 2000)), 1.1)
        assert abs(m.altitude - 60.0) < 0.01  # 1 mm GPS quantisation, float32 pressure
    finally:
        link.close()
    # no fix at all: after origin_wait_s the height of that moment is the reference, said once
    link, br, sent, notes = _bridge()
    try:
        br.cfg.origin_wait_s = 0.5
        tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        msg = mavlink.MAVLink(None).parse_buffer(mavlink.MAVLink_scaled_pressure_message(5, 1000.0, 0.0, 2000).pack(tx))[0]
        assert br._decode(msg, 10.0) is None
        assert br._decode(msg, 10.6).altitude == 0.0
        assert sum("no position fix within 0.5 s" in n for n in notes) == 1
    finally:
        link.close()
