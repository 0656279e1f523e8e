"""xArm packet codec: byte vectors fed whole, split, byte by byte, with junk; typed builders and
parsers; hypothesis round trips and noise.

Packet layout: ``55 55 | length (= params + 2) | command | params``, u16 little-endian.
"""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Callable

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from xgo_show.errors import ProtocolError
from xgo_show.wire.xarm import (
    ALL_GROUPS,
    MAX_PACKET,
    BatteryVoltage,
    GetBatteryVoltage,
    GroupErase,
    GroupRun,
    GroupRunRepeat,
    GroupSpeed,
    GroupStop,
    ServoMove,
    ServoOff,
    ServoOffsetRead,
    ServoOffsets,
    ServoOffsetWrite,
    ServoPositionRead,
    ServoPositions,
    ServoPositionWrite,
    XarmCommand,
    XarmDecoder,
    XarmPacket,
    XarmReply,
    XarmRequest,
    battery_mv,
    battery_reply,
    decode_one,
    encode_packet,
    get_battery_voltage,
    group_erase,
    group_run,
    group_run_repeat,
    group_speed,
    group_stop,
    offsets,
    offsets_reply,
    parse_reply,
    parse_request,
    positions,
    positions_reply,
    servo_move,
    servo_off,
    servo_offset_read,
    servo_offset_write,
    servo_position_read,
    servo_position_write,
)

C = XarmCommand

# --- Byte vectors (each header byte explained once, in the first) ---------------------------------
# 55 55 header | 08 length = 6 params + 2 | 03 ServoMove | 01 one servo | E8 03 = 1000 ms (LE)
# | 01 servo 1 | F4 01 = position 500. The vendor `xarm` library sends these exact bytes for
# setPosition(1, 500, duration=1000) (its _send writes 55 55, len(data) + 2, command, data;
# tests/interop/test_interop_xarm.py drives the simulator with it).
MOVE_ONE = bytes.fromhex("55 55 08 03 01 E8 03 01 F4 01")
# Six servos to 0, 200, 400, 600, 800, 1000 in 500 ms (F4 01): 2 + 3 + 6*3 = 23 = 0x17.
MOVE_SIX = bytes.fromhex(
    "55 55 17 03 06 F4 01  01 00 00  02 C8 00  03 90 01  04 58 02  05 20 03  06 E8 03"
)
GROUP_STOP = bytes.fromhex("55 55 02 07")  # no parameters
BATTERY_REQ = bytes.fromhex("55 55 02 0F")
BATTERY_REP = bytes.fromhex("55 55 04 0F B0 1D")  # 0x1DB0 = 7600 mV
SERVO_OFF_ALL = bytes.fromhex("55 55 09 14 06 01 02 03 04 05 06")  # vendor servoOff()
POS_READ = bytes.fromhex("55 55 05 15 02 01 06")  # servos 1 and 6
POS_REPLY = bytes.fromhex("55 55 09 15 02 01 F4 01 06 E8 03")  # 1 -> 500, 6 -> 1000
POS_WRITE = bytes.fromhex("55 55 09 16 02 01 00 00 02 E8 03")  # 1 -> 0, 2 -> 1000
OFFSET_READ = bytes.fromhex("55 55 04 17 01 02")
OFFSET_REPLY = bytes.fromhex("55 55 05 17 01 02 FB")  # servo 2 offset -5 (signed byte)
OFFSET_WRITE = bytes.fromhex("55 55 04 18 02 FB")
GROUP_RUN_REPEAT = bytes.fromhex("55 55 04 05 FF 02")  # all groups, twice
GROUP_RUN = bytes.fromhex("55 55 05 06 01 00 00")  # group 1, continuously
GROUP_ERASE = bytes.fromhex("55 55 03 08 FF")
GROUP_SPEED = bytes.fromhex("55 55 05 0B 01 96 00")  # group 1 at 150 %

