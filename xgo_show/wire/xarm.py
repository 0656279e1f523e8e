"""LewanSoul / Hiwonder xArm packet codec (9600-baud serial, and the payload of USB-HID reports).

Wire layout (both directions)::

    +------+------+--------+---------+----------------------------------+
    | 0x55 | 0x55 | length | command | parameters ...                   |
    +------+------+--------+---------+----------------------------------+
      header        params     see       0..253 bytes; every u16 field is
                    + 2        XarmCommand   little-endian (low byte first)

``length`` counts itself, the command byte and the parameters, so a packet is ``length + 2``
bytes: 4 bytes at least (GroupStop), 257 at most. Over USB-HID each packet rides alone in a
64-byte report (see :mod:`xgo_show.transports.hid`).

Commands (seed ``lewansoul-xarm-protocol.txt``); ``;`` separates request and reply::

     3 ServoMove           count, time_ms u16, {id, position u16 0..1000}
     5 GroupRunRepeat      group (255 = all), times
     6 GroupRun            group, count u16 (0 = continuously)
     7 GroupStop           -
     8 GroupErase          group (255 = all)
    11 GroupSpeed          group, percent u16
    15 GetBatteryVoltage   - ; millivolts u16
    20 ServoOff            count, {id}
    21 ServoPositionRead   count, {id} ; count, {id, position u16}
    22 ServoPositionWrite  count, {id, position u16}
    23 ServoOffsetRead     count, {id} ; count, {id, offset s8}
    24 ServoOffsetWrite    id, offset s8
    26 BusServoMoroCtrl    id, ?, speed u16                  (framed, not interpreted)
    27 BusServoInfoWrite   id, 5 x u16 limits, 2 x u8 led    (framed, not interpreted)
    28 BusServoInfoRead    - ; 19-byte servo info block       (framed, not interpreted)

Seed ambiguities and what this module chooses: the ServoOffsetRead section heading says "(28)"
but the command table says 23 and 28 is BusServoInfoRead: 23 is used. The offset range is given
as "-128 to 128", which a signed byte cannot hold: -128..127 is accepted. Commands 12..14 are
marked "not sure" in the seed and are not recognised. 26..28 reprogram or query *every*
attached servo; they are recognised so a simulator can name them, but have no builders.

Resynchronisation. The protocol has no checksum, so the only evidence that ``55 55`` starts a
real packet is its structure. :func:`decode_one` accepts a candidate only when its command is
one of :class:`XarmCommand` and its length fits that command's parameter shape: a fixed size
(GroupStop 0, ServoOffsetWrite 2, ...) or a count-prefixed list whose size is exactly what its
count byte (``>= 1``) says (ServoMove ``3 + 3n``, ServoOff ``1 + n``, ...). Requests and replies
sharing a command number have disjoint shapes, so both are accepted and
:attr:`XarmPacket.is_reply` tells them apart. These checks run as soon as the length, command
and count bytes are in, so a false header in line noise is given up after 4 or 5 bytes, one
byte at a time so that a real packet starting inside it is still found. A candidate that passes
is waited for (at most 257 bytes) and then delivered: there is no later test it could fail.

Unknown command numbers are treated as noise, not delivered. The arm only ever answers 15, 21,
23 (and 28); a host that accepted any ``55 55 len cmd`` after noise would lock onto false
packets and swallow real replies inside them. Anything else the firmware may send shows up in
:attr:`XarmDecoder.discarded`. Value ranges (position 0..1000, ids, ...) are *not* part of
framing: a well-formed packet with a bad value is delivered, and the typed parsers
(:func:`parse_request`, :func:`positions`, ...) raise :class:`ProtocolError` naming it, so a
simulator can tell a host exactly what it sent wrong. Because no checksum can reject a
plausible false packet, a host should :meth:`XarmDecoder.reset` its decoder (and drain the
port) before each request, as the vendor library flushes, and match the reply by command.

Vendor library note: ``xarm`` 0.0.4 (``Controller._recv``) reads the 4 header bytes and then
``length`` more bytes. ``length`` already counts the length and command bytes, so over serial
it asks for 2 bytes too many and each reply waits out the port's 1 s timeout (or takes the next
packet's first two bytes); over USB it slices 2 bytes of report padding. The values it returns
are still right. This codec follows the documented layout; replies need no padding for it.

The module is pure: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple, TypeAlias

from xgo_show.errors import ProtocolError
from xgo_show.wire.stream import StreamDecoder

__all__ = [
    "ALL_GROUPS",
    "HEADER",
    "MAX_PACKET",
    "MAX_PARAMS",
    "MIN_PACKET",
    "POSITION_MAX",
    "POSITION_MIN",
    "BatteryVoltage",
    "GetBatteryVoltage",
    "GroupErase",
    "GroupRun",
    "GroupRunRepeat",
    "GroupSpeed",
    "GroupStop",
    "ServoMove",
    "ServoOff",
    "ServoOffsetRead",
    "ServoOffsetWrite",
    "ServoOffsets",
    "ServoPositionRead",
    "ServoPositionWrite",
    "ServoPositions",
    "XarmCommand",
    "XarmDecoder",
    "XarmPacket",
    "XarmReply",
    "XarmRequest",
    "battery_mv",
    "battery_reply",
    "decode_one",
    "encode_packet",
    "get_battery_voltage",
    "group_erase",
    "group_run",
    "group_run_repeat",
    "group_speed",
    "group_stop",
    "offsets",
    "offsets_reply",
    "parse_reply",
    "parse_request",
    "positions",
    "positions_reply",
    "servo_move",
    "servo_off",
    "servo_offset_read",
    "servo_offset_write",
    "servo_position_read",
    "servo_position_write",
]

HEADER = b"\x55\x55"
#: Parameter bytes that fit the one-byte length field (``length = params + 2 <= 255``).
MAX_PARAMS = 253
#: Header, length and command: the bytes of a packet without parameters.
MIN_PACKET = 4
MAX_PACKET = MAX_PARAMS + MIN_PACKET
POSITION_MIN = 0
POSITION_MAX = 1000
#: The group number meaning "every group" for GroupRunRepeat and GroupErase.
ALL_GROUPS = 255


class XarmCommand(IntEnum):
    """Command numbers of the xArm controller board."""

    SERVO_MOVE = 3
    GROUP_RUN_REPEAT = 5
    GROUP_RUN = 6
    GROUP_STOP = 7
    GROUP_ERASE = 8
    GROUP_SPEED = 11
    GET_BATTERY_VOLTAGE = 15
    SERVO_OFF = 20
    SERVO_POSITION_READ = 21
    SERVO_POSITION_WRITE = 22
    SERVO_OFFSET_READ = 23
    SERVO_OFFSET_WRITE = 24
    BUS_SERVO_MORO_CTRL = 26
    BUS_SERVO_INFO_WRITE = 27
    BUS_SERVO_INFO_READ = 28

    @property
    def label(self) -> str:
        """The seed's CamelCase name, e.g. ``ServoMove``."""
        return "".join(word.capitalize() for word in self.name.split("_"))


