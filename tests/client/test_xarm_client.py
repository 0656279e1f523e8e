"""XarmClient against the in-process simulator, a simulator on a real pty and a scripted peer."""

from __future__ import annotations

from typing import Any

import pytest

from xgo_show.client import XarmClient, open_client
from xgo_show.errors import ProfileError, ProtocolError, TransportTimeout
from xgo_show.profiles import get_profile
from xgo_show.sim import PtyServer, create_robot
from xgo_show.transports import open_transport
from xgo_show.wire import xarm
from xgo_show.wire.xarm import XarmCommand, XarmPacket


def test_battery_and_positions_from_the_simulator() -> None:
    with open_transport("sim:xarm", baudrate=9600, drain_mv_per_minute=0) as link:
        arm = XarmClient(link)
        assert arm.model == "xarm"
        assert arm.battery_mv() == 7600
        assert arm.positions() == {servo: 500 for servo in range(1, 7)}
        assert list(arm.positions([3, 1])) == [3, 1]  # in the order asked for
        requests = [f.data for f in link.robot.received]  # type: ignore[attr-defined]
    assert requests == [
        xarm.get_battery_voltage(),
        xarm.servo_position_read(range(1, 7)),
        xarm.servo_position_read([3, 1]),
    ]


def test_user_mistakes_are_profile_errors() -> None:
    with open_transport("sim:xarm") as link:
        arm = XarmClient(link)
        with pytest.raises(ProfileError, match="the xArm has no servo 7; valid: 1, 2, 3, 4, 5, 6"):
            arm.positions([1, 7])
        with pytest.raises(ProfileError, match="name at least one servo"):
            arm.positions([])
        with pytest.raises(ProfileError, match="XarmClient talks to the xArm"):
            XarmClient(link, get_profile("mini"))


def test_open_client_over_a_real_pty() -> None:
    robot = create_robot("xarm", battery_mv=6900, drain_mv_per_minute=0, positions={2: 120, 6: 875})
    with PtyServer(robot) as server, open_client(server.path, "xarm") as arm:
        assert isinstance(arm, XarmClient)
        assert arm.transport.baudrate == 9600  # type: ignore[attr-defined]  # the arm's link
        assert arm.battery_mv() == 6900
        assert arm.positions([2, 6]) == {2: 120, 6: 875}


def client_on(peer: Any) -> XarmClient:
    link = open_transport(peer.path, baudrate=9600)
    link.open()
    return XarmClient(link, timeout=0.1)


def test_other_packets_and_noise_are_skipped(xarm_peer: Any) -> None:
    def answer(request: XarmPacket) -> bytes:
        return b"".join(
            (
                b"\x55\x55\x99\x01\x13",  # noise with a false header
                xarm.positions_reply({1: 10}),  # another command's reply
                xarm.battery_reply(7123),
            )
        )

    with client_on(xarm_peer(answer)) as arm:
        assert arm.battery_mv() == 7123


def test_silence_is_a_timeout(xarm_peer: Any) -> None:
    peer = xarm_peer(lambda request: b"")
    with client_on(peer) as arm, pytest.raises(TransportTimeout) as info:
        arm.battery_mv()
    assert str(info.value) == f"no reply from {peer.path} to a GetBatteryVoltage within 0.1 s"


def test_garbage_is_a_protocol_error(xarm_peer: Any) -> None:
    peer = xarm_peer(lambda request: b"\x00\x13\x37" * 5)
    with client_on(peer) as arm, pytest.raises(ProtocolError) as info:
        arm.positions([1])
    assert str(info.value) == (
        f"garbage from {peer.path} to a ServoPositionRead of servos 1: 15 bytes that are no "
        "xArm frame (wrong baud rate, or not an xArm robot?)"
    )


def test_reply_for_other_servos_is_a_protocol_error(xarm_peer: Any) -> None:
    def answer(request: XarmPacket) -> bytes:
        assert request.command is XarmCommand.SERVO_POSITION_READ
        return xarm.positions_reply({1: 500, 4: 500})

    peer = xarm_peer(answer)
    with client_on(peer) as arm, pytest.raises(ProtocolError) as info:
        arm.positions([1, 2])
    assert str(info.value) == (
        f"reply from {peer.path} to a ServoPositionRead of servos 1, 2 lists servos 1, 4"
    )