VECTORS: list[tuple[str, bytes, bytes, XarmRequest | XarmReply]] = [
    # (id, bytes, builder output, typed message)
    ("move-one", MOVE_ONE, servo_move(1000, {1: 500}), ServoMove(1000, {1: 500})),
    (
        "move-six",
        MOVE_SIX,
        servo_move(500, {i: (i - 1) * 200 for i in range(1, 7)}),
        ServoMove(500, {i: (i - 1) * 200 for i in range(1, 7)}),
    ),
    ("group-stop", GROUP_STOP, group_stop(), GroupStop()),
    ("battery-req", BATTERY_REQ, get_battery_voltage(), GetBatteryVoltage()),
    ("battery-rep", BATTERY_REP, battery_reply(7600), BatteryVoltage(7600)),
    ("servo-off", SERVO_OFF_ALL, servo_off(range(1, 7)), ServoOff((1, 2, 3, 4, 5, 6))),
    ("pos-read", POS_READ, servo_position_read([1, 6]), ServoPositionRead((1, 6))),
    ("pos-reply", POS_REPLY, positions_reply({1: 500, 6: 1000}), ServoPositions({1: 500, 6: 1000})),
    (
        "pos-write",
        POS_WRITE,
        servo_position_write({1: 0, 2: 1000}),
        ServoPositionWrite({1: 0, 2: 1000}),
    ),
    ("offset-read", OFFSET_READ, servo_offset_read([2]), ServoOffsetRead((2,))),
    ("offset-reply", OFFSET_REPLY, offsets_reply({2: -5}), ServoOffsets({2: -5})),
    ("offset-write", OFFSET_WRITE, servo_offset_write(2, -5), ServoOffsetWrite(2, -5)),
    ("group-repeat", GROUP_RUN_REPEAT, group_run_repeat(ALL_GROUPS, 2), GroupRunRepeat(255, 2)),
    ("group-run", GROUP_RUN, group_run(1, 0), GroupRun(1, 0)),
    ("group-erase", GROUP_ERASE, group_erase(ALL_GROUPS), GroupErase(255)),
    ("group-speed", GROUP_SPEED, group_speed(1, 150), GroupSpeed(1, 150)),
]
REPLIES = {BATTERY_REP, POS_REPLY, OFFSET_REPLY}
RAW = [pytest.param(v[1], id=v[0]) for v in VECTORS]


def packet_of(raw: bytes) -> XarmPacket:
    return XarmPacket(XarmCommand(raw[3]), raw[4:])


def feed_all(chunks: list[bytes]) -> tuple[list[XarmPacket], XarmDecoder]:
    dec = XarmDecoder()
    out: list[XarmPacket] = []
    for chunk in chunks:
        out += dec.feed(chunk)
    return out, dec


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    bounds = [0, *sorted({c % (len(data) + 1) for c in cuts}), len(data)]
    return [data[a:b] for a, b in itertools.pairwise(bounds)]


# --- Encoding and typed messages ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("raw", "built", "message"), [pytest.param(*v[1:], id=v[0]) for v in VECTORS]
)
def test_builders_and_messages_encode_vector(
    raw: bytes, built: bytes, message: XarmRequest | XarmReply
) -> None:
    assert built == raw
    assert message.encode() == raw
    assert packet_of(raw).encode() == raw


@pytest.mark.parametrize(("raw", "message"), [pytest.param(v[1], v[3], id=v[0]) for v in VECTORS])
def test_parse_vector(raw: bytes, message: XarmRequest | XarmReply) -> None:
    packet = packet_of(raw)
    assert packet.is_reply == (raw in REPLIES)
    parsed = parse_reply(packet) if packet.is_reply else parse_request(packet)
    assert parsed == message


def test_typed_reply_accessors() -> None:
    assert battery_mv(packet_of(BATTERY_REP)) == 7600
    assert positions(packet_of(POS_REPLY)) == {1: 500, 6: 1000}
    assert list(positions(packet_of(POS_REPLY))) == [1, 6]  # wire order kept
    assert offsets(packet_of(OFFSET_REPLY)) == {2: -5}