class _Shape(NamedTuple):
    """Parameter size: ``base`` bytes when ``per == 0``, else ``base + per * count``."""

    base: int
    per: int = 0

    def fits(self, nparams: int, count: int | None) -> bool:
        if self.per == 0:
            return nparams == self.base
        return count is not None and count >= 1 and nparams == self.base + self.per * count

    def describe(self) -> str:
        return f"{self.base} bytes" if self.per == 0 else f"{self.base} + {self.per} x count bytes"


_C = XarmCommand
_REQUEST_SHAPES: dict[XarmCommand, _Shape] = {
    _C.SERVO_MOVE: _Shape(3, 3),
    _C.GROUP_RUN_REPEAT: _Shape(2),
    _C.GROUP_RUN: _Shape(3),
    _C.GROUP_STOP: _Shape(0),
    _C.GROUP_ERASE: _Shape(1),
    _C.GROUP_SPEED: _Shape(3),
    _C.GET_BATTERY_VOLTAGE: _Shape(0),
    _C.SERVO_OFF: _Shape(1, 1),
    _C.SERVO_POSITION_READ: _Shape(1, 1),
    _C.SERVO_POSITION_WRITE: _Shape(1, 3),
    _C.SERVO_OFFSET_READ: _Shape(1, 1),
    _C.SERVO_OFFSET_WRITE: _Shape(2),
    _C.BUS_SERVO_MORO_CTRL: _Shape(4),
    _C.BUS_SERVO_INFO_WRITE: _Shape(12),
    _C.BUS_SERVO_INFO_READ: _Shape(0),
}
# Shapes are disjoint from the request shape of the same command (count >= 1), so a packet is
# classified as request or reply by its size alone.
_REPLY_SHAPES: dict[XarmCommand, _Shape] = {
    _C.GET_BATTERY_VOLTAGE: _Shape(2),
    _C.SERVO_POSITION_READ: _Shape(1, 3),
    _C.SERVO_OFFSET_READ: _Shape(1, 2),
    _C.BUS_SERVO_INFO_READ: _Shape(19),
}
_SHAPES: dict[int, tuple[_Shape, ...]] = {
    int(cmd): (shape, *((_REPLY_SHAPES[cmd],) if cmd in _REPLY_SHAPES else ()))
    for cmd, shape in _REQUEST_SHAPES.items()
}


