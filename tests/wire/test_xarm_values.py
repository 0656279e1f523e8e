"""xArm messages are values with stated ranges: what they hold does not depend on how they were
built, every integer field takes both ends of its range and refuses one past either, and a
refusal names the message and the field, whether built in code or parsed off the wire."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from xgo_show.errors import ProtocolError
from xgo_show.wire.xarm import (
    BatteryVoltage,
    GroupErase,
    GroupRun,
    GroupRunRepeat,
    GroupSpeed,
    ServoMove,
    ServoOff,
    ServoOffsetRead,
    ServoOffsets,
    ServoOffsetWrite,
    ServoPositionRead,
    ServoPositions,
    ServoPositionWrite,
    XarmCommand,
    XarmPacket,
    decode_one,
    encode_packet,
    group_run,
    parse_reply,
    parse_request,
)

C = XarmCommand


def packet_of(raw: bytes) -> XarmPacket:
    used, packet = decode_one(raw)
    assert used == len(raw) and packet is not None
    return packet


def refused(call: Callable[[], object]) -> str:
    with pytest.raises(ProtocolError) as err:
        call()
    return str(err.value)


def test_a_packet_holds_its_command_as_the_enum_and_its_params_as_bytes() -> None:
    packet = XarmPacket(3, bytearray(b"\x01\x10\x00\x01\xf4\x01"))  # type: ignore[arg-type]
    assert type(packet.command) is XarmCommand and packet.command.label == "ServoMove"
    assert type(packet.params) is bytes
    assert packet == XarmPacket(C.SERVO_MOVE, b"\x01\x10\x00\x01\xf4\x01")


# Each message with a map or a list of servos, built from a mutable value.
MAPS: list[tuple[Callable[[dict[int, int]], object], str]] = [
    (lambda m: ServoMove(100, m), "positions"),
    (ServoPositionWrite, "positions"),
    (ServoPositions, "positions"),
    (ServoOffsets, "offsets"),
]
LISTS: list[Callable[[list[int]], object]] = [ServoOff, ServoPositionRead, ServoOffsetRead]  # type: ignore[list-item]


@pytest.mark.parametrize(("build", "field"), MAPS)
def test_a_message_keeps_its_own_copy_of_the_servo_map(
    build: Callable[[dict[int, int]], object], field: str
) -> None:
    given = {1: 10, 2: 20}
    message = build(given)
    given[1] = 99
    given[3] = 30
    assert getattr(message, field) == {1: 10, 2: 20}
    assert message == build({1: 10, 2: 20})


@pytest.mark.parametrize("build", LISTS)
def test_a_message_built_from_a_list_of_ids_equals_one_built_from_a_tuple(
    build: Callable[[list[int]], object],
) -> None:
    message = build([4, 2])
    assert message.ids == (4, 2)  # type: ignore[attr-defined]
    assert message == build((4, 2))  # type: ignore[arg-type]


def test_group_run_runs_the_group_once_unless_told() -> None:
    assert group_run(7) == group_run(7, 1) == GroupRun(7).encode()


# (constructor of one integer field, the field's name in messages, lowest, highest)
RANGES: list[tuple[Callable[[int], object], str, int, int]] = [
    (lambda v: ServoMove(v, {1: 0}), "ServoMove time (ms)", 0, 0xFFFF),
    (lambda v: ServoMove(0, {v: 0}), "servo id", 1, 255),
    (lambda v: ServoMove(0, {1: v}), "servo 1 position", 0, 1000),
    (lambda v: GroupRunRepeat(v, 1), "action group", 0, 255),
    (lambda v: GroupRunRepeat(1, v), "GroupRunRepeat times", 0, 255),
    (lambda v: GroupRun(v, 1), "action group", 0, 255),
    (lambda v: GroupRun(1, v), "GroupRun count", 0, 0xFFFF),
    (GroupErase, "action group", 0, 255),
    (lambda v: GroupSpeed(v, 100), "action group", 0, 255),
    (lambda v: GroupSpeed(1, v), "GroupSpeed percent", 0, 0xFFFF),
    (lambda v: ServoOff((v,)), "servo id", 1, 255),
    (lambda v: ServoPositionWrite({1: v}), "servo 1 position", 0, 1000),
    (lambda v: ServoOffsetWrite(v, 0), "servo id", 1, 255),
    (lambda v: ServoOffsetWrite(2, v), "servo 2 offset", -128, 127),
    (BatteryVoltage, "battery voltage (mV)", 0, 0xFFFF),
    (lambda v: ServoPositions({1: v}), "servo 1 position", 0, 0xFFFF),
    (lambda v: ServoOffsets({1: v}), "servo 1 offset", -128, 127),
]


@pytest.mark.parametrize(("build", "what", "low", "high"), RANGES)
def test_every_integer_field_takes_its_range_and_refuses_one_past_it(
    build: Callable[[int], object], what: str, low: int, high: int
) -> None:
    build(low)
    build(high)
    for bad in (low - 1, high + 1):
        assert refused(lambda b=bad: build(b)) == f"xArm {what} {bad} must be {low}..{high}"


# (build a message with no servos, its name in the refusal, how many servos it can carry)
EMPTY: list[tuple[Callable[[], object], str, int]] = [
    (lambda: ServoMove(0, {}), "ServoMove", 83),
    (lambda: ServoOff(()), "ServoOff", 252),
    (lambda: ServoPositionRead(()), "ServoPositionRead", 252),
    (lambda: ServoPositionWrite({}), "ServoPositionWrite", 84),
    (lambda: ServoOffsetRead(()), "ServoOffsetRead", 252),
    (lambda: ServoPositions({}), "ServoPositionRead reply", 84),
    (lambda: ServoOffsets({}), "ServoOffsetRead reply", 126),
]


@pytest.mark.parametrize(("build", "name", "limit"), EMPTY)
def test_a_message_without_servos_is_refused_by_name(
    build: Callable[[], object], name: str, limit: int
) -> None:
    assert refused(build) == f"xArm {name} takes 1..{limit} servo ids; got 0"


@pytest.mark.parametrize(
    ("packet", "parse", "message"),
    [
        (XarmPacket(C.SERVO_MOVE, bytes.fromhex("02 10 00 05 00 00 05 01 00")), parse_request,
         "xArm ServoMove lists servo 5 twice"),
        (XarmPacket(C.SERVO_POSITION_WRITE, bytes.fromhex("02 05 00 00 05 01 00")),
         parse_request, "xArm ServoPositionWrite lists servo 5 twice"),
        (XarmPacket(C.SERVO_POSITION_READ, bytes.fromhex("02 05 00 00 05 01 00")), parse_reply,
         "xArm ServoPositionRead reply lists servo 5 twice"),
        (XarmPacket(C.SERVO_POSITION_READ, bytes.fromhex("02 05 05")), parse_request,
         "xArm ServoPositionRead lists servo 5 twice"),
        (XarmPacket(C.SERVO_OFFSET_READ, bytes.fromhex("02 05 05")), parse_request,
         "xArm ServoOffsetRead lists servo 5 twice"),
    ],
)
def test_a_parsed_packet_that_lists_a_servo_twice_is_refused_by_name(
    packet: XarmPacket, parse: Callable[[XarmPacket], object], message: str
) -> None:
    assert refused(lambda: parse(packet)) == message


@pytest.mark.parametrize("value", [0x0001, 0x0100, 0x1234, 0xFFFF])
def test_sixteen_bit_fields_survive_the_wire_whole(value: int) -> None:
    for message in (GroupRun(3, value), GroupSpeed(3, value), ServoMove(value, {1: 500})):
        assert parse_request(packet_of(message.encode())) == message
    for reply in (BatteryVoltage(value), ServoPositions({1: value})):
        assert parse_reply(packet_of(reply.encode())) == reply


@pytest.mark.parametrize(
    ("command", "params", "message"),
    [
        (C.SERVO_MOVE, b"\x01\x00",
         "xArm ServoMove parameters are 2 bytes; expected 3 + 3 x count bytes with count >= 1"),
        (C.GET_BATTERY_VOLTAGE, b"\x01",
         "xArm GetBatteryVoltage parameters are 1 bytes; expected 0 bytes or 2 bytes"),
        (C.SERVO_POSITION_READ, b"\x02\x01",
         "xArm ServoPositionRead parameters are 2 bytes; expected 1 + 1 x count bytes or "
         "1 + 3 x count bytes with count >= 1"),
        (C.GROUP_RUN, b"\x01", "xArm GroupRun parameters are 1 bytes; expected 3 bytes"),
    ],
)
def test_a_packet_of_the_wrong_size_is_refused_with_every_size_it_could_have(
    command: XarmCommand, params: bytes, message: str
) -> None:
    assert refused(lambda: encode_packet(command, params)) == message