@pytest.mark.parametrize(
    ("call", "packet"),
    [
        (battery_mv, POS_REPLY),
        (positions, BATTERY_REP),
        (offsets, POS_REPLY),
        (positions, POS_READ),  # a request, not a reply
        (battery_mv, BATTERY_REQ),
    ],
)
def test_typed_reply_accessors_reject_other_packets(
    call: Callable[[XarmPacket], object], packet: bytes
) -> None:
    with pytest.raises(ProtocolError, match="reply"):
        call(packet_of(packet))


def test_offsets_are_signed_bytes() -> None:
    raw = offsets_reply({1: -128, 2: 127, 3: 0, 4: -1})
    assert raw[4:] == bytes.fromhex("04 01 80 02 7F 03 00 04 FF")
    assert offsets(packet_of(raw)) == {1: -128, 2: 127, 3: 0, 4: -1}


def test_command_labels_are_the_seed_names() -> None:
    assert C.SERVO_MOVE.label == "ServoMove"
    assert C.GET_BATTERY_VOLTAGE.label == "GetBatteryVoltage"
    assert [int(c) for c in C] == [3, 5, 6, 7, 8, 11, 15, 20, 21, 22, 23, 24, 26, 27, 28]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: servo_move(1000, {0: 500}), "servo id 0 must be 1..255"),
        (lambda: servo_move(1000, {256: 500}), "servo id 256 must be 1..255"),
        (lambda: servo_move(1000, {1: 1001}), "servo 1 position 1001 must be 0..1000"),
        (lambda: servo_move(1000, {1: -1}), "servo 1 position -1 must be 0..1000"),
        (lambda: servo_move(65536, {1: 0}), "time \\(ms\\) 65536 must be 0..65535"),
        (lambda: servo_move(-1, {1: 0}), "time \\(ms\\) -1 must be 0..65535"),
        (lambda: servo_move(100, {}), "takes 1..83 servo ids; got 0"),
        (lambda: servo_move(100, dict.fromkeys(range(1, 85), 0)), "takes 1..83 servo ids; got 84"),
        (lambda: servo_move(100, {1: 500.0}), "must be an integer, not 500.0"),  # type: ignore[dict-item]
        (lambda: servo_move(100, {1: True}), "must be an integer, not True"),
        (lambda: servo_off([]), "ServoOff takes 1..252 servo ids; got 0"),
        (lambda: servo_off([1, 2, 1]), "ServoOff lists servo 1 twice"),
        (lambda: servo_position_read([7, 0]), "servo id 0"),
        (lambda: servo_offset_read(range(1, 254)), "got 253"),
        (lambda: servo_position_write({1: 2000}), "servo 1 position 2000"),
        (lambda: servo_offset_write(1, 128), "servo 1 offset 128 must be -128..127"),
        (lambda: servo_offset_write(1, -129), "offset -129"),
        (lambda: servo_offset_write(0, 0), "servo id 0"),
        (lambda: group_run_repeat(256, 1), "action group 256 must be 0..255"),
        (lambda: group_run_repeat(1, 256), "GroupRunRepeat times 256"),
        (lambda: group_run(1, 70000), "GroupRun count 70000"),
        (lambda: group_erase(-1), "action group -1"),
        (lambda: group_speed(1, 65536), "GroupSpeed percent 65536"),
        (lambda: battery_reply(70000), "battery voltage \\(mV\\) 70000"),
        (lambda: positions_reply({1: 65536}), "servo 1 position 65536"),
        (lambda: offsets_reply({1: 200}), "servo 1 offset 200"),
        (lambda: encode_packet(99), "command 99 is not a known command number"),
        (
            lambda: encode_packet(C.GROUP_STOP, b"\x00"),
            "GroupStop parameters are 1 bytes; expected 0",
        ),
        (lambda: encode_packet(C.SERVO_OFF, b"\x02\x01"), "ServoOff parameters are 2 bytes"),
        (lambda: encode_packet(C.SERVO_OFF, b"\x00"), "with count >= 1"),
        (lambda: XarmPacket(99, b""), "command 99"),  # type: ignore[arg-type]
    ],
)
def test_bad_values_raise_protocol_error(call: Callable[[], object], message: str) -> None:
    with pytest.raises(ProtocolError, match=message):
        call()