def _count_of(params: bytes | bytearray) -> int | None:
    return params[0] if params else None


@dataclass(frozen=True)
class XarmPacket:
    """One packet: command and raw parameter bytes (a request or, for 15/21/23/28, a reply)."""

    command: XarmCommand
    params: bytes = b""

    def __post_init__(self) -> None:
        object.__setattr__(self, "command", _command(self.command))
        object.__setattr__(self, "params", bytes(self.params))

    @property
    def is_reply(self) -> bool:
        """Whether the parameters have this command's reply shape (replies come from the arm)."""
        shape = _REPLY_SHAPES.get(self.command)
        return shape is not None and shape.fits(len(self.params), _count_of(self.params))

    def encode(self) -> bytes:
        return encode_packet(self.command, self.params)


def _command(command: int) -> XarmCommand:
    try:
        return XarmCommand(command)
    except ValueError:
        raise ProtocolError(f"xArm command {command} is not a known command number") from None


def encode_packet(command: int, params: bytes = b"") -> bytes:
    """Encode one packet; raise :class:`ProtocolError` unless the decoder would accept it."""
    cmd = _command(command)
    shapes = _SHAPES[cmd]
    if len(params) > MAX_PARAMS or not any(s.fits(len(params), _count_of(params)) for s in shapes):
        wanted = " or ".join(s.describe() for s in shapes)
        raise ProtocolError(
            f"xArm {cmd.label} parameters are {len(params)} bytes; expected {wanted}"
            + (" with count >= 1" if any(s.per for s in shapes) else "")
        )
    return HEADER + bytes((len(params) + 2, cmd)) + bytes(params)


# --- Decoding -------------------------------------------------------------------------------------


def decode_one(buf: bytes | bytearray) -> tuple[int, XarmPacket | None]:
    """Decode at the start of ``buf``.

    Returns ``(bytes_used, packet)``:

    - ``(0, None)``: ``buf`` starts a plausible packet but more bytes are needed;
    - ``(n, None)`` with ``n > 0``: the first ``n`` bytes are junk and were skipped;
    - ``(n, packet)``: a complete packet of ``n`` bytes.

    A bad header, unknown command or length that does not fit the command skips one byte only,
    so that a real packet starting inside a false one is still found.
    """
    n = len(buf)
    if n == 0:
        return 0, None
    if buf[0] != 0x55:
        nxt = buf.find(b"\x55", 1)
        return (n if nxt < 0 else nxt), None
    if n < MIN_PACKET:
        # Judge what is there now: "55 xx" or a length < 2 is junk whatever follows.
        if (n >= 2 and buf[1] != 0x55) or (n >= 3 and buf[2] < 2):
            return 1, None
        return 0, None
    if buf[1] != 0x55:
        return 1, None
    length, command = buf[2], buf[3]
    shapes = _SHAPES.get(command)
    if shapes is None or length < 2:
        return 1, None
    nparams = length - 2
    if not any(s.per == 0 and s.fits(nparams, None) for s in shapes):
        if not any(s.per for s in shapes) or nparams == 0:
            return 1, None
        if n < 5:
            return 0, None  # the count byte decides
        if not any(s.fits(nparams, buf[4]) for s in shapes):
            return 1, None
    if n < length + 2:
        return 0, None
    return length + 2, XarmPacket(XarmCommand(command), bytes(buf[4 : length + 2]))


