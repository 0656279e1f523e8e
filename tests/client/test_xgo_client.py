"""XgoClient against the in-process simulator, a simulator on a real pty, and a scripted peer."""

from __future__ import annotations

import os
import select
from collections.abc import Iterator
from typing import Any

import pytest

from xgo_show.client import XgoClient, open_client
from xgo_show.errors import ProfileError, ProtocolError, TransportTimeout, ValueRangeError
from xgo_show.profiles import get_profile
from xgo_show.sim import PtyServer, create_robot
from xgo_show.transports import open_transport
from xgo_show.transports.sim import SimTransport
from xgo_show.wire.xgo import XgoFrame, read_frame, reply_frame, write_frame


@pytest.fixture
def mini() -> Iterator[XgoClient]:
    with open_transport("sim:mini") as link:
        yield XgoClient(link, get_profile("mini"))


def robot_of(client: XgoClient) -> object:
    assert isinstance(client.transport, SimTransport)
    return client.transport.robot


# ---------------------------------------------------------------- in-process simulator
def test_identity_and_health_from_the_simulator(mini: XgoClient) -> None:
    assert mini.firmware() == "M-1.4.1"
    assert mini.identify() == "mini"
    assert mini.battery() == 100
    assert mini.status() == 0
    assert mini.read("firmware") == b"M-1.4.1\0\0\0"
    assert mini.read(0x00, 2) == b"\x00\x64"  # by address: status and battery


def test_read_value_decodes_by_profile(mini: XgoClient) -> None:
    assert mini.read_value("vx") == 0.0  # 0x80 is exactly zero
    assert isinstance(mini.read_value("imu_roll"), float)
    assert isinstance(mini.read_value("imu_roll_i16"), int)
    assert mini.read_value("firmware") == "M-1.4.1"


def test_writes_are_encoded_by_the_profile(mini: XgoClient) -> None:
    vx = get_profile("mini").register("vx")
    mini.write("vx", 12.5)
    mini.write("gait", "walk")
    act = mini.action("sit_down")
    received = [f.data for f in mini.transport.robot.received]  # type: ignore[attr-defined]
    assert received == [
        write_frame(0x30, vx.encode_value(12.5)),
        write_frame(0x09, b"\x01"),
        write_frame(0x3E, bytes((act.id,))),
    ]
    assert mini.read_value("vx") == pytest.approx(12.5, abs=0.2)


def test_rider_writes_use_its_write_type() -> None:
    with open_transport("sim:rider") as link:
        rider = XgoClient(link, get_profile("rider"))
        rider.write("led1", (255, 0, 16))
        assert link.robot.received[-1].data == write_frame(0x69, b"\xff\x00\x10", write_type=0x01)  # type: ignore[attr-defined]


def test_user_mistakes_are_profile_errors(mini: XgoClient) -> None:
    with pytest.raises(ProfileError, match="has no register 'speed'"):
        mini.read("speed")
    with pytest.raises(ProfileError, match="battery is read-only"):
        mini.write("battery", 50)
    with pytest.raises(ProfileError, match="action is write-only"):
        mini.read("action")
    with pytest.raises(ProfileError, match="calibration is an unsafe register"):
        mini.write("calibration", 1)
    with pytest.raises(ValueRangeError, match=r"vx = 99 mm/step is out of range"):
        mini.write("vx", 99)
    assert mini.transport.robot.received == []  # type: ignore[attr-defined]
    with pytest.raises(ProfileError, match="XgoClient talks to XGO robots"):
        XgoClient(mini.transport, get_profile("xarm"))


def test_rider_feedback_frames_are_skipped() -> None:
    # Auto feedback streams reply frames at 0x01, 0x02, 0x62 (12 bytes) and 0x65 at 50 Hz;
    # a read of imu_roll (0x62, 4 bytes) must not take the 12-byte feedback frame for its reply.
    with open_transport("sim:rider") as link:
        rider = XgoClient(link, get_profile("rider"))
        rider.write("auto_feedback", 1)
        for _ in range(5):
            assert rider.firmware() == "R-1.2.3"
            assert isinstance(rider.read_value("imu_roll"), float)
            assert rider.read_value("status") == "normal"
        assert link.robot.snapshot()["feedback_ticks"] > 0  # type: ignore[attr-defined]


def test_timeout_on_a_fake_clock_is_a_transport_timeout() -> None:
    now = [0.0]

    def advance(dt: float) -> None:
        now[0] += dt

    with open_transport("sim:mini", clock=lambda: now[0], sleep=advance) as link:
        client = XgoClient(link, get_profile("mini"), timeout=2.0, clock=lambda: now[0])
        with pytest.raises(TransportTimeout) as info:
            client.read(0xF0)  # no register there: the robot stays silent
    assert str(info.value) == "no reply from sim:mini to a read of 0xF0 within 2 s"
    assert now[0] >= 2.0