def test_positions_reply_allows_readings_outside_move_range() -> None:
    # A reading is reported as the arm sent it (u16), not rejected like a bad move target.
    assert positions(packet_of(positions_reply({1: 1020}))) == {1: 1020}


def test_largest_packets_fit_the_length_byte() -> None:
    move = servo_move(1, {i: 1 for i in range(1, 84)})  # 83 servos: 3 + 249 parameter bytes
    assert len(move) == 256 and move[2] == 254
    biggest = offsets_reply({i: -1 for i in range(1, 127)})  # 1 + 126 x 2 = 253 parameters
    assert len(biggest) == MAX_PACKET == 257 and biggest[2] == 255
    for raw in (move, biggest):
        assert decode_one(raw) == (len(raw), packet_of(raw))


# --- parse_request / parse_reply on hand-made packets ---------------------------------------------


@pytest.mark.parametrize(
    ("packet", "message"),
    [
        (XarmPacket(C.SERVO_MOVE, bytes.fromhex("01 E8 03 01 E9 03")), "servo 1 position 1001"),
        (XarmPacket(C.SERVO_MOVE, bytes.fromhex("02 E8 03 01 00 00 01 00 00")), "servo 1 twice"),
        (XarmPacket(C.SERVO_MOVE, bytes.fromhex("01 E8 03 00 00 00")), "servo id 0"),
        (XarmPacket(C.SERVO_MOVE, bytes.fromhex("02 E8 03 01 00 00")), "expected 3 \\+ 3 x count"),
        (XarmPacket(C.SERVO_OFF, bytes.fromhex("02 01 01")), "ServoOff lists servo 1 twice"),
        (XarmPacket(C.SERVO_POSITION_READ, bytes.fromhex("01 01 F4 01")), "has no|request"),
        (XarmPacket(C.BUS_SERVO_INFO_WRITE, bytes(12)), "BusServoInfoWrite \\(27\\) is recognised"),
        (XarmPacket(C.BUS_SERVO_MORO_CTRL, bytes(4)), "BusServoMoroCtrl"),
        (XarmPacket(C.GROUP_STOP, b"\x00"), "GroupStop request parameters are 1 bytes"),
    ],
)
def test_parse_request_rejects(packet: XarmPacket, message: str) -> None:
    with pytest.raises(ProtocolError, match=message):
        parse_request(packet)


@pytest.mark.parametrize(
    ("packet", "message"),
    [
        (XarmPacket(C.GROUP_STOP), "GroupStop has no reply"),
        (XarmPacket(C.GET_BATTERY_VOLTAGE), "expected 2 bytes"),
        (XarmPacket(C.SERVO_POSITION_READ, bytes.fromhex("02 01 00 00 01 00 00")), "twice"),
        (XarmPacket(C.SERVO_OFFSET_READ, bytes.fromhex("02 01 00 01 00")), "twice"),
        (XarmPacket(C.BUS_SERVO_INFO_READ, bytes(19)), "recognised but not supported"),
    ],
)
def test_parse_reply_rejects(packet: XarmPacket, message: str) -> None:
    with pytest.raises(ProtocolError, match=message):
        parse_reply(packet)


def test_bus_servo_commands_are_framed() -> None:
    # Recognised so a simulator can name them, even though they are not interpreted.
    info_read = encode_packet(C.BUS_SERVO_INFO_READ)
    info_reply = encode_packet(C.BUS_SERVO_INFO_READ, bytes(19))
    out, dec = feed_all([info_read + info_reply])
    assert [p.is_reply for p in out] == [False, True]
    assert dec.discarded == 0


# --- decode_one contract --------------------------------------------------------------------------


@pytest.mark.parametrize("raw", RAW)
def test_decode_one_whole(raw: bytes) -> None:
    assert decode_one(raw) == (len(raw), packet_of(raw))


@pytest.mark.parametrize("raw", RAW)
def test_decode_one_needs_more_for_every_prefix(raw: bytes) -> None:
    for cut in range(len(raw)):
        assert decode_one(raw[:cut]) == (0, None), cut