class XarmDecoder(StreamDecoder[XarmPacket]):
    """Streaming decoder: ``feed()`` any chunks, get complete packets out; never raises.

    ``discarded`` counts bytes thrown away as junk (line noise, torn or corrupt packets).
    """

    def __init__(self) -> None:
        super().__init__(decode_one)

    @property
    def packets(self) -> int:
        """Packets decoded so far."""
        return self.decoded


# --- Value checks ---------------------------------------------------------------------------------


def _int_in(what: str, value: int, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ProtocolError(f"xArm {what} must be an integer, not {value!r}")
    if not low <= value <= high:
        raise ProtocolError(f"xArm {what} {value} must be {low}..{high}")
    return value


def _servo_id(value: int) -> int:
    # The board numbers its servos from 1; the arm's profile narrows this to its own servo ids.
    return _int_in("servo id", value, 1, 255)


def _ids(what: str, ids: Iterable[int], limit: int) -> tuple[int, ...]:
    out = tuple(ids)
    if not 1 <= len(out) <= limit:
        raise ProtocolError(f"xArm {what} takes 1..{limit} servo ids; got {len(out)}")
    seen: set[int] = set()
    for servo in out:
        _servo_id(servo)
        if servo in seen:
            raise ProtocolError(f"xArm {what} lists servo {servo} twice")
        seen.add(servo)
    return out


class _Check:
    def __init__(self, what: str, low: int, high: int) -> None:
        self.what, self.low, self.high = what, low, high

    def __call__(self, servo: int, value: int) -> None:
        _int_in(f"servo {servo} {self.what}", value, self.low, self.high)


def _servo_map(what: str, values: Mapping[int, int], limit: int, check: _Check) -> dict[int, int]:
    out = dict(values)
    _ids(what, out, limit)
    for servo, value in out.items():
        check(servo, value)
    return out


_POSITION = _Check("position", POSITION_MIN, POSITION_MAX)
_OFFSET = _Check("offset", -128, 127)
_U16_VALUE = _Check("position", 0, 0xFFFF)
_MAX_MOVE = (MAX_PARAMS - 3) // 3
_MAX_IDS = MAX_PARAMS - 1
_MAX_TRIPLES = (MAX_PARAMS - 1) // 3
_MAX_PAIRS = (MAX_PARAMS - 1) // 2


def _u16(value: int) -> bytes:
    return value.to_bytes(2, "little")


def _read_u16(params: bytes, at: int) -> int:
    return int.from_bytes(params[at : at + 2], "little")


def _triples(params: bytes, start: int, what: str) -> dict[int, int]:
    out: dict[int, int] = {}
    for at in range(start, len(params), 3):
        servo = params[at]
        if servo in out:
            raise ProtocolError(f"xArm {what} lists servo {servo} twice")
        out[servo] = _read_u16(params, at + 1)
    return out


# --- Requests -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ServoMove:
    """Move servos to ``positions`` (id -> 0..1000) in ``time_ms`` milliseconds."""

    time_ms: int
    positions: Mapping[int, int]

    def __post_init__(self) -> None:
        _int_in("ServoMove time (ms)", self.time_ms, 0, 0xFFFF)
        object.__setattr__(
            self, "positions", _servo_map("ServoMove", self.positions, _MAX_MOVE, _POSITION)
        )

    def encode(self) -> bytes:
        body = b"".join(bytes((s,)) + _u16(p) for s, p in self.positions.items())
        params = bytes((len(self.positions),)) + _u16(self.time_ms) + body
        return encode_packet(XarmCommand.SERVO_MOVE, params)


@dataclass(frozen=True)
class GroupRunRepeat:
    """Run action group ``group`` (255 = all) ``times`` times."""

    group: int
    times: int

    def __post_init__(self) -> None:
        _int_in("action group", self.group, 0, 255)
        _int_in("GroupRunRepeat times", self.times, 0, 255)

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GROUP_RUN_REPEAT, bytes((self.group, self.times)))