# ---------------------------------------------------------------- simulator on a real pty
def test_client_over_a_real_pty() -> None:
    robot = create_robot("lite")
    with PtyServer(robot) as server, open_client(server.path) as client:
        assert client.model == "lite"
        assert client.transport.url == server.path
        assert client.battery() == 100
        client.write("body_z", 80.0)
        client.action("sit_down")
    with server.lock:
        frames = [f.data for f in robot.received]
    assert frames[0] == read_frame(0x07, 10)
    assert frames[-1][3:5] == bytes((0x00, 0x3E))  # the action write arrived last


def test_open_client_refuses_unknown_firmware() -> None:
    with (
        PtyServer(create_robot("mini", firmware="Q-0.0.1")) as server,
        pytest.raises(ProfileError, match=r"firmware 'Q-0.0.1', which names no supported"),
    ):
        open_client(server.path)


def test_open_client_takes_the_model_from_a_sim_url() -> None:
    with open_client("hex+sim:rider") as client:
        assert client.model == "rider"
    with open_client("sim:rider", "rider") as client:
        assert client.profile is get_profile("rider")


# ---------------------------------------------------------------- scripted peer on a pty
def client_on(peer: Any, link_timeout: float = 0.2) -> XgoClient:
    link = open_transport(peer.path)
    link.open()
    return XgoClient(link, get_profile("mini"), timeout=link_timeout)


def test_unsolicited_frames_and_junk_are_skipped(xgo_peer: Any) -> None:
    def answer(frame: XgoFrame) -> bytes:
        return b"".join(
            (
                reply_frame(0x62, bytes(12)),  # feedback-like frame at another address
                b"\xff\x55\x00\x30junk",  # line noise with a false header
                reply_frame(0x07, b"abc"),  # right address, wrong size: not the reply
                reply_frame(0x01, b"\x50"),
                reply_frame(0x07, b"M-2.0.0\0\0\0"),
            )
        )

    with client_on(xgo_peer(answer)) as client:
        assert client.firmware() == "M-2.0.0"


def test_silence_is_a_timeout_naming_port_and_register(xgo_peer: Any) -> None:
    peer = xgo_peer(lambda frame: b"")
    with client_on(peer, 0.1) as client, pytest.raises(TransportTimeout) as info:
        client.firmware()
    assert str(info.value) == (
        f"no reply from {peer.path} to a read of firmware (0x07) within 0.1 s"
    )


def test_garbage_is_a_protocol_error(xgo_peer: Any) -> None:
    peer = xgo_peer(lambda frame: b"\x13\x37\xfe" * 10)
    with client_on(peer, 0.1) as client, pytest.raises(ProtocolError) as info:
        client.battery()
    assert str(info.value) == (
        f"garbage from {peer.path} to a read of battery (0x01): 30 bytes that are no XGO "
        "frame (wrong baud rate, or not an XGO robot?)"
    )


def test_reply_of_the_wrong_size_is_a_protocol_error(xgo_peer: Any) -> None:
    peer = xgo_peer(lambda frame: reply_frame(frame.address, b"abc"))
    with client_on(peer, 0.1) as client, pytest.raises(ProtocolError) as info:
        client.firmware()
    assert str(info.value) == (
        f"reply from {peer.path} to a read of firmware (0x07) has 3 data bytes, expected 10"
    )


def test_stale_bytes_before_a_request_are_not_its_reply(xgo_peer: Any) -> None:
    peer = xgo_peer(lambda frame: reply_frame(0x01, b"\x2a"))
    with client_on(peer) as client:
        os.write(peer.master, reply_frame(0x01, b"\x07"))  # a late reply to an older read
        select.select([], [], [], 0.05)  # let it reach the port's input queue
        assert client.battery() == 42


def test_frames_are_spaced_by_wire_time_and_gap_on_a_fake_clock() -> None:
    now = [0.0]

    def advance(dt: float) -> None:
        now[0] += dt

    profile = get_profile("mini")
    with open_transport("sim:mini", clock=lambda: now[0], sleep=advance) as link:
        client = XgoClient(link, profile, clock=lambda: now[0], sleep=advance)
        client.write("vx", 0.0)
        client.write("vyaw", 0.0)
        client.battery()
        times = [f.t for f in link.robot.received]  # type: ignore[attr-defined]
    spacing = profile.link.wire_time(9) + profile.link.gap
    assert times[1] - times[0] == pytest.approx(spacing)
    assert times[2] - times[1] == pytest.approx(spacing)