@pytest.mark.parametrize(
    ("buf", "used"),
    [
        (b"\x01\x02\x55\x55", 2),  # skip to the next header byte
        (b"\x01\x02\x03", 3),
        (b"\x55\x01", 1),  # 55 not followed by 55
        (b"\x55\x55\x01", 1),  # length 1 < 2 is impossible, known at once
        (b"\x55\x55\x00\x07", 1),
        (b"\x55\x55\x02\x63", 1),  # unknown command 99
        (b"\x55\x55\x02\x0c", 1),  # 12: "not sure" in the seed, not recognised
        (b"\x55\x55\x03\x07\x00", 1),  # GroupStop with a parameter
        (b"\x55\x55\xff\x07", 1),  # huge length for a fixed-size command: rejected at once
        (b"\x55\x55\x05\x14\x01", 1),  # ServoOff count 1 needs length 4, not 5
        (b"\x55\x55\x03\x14\x00", 1),  # count 0
        (b"\x55\x55\xff\x03\x53", 1),  # ServoMove count 83 needs length 254, not 255
        (b"\x55\x55\x02\x14", 1),  # ServoOff with no count byte at all
    ],
)
def test_decode_one_rejects_implausible_headers(buf: bytes, used: int) -> None:
    assert decode_one(buf) == (used, None)


@pytest.mark.parametrize(
    "buf",
    [
        b"\x55",
        b"\x55\x55",
        b"\x55\x55\x02",
        b"\x55\x55\x06\x14",  # ServoOff: the count byte decides
        b"\x55\x55\xfe\x03\x53",  # ServoMove of 83 servos: plausible, wait for 256 bytes
    ],
)
def test_decode_one_waits_on_plausible_prefixes(buf: bytes) -> None:
    assert decode_one(buf) == (0, None)


# --- Streaming decoder ----------------------------------------------------------------------------


@pytest.mark.parametrize("raw", RAW)
def test_feed_split_at_every_point(raw: bytes) -> None:
    for cut in range(len(raw) + 1):
        dec = XarmDecoder()
        first = dec.feed(raw[:cut])
        second = dec.feed(raw[cut:])
        assert first + second == [packet_of(raw)], cut
        assert (dec.discarded, dec.pending, dec.packets) == (0, 0, 1)


@pytest.mark.parametrize("raw", RAW)
def test_feed_byte_by_byte(raw: bytes) -> None:
    out, dec = feed_all([raw[i : i + 1] for i in range(len(raw))])
    assert out == [packet_of(raw)]
    assert (dec.discarded, dec.pending) == (0, 0)


@pytest.mark.parametrize("raw", RAW)
def test_feed_with_junk_before_and_after(raw: bytes) -> None:
    # "55 55 02 63" is a header with an unknown command; "55 01" a half header.
    before, after = b"\x00\xff\x55\x55\x02\x63\x55\x01\x07", b"\x13\x37\x00"
    out, dec = feed_all([before + raw + after])
    assert out == [packet_of(raw)]
    assert (dec.discarded, dec.pending) == (len(before) + len(after), 0)


def test_feed_back_to_back_all_vectors() -> None:
    stream = b"".join(v[1] for v in VECTORS)
    expected = [packet_of(v[1]) for v in VECTORS]
    for chunks in ([stream], [stream[i : i + 1] for i in range(len(stream))]):
        out, dec = feed_all(chunks)
        assert out == expected
        assert (dec.discarded, dec.pending, dec.packets) == (0, 0, len(VECTORS))


def test_header_bytes_inside_parameters_do_not_split_a_packet() -> None:
    # 0x5555 ms = 21845 ms: the time field holds "55 55"; servo 0x55 at 0x0255 adds "55 55 02".
    raw = servo_move(0x5555, {0x55: 0x0255, 7: 0x0207})
    assert raw.count(b"\x55\x55") == 3
    for cut in range(len(raw) + 1):
        out, dec = feed_all([raw[:cut], raw[cut:]])
        assert out == [packet_of(raw)], cut
        assert dec.discarded == 0