@dataclass(frozen=True)
class GroupRun:
    """Run action group ``group`` ``count`` times (0 = continuously)."""

    group: int
    count: int = 1

    def __post_init__(self) -> None:
        _int_in("action group", self.group, 0, 255)
        _int_in("GroupRun count", self.count, 0, 0xFFFF)

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GROUP_RUN, bytes((self.group,)) + _u16(self.count))


@dataclass(frozen=True)
class GroupStop:
    """Stop the running action group (the xArm's safe stop)."""

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GROUP_STOP)


@dataclass(frozen=True)
class GroupErase:
    """Erase action group ``group`` (255 = all)."""

    group: int

    def __post_init__(self) -> None:
        _int_in("action group", self.group, 0, 255)

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GROUP_ERASE, bytes((self.group,)))


@dataclass(frozen=True)
class GroupSpeed:
    """Set the playback speed of action group ``group`` in percent."""

    group: int
    percent: int

    def __post_init__(self) -> None:
        _int_in("action group", self.group, 0, 255)
        _int_in("GroupSpeed percent", self.percent, 0, 0xFFFF)

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GROUP_SPEED, bytes((self.group,)) + _u16(self.percent))


@dataclass(frozen=True)
class GetBatteryVoltage:
    """Ask for the battery voltage (reply: :class:`BatteryVoltage`)."""

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GET_BATTERY_VOLTAGE)


@dataclass(frozen=True)
class ServoOff:
    """Unpower servos ``ids`` (any later move powers them again)."""

    ids: tuple[int, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "ids", _ids("ServoOff", self.ids, _MAX_IDS))

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.SERVO_OFF, bytes((len(self.ids), *self.ids)))


@dataclass(frozen=True)
class ServoPositionRead:
    """Ask for the positions of servos ``ids`` (reply: :class:`ServoPositions`)."""

    ids: tuple[int, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "ids", _ids("ServoPositionRead", self.ids, _MAX_IDS))

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.SERVO_POSITION_READ, bytes((len(self.ids), *self.ids)))


@dataclass(frozen=True)
class ServoPositionWrite:
    """Set servo positions (id -> 0..1000) without a move time."""

    positions: Mapping[int, int]

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "positions",
            _servo_map("ServoPositionWrite", self.positions, _MAX_TRIPLES, _POSITION),
        )

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.SERVO_POSITION_WRITE, _triple_params(self.positions))


@dataclass(frozen=True)
class ServoOffsetRead:
    """Ask for the offsets of servos ``ids`` (reply: :class:`ServoOffsets`)."""

    ids: tuple[int, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "ids", _ids("ServoOffsetRead", self.ids, _MAX_IDS))

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.SERVO_OFFSET_READ, bytes((len(self.ids), *self.ids)))


@dataclass(frozen=True)
class ServoOffsetWrite:
    """Set servo ``servo_id``'s offset (signed byte)."""

    servo_id: int
    offset: int

    def __post_init__(self) -> None:
        _servo_id(self.servo_id)
        _OFFSET(self.servo_id, self.offset)

    def encode(self) -> bytes:
        return encode_packet(
            XarmCommand.SERVO_OFFSET_WRITE, bytes((self.servo_id, self.offset & 0xFF))
        )


XarmRequest: TypeAlias = (
    ServoMove
    | GroupRunRepeat
    | GroupRun
    | GroupStop
    | GroupErase
    | GroupSpeed
    | GetBatteryVoltage
    | ServoOff
    | ServoPositionRead
    | ServoPositionWrite
    | ServoOffsetRead
    | ServoOffsetWrite
)


def _triple_params(values: Mapping[int, int]) -> bytes:
    body = b"".join(bytes((s,)) + _u16(v) for s, v in values.items())
    return bytes((len(values),)) + body


def _check_shape(packet: XarmPacket, *, reply: bool) -> bytes:
    shapes = _REPLY_SHAPES if reply else _REQUEST_SHAPES
    kind = "reply" if reply else "request"
    shape = shapes.get(packet.command)
    if shape is None:
        raise ProtocolError(f"xArm {packet.command.label} has no {kind}")
    params = packet.params
    if not shape.fits(len(params), _count_of(params)):
        raise ProtocolError(
            f"xArm {packet.command.label} {kind} parameters are {len(params)} bytes; "
            f"expected {shape.describe()}"
        )
    return params