def test_false_header_with_huge_length_does_not_hold_up_a_real_packet() -> None:
    # "55 55 F0 07" claims a 242-byte GroupStop: impossible, so the real reply behind it comes
    # out as soon as it is complete.
    noise = b"\x55\x55\xf0\x07"
    dec = XarmDecoder()
    assert dec.feed(noise + BATTERY_REP[:-1]) == []
    assert dec.feed(BATTERY_REP[-1:]) == [packet_of(BATTERY_REP)]
    assert (dec.discarded, dec.pending) == (len(noise), 0)


def test_plausible_false_header_holds_until_reset() -> None:
    # Without a checksum a plausible header ("ServoOff of 3 servos") is indistinguishable from a
    # real packet: its next bytes are taken as its parameters. reset() before a request is how a
    # host recovers (module docstring).
    dec = XarmDecoder()
    assert dec.feed(b"\x55\x55\x06\x14\x03") == []
    assert dec.pending == 5
    dec.reset()
    assert dec.discarded == 5
    assert dec.feed(BATTERY_REP) == [packet_of(BATTERY_REP)]


def test_torn_packet_then_real_packet() -> None:
    # A reply lost its last byte; the next reply's bytes complete it (no checksum can tell), and
    # what follows resynchronises. This is why hosts reset() before each request.
    out, dec = feed_all([POS_REPLY[:-1], BATTERY_REP, BATTERY_REP])
    bogus = XarmPacket(C.SERVO_POSITION_READ, POS_REPLY[4:-1] + b"\x55")
    assert out == [bogus, packet_of(BATTERY_REP)]
    assert dec.discarded == len(BATTERY_REP) - 1


# --- Properties -----------------------------------------------------------------------------------

servo_ids = st.integers(1, 255)
position = st.integers(0, 1000)
u8, u16 = st.integers(0, 255), st.integers(0, 0xFFFF)
offset = st.integers(-128, 127)
id_lists = st.lists(servo_ids, min_size=1, max_size=20, unique=True).map(tuple)

requests: st.SearchStrategy[XarmRequest] = st.one_of(
    st.builds(ServoMove, u16, st.dictionaries(servo_ids, position, min_size=1, max_size=83)),
    st.builds(GroupRunRepeat, u8, u8),
    st.builds(GroupRun, u8, u16),
    st.just(GroupStop()),
    st.builds(GroupErase, u8),
    st.builds(GroupSpeed, u8, u16),
    st.just(GetBatteryVoltage()),
    st.builds(ServoOff, id_lists),
    st.builds(ServoPositionRead, id_lists),
    st.builds(ServoPositionWrite, st.dictionaries(servo_ids, position, min_size=1, max_size=84)),
    st.builds(ServoOffsetRead, id_lists),
    st.builds(ServoOffsetWrite, servo_ids, offset),
)
replies: st.SearchStrategy[XarmReply] = st.one_of(
    st.builds(BatteryVoltage, u16),
    st.builds(ServoPositions, st.dictionaries(servo_ids, u16, min_size=1, max_size=84)),
    st.builds(ServoOffsets, st.dictionaries(servo_ids, offset, min_size=1, max_size=126)),
)
messages = st.one_of(requests, replies)

# Oracle for "could a packet start here", written from the seed table independently of the codec:
# command -> parameter sizes allowed for a count byte c (requests and replies).
SIZES: dict[int, Callable[[int], set[int]]] = {
    3: lambda c: {3 + 3 * c},
    5: lambda c: {2},
    6: lambda c: {3},
    7: lambda c: {0},
    8: lambda c: {1},
    11: lambda c: {3},
    15: lambda c: {0, 2},
    20: lambda c: {1 + c},
    21: lambda c: {1 + c, 1 + 3 * c},
    22: lambda c: {1 + 3 * c},
    23: lambda c: {1 + c, 1 + 2 * c},
    24: lambda c: {2},
    26: lambda c: {4},
    27: lambda c: {12},
    28: lambda c: {0, 19},
}
COUNTED = {3, 20, 21, 22, 23}