def parse_request(packet: XarmPacket) -> XarmRequest:
    """The typed request a packet carries (what a simulated arm does with it).

    Raises :class:`ProtocolError` for a reply, a malformed packet, a value out of range, or a
    bus-servo command (26..28), which is recognised but not interpreted.
    """
    cmd = packet.command
    if cmd in (_C.BUS_SERVO_MORO_CTRL, _C.BUS_SERVO_INFO_WRITE, _C.BUS_SERVO_INFO_READ):
        raise ProtocolError(f"xArm {cmd.label} ({int(cmd)}) is recognised but not supported")
    p = _check_shape(packet, reply=False)
    if cmd is _C.SERVO_MOVE:
        return ServoMove(_read_u16(p, 1), _triples(p, 3, "ServoMove"))
    if cmd is _C.GROUP_RUN_REPEAT:
        return GroupRunRepeat(p[0], p[1])
    if cmd is _C.GROUP_RUN:
        return GroupRun(p[0], _read_u16(p, 1))
    if cmd is _C.GROUP_STOP:
        return GroupStop()
    if cmd is _C.GROUP_ERASE:
        return GroupErase(p[0])
    if cmd is _C.GROUP_SPEED:
        return GroupSpeed(p[0], _read_u16(p, 1))
    if cmd is _C.GET_BATTERY_VOLTAGE:
        return GetBatteryVoltage()
    if cmd is _C.SERVO_OFF:
        return ServoOff(tuple(p[1:]))
    if cmd is _C.SERVO_POSITION_READ:
        return ServoPositionRead(tuple(p[1:]))
    if cmd is _C.SERVO_POSITION_WRITE:
        return ServoPositionWrite(_triples(p, 1, "ServoPositionWrite"))
    if cmd is _C.SERVO_OFFSET_READ:
        return ServoOffsetRead(tuple(p[1:]))
    # Only ServoOffsetWrite is left.
    return ServoOffsetWrite(p[0], int.from_bytes(p[1:2], "little", signed=True))


# --- Replies --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BatteryVoltage:
    """Reply to GetBatteryVoltage: battery voltage in millivolts."""

    millivolts: int

    def __post_init__(self) -> None:
        _int_in("battery voltage (mV)", self.millivolts, 0, 0xFFFF)

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.GET_BATTERY_VOLTAGE, _u16(self.millivolts))


@dataclass(frozen=True)
class ServoPositions:
    """Reply to ServoPositionRead: id -> position."""

    positions: Mapping[int, int]

    def __post_init__(self) -> None:
        # Replies are checked against the byte range, not 0..1000: a servo pushed past its
        # travel reports what it reports, and the host should see it rather than an error.
        object.__setattr__(
            self,
            "positions",
            _servo_map("ServoPositionRead reply", self.positions, _MAX_TRIPLES, _U16_VALUE),
        )

    def encode(self) -> bytes:
        return encode_packet(XarmCommand.SERVO_POSITION_READ, _triple_params(self.positions))


@dataclass(frozen=True)
class ServoOffsets:
    """Reply to ServoOffsetRead: id -> offset (signed byte)."""

    offsets: Mapping[int, int]

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "offsets",
            _servo_map("ServoOffsetRead reply", self.offsets, _MAX_PAIRS, _OFFSET),
        )

    def encode(self) -> bytes:
        body = b"".join(bytes((s, o & 0xFF)) for s, o in self.offsets.items())
        return encode_packet(XarmCommand.SERVO_OFFSET_READ, bytes((len(self.offsets),)) + body)


XarmReply: TypeAlias = BatteryVoltage | ServoPositions | ServoOffsets


def parse_reply(packet: XarmPacket) -> XarmReply:
    """The typed reply a packet carries; :class:`ProtocolError` if it is not a valid reply."""
    cmd = packet.command
    if cmd is _C.BUS_SERVO_INFO_READ:
        raise ProtocolError(f"xArm {cmd.label} ({int(cmd)}) is recognised but not supported")
    p = _check_shape(packet, reply=True)
    if cmd is _C.GET_BATTERY_VOLTAGE:
        return BatteryVoltage(_read_u16(p, 0))
    if cmd is _C.SERVO_POSITION_READ:
        return ServoPositions(_triples(p, 1, "ServoPositionRead reply"))
    # Only ServoOffsetRead is left.
    pairs: dict[int, int] = {}
    for at in range(1, len(p), 2):
        if p[at] in pairs:
            raise ProtocolError(f"xArm ServoOffsetRead reply lists servo {p[at]} twice")
        pairs[p[at]] = int.from_bytes(p[at + 1 : at + 2], "little", signed=True)
    return ServoOffsets(pairs)