def candidate_size(buf: bytes, pos: int) -> int:
    """Size of a plausible packet starting at ``pos`` (judged on the bytes there), else 0."""
    head = buf[pos : pos + 5]
    if len(head) < 4 or head[:2] != b"\x55\x55" or head[3] not in SIZES or head[2] < 2:
        return 0
    nparams, cmd = head[2] - 2, head[3]
    if cmd in COUNTED:
        if nparams == 0 or len(head) < 5 or head[4] == 0:
            return 0
        return nparams + 4 if nparams in SIZES[cmd](head[4]) else 0
    return nparams + 4 if nparams in SIZES[cmd](0) else 0


@given(messages)
def test_message_round_trip(message: XarmRequest | XarmReply) -> None:
    raw = message.encode()
    used, packet = decode_one(raw)
    assert used == len(raw) and packet is not None
    assert packet.encode() == raw
    if isinstance(message, BatteryVoltage | ServoPositions | ServoOffsets):
        assert packet.is_reply
        assert parse_reply(packet) == message
    else:
        assert not packet.is_reply
        assert parse_request(packet) == message


@given(st.sampled_from(list(C)), st.binary(max_size=253))
def test_encode_packet_accepts_exactly_what_decode_one_accepts(cmd: C, params: bytes) -> None:
    try:
        raw = encode_packet(cmd, params)
    except ProtocolError:
        raw = b"\x55\x55" + bytes((len(params) + 2, cmd)) + params
        assert decode_one(raw)[1] is None
    else:
        assert decode_one(raw) == (len(raw), XarmPacket(cmd, params))


@given(st.binary(max_size=600), st.lists(st.integers(0, 600), max_size=8))
def test_random_bytes_never_raise(noise: bytes, cuts: list[int]) -> None:
    out, dec = feed_all(chunked(noise, cuts))
    used = dec.discarded + dec.pending + sum(len(p.params) + 4 for p in out)
    assert used == len(noise)
    for packet in out:
        assert packet.encode() in noise
        # Typed parsing of whatever came out either works or says why.
        with contextlib.suppress(ProtocolError):
            parse_reply(packet) if packet.is_reply else parse_request(packet)


@given(st.binary(max_size=300))
def test_decode_one_contract_on_random_bytes(noise: bytes) -> None:
    used, packet = decode_one(noise)
    assert 0 <= used <= len(noise)
    if packet is not None:
        assert noise[:used] == packet.encode()
        assert used == candidate_size(noise, 0)
    elif used == 0 and noise:
        assert noise[0] == 0x55 and len(noise) < MAX_PACKET


@given(st.binary(max_size=40), messages, st.binary(max_size=40))
def test_packet_embedded_in_junk_is_recovered(
    before: bytes, message: XarmRequest | XarmReply, after: bytes
) -> None:
    raw = message.encode()
    stream = before + raw + after
    # Precondition: no plausible header in the junk reaches into our packet (it would take it).
    assume(all(pos + candidate_size(stream, pos) <= len(before) for pos in range(len(before))))
    out, _ = feed_all([stream])
    assert packet_of(raw) in out


@given(
    st.lists(st.one_of(messages.map(lambda m: m.encode()), st.binary(max_size=12)), max_size=6),
    st.data(),
)
def test_output_independent_of_chunking(parts: list[bytes], data: st.DataObject) -> None:
    # No look-ahead in this decoder: every decision depends only on bytes already seen, so any
    # chunking gives identical output, with no exceptions.
    stream = b"".join(parts)
    whole, whole_dec = feed_all([stream])
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=10))
    pieces, dec = feed_all(chunked(stream, cuts))
    assert pieces == whole
    assert (dec.discarded, dec.pending) == (whole_dec.discarded, whole_dec.pending)


@given(st.lists(messages, min_size=1, max_size=5))
def test_back_to_back_messages_byte_by_byte(ms: list[XarmRequest | XarmReply]) -> None:
    stream = b"".join(m.encode() for m in ms)
    out, dec = feed_all([stream[i : i + 1] for i in range(len(stream))])
    assert [p.encode() for p in out] == [m.encode() for m in ms]
    assert (dec.discarded, dec.pending) == (0, 0)