def battery_mv(packet: XarmPacket) -> int:
    """Battery voltage in millivolts from a GetBatteryVoltage reply."""
    reply = parse_reply(packet)
    if not isinstance(reply, BatteryVoltage):
        raise ProtocolError(f"expected a GetBatteryVoltage reply, got {packet.command.label}")
    return reply.millivolts


def positions(packet: XarmPacket) -> dict[int, int]:
    """Servo id -> position from a ServoPositionRead reply, in the order the arm sent them."""
    reply = parse_reply(packet)
    if not isinstance(reply, ServoPositions):
        raise ProtocolError(f"expected a ServoPositionRead reply, got {packet.command.label}")
    return dict(reply.positions)


def offsets(packet: XarmPacket) -> dict[int, int]:
    """Servo id -> offset (signed) from a ServoOffsetRead reply."""
    reply = parse_reply(packet)
    if not isinstance(reply, ServoOffsets):
        raise ProtocolError(f"expected a ServoOffsetRead reply, got {packet.command.label}")
    return dict(reply.offsets)


# --- Builders (bytes, like wire.xgo's) ------------------------------------------------------------


def servo_move(time_ms: int, positions: Mapping[int, int]) -> bytes:
    """ServoMove: move servos (id -> position 0..1000) in ``time_ms`` ms (0..65535)."""
    return ServoMove(time_ms, positions).encode()


def group_run_repeat(group: int, times: int) -> bytes:
    """GroupRunRepeat: run action group ``group`` (255 = all) ``times`` times."""
    return GroupRunRepeat(group, times).encode()


def group_run(group: int, count: int = 1) -> bytes:
    """GroupRun: run action group ``group`` ``count`` times (0 = continuously)."""
    return GroupRun(group, count).encode()


def group_stop() -> bytes:
    """GroupStop: stop the running action group (``55 55 02 07``)."""
    return GroupStop().encode()


def group_erase(group: int) -> bytes:
    """GroupErase: erase action group ``group`` (255 = all)."""
    return GroupErase(group).encode()


def group_speed(group: int, percent: int) -> bytes:
    """GroupSpeed: set action group ``group``'s speed in percent."""
    return GroupSpeed(group, percent).encode()


def get_battery_voltage() -> bytes:
    """GetBatteryVoltage request (``55 55 02 0F``)."""
    return GetBatteryVoltage().encode()


def servo_off(ids: Iterable[int]) -> bytes:
    """ServoOff: unpower the servos ``ids``."""
    return ServoOff(tuple(ids)).encode()


def servo_position_read(ids: Iterable[int]) -> bytes:
    """ServoPositionRead request for servos ``ids``."""
    return ServoPositionRead(tuple(ids)).encode()


def servo_position_write(positions: Mapping[int, int]) -> bytes:
    """ServoPositionWrite: set positions (id -> 0..1000) with no move time."""
    return ServoPositionWrite(positions).encode()


def servo_offset_read(ids: Iterable[int]) -> bytes:
    """ServoOffsetRead request for servos ``ids``."""
    return ServoOffsetRead(tuple(ids)).encode()


def servo_offset_write(servo_id: int, offset: int) -> bytes:
    """ServoOffsetWrite: set one servo's offset (-128..127)."""
    return ServoOffsetWrite(servo_id, offset).encode()


def battery_reply(millivolts: int) -> bytes:
    """The arm's reply to GetBatteryVoltage (for simulators)."""
    return BatteryVoltage(millivolts).encode()


def positions_reply(positions: Mapping[int, int]) -> bytes:
    """The arm's reply to ServoPositionRead: id -> position (for simulators)."""
    return ServoPositions(positions).encode()


def offsets_reply(offsets: Mapping[int, int]) -> bytes:
    """The arm's reply to ServoOffsetRead: id -> offset (for simulators)."""
    return ServoOffsets(offsets).encode()
