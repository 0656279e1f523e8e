"""XGO serial frame codec (Mini, Lite, Rider).

Wire layout (all frames, both directions)::

    +------+------+--------+------+---------+-----------+----------+------+------+
    | 0x55 | 0x00 | length | type | address | data ...  | checksum | 0x00 | 0xAA |
    +------+------+--------+------+---------+-----------+----------+------+------+
      header       whole      |      first     0..247     ~(sum of    tail
                   frame      |      register  bytes      length..data) & 0xFF
                   bytes      +-- 0x00 write (Mini/Lite), 0x01 write (Rider library),
                                  0x02 read (data = count), 0x12 reply

``length`` counts every byte of the frame, header and tail included, so the smallest frame
(no data) is 8 bytes and the largest is 255 bytes (247 data bytes).

The module is pure: no I/O, no clock. :class:`XgoDecoder` is a streaming decoder that takes
arbitrary chunks, yields complete frames, skips junk and never raises on line noise.
"""

from __future__ import annotations

from dataclasses import dataclass

from xgo_show.errors import ProtocolError
from xgo_show.wire.stream import StreamDecoder

__all__ = [
    "HEADER",
    "MAX_DATA",
    "MIN_LENGTH",
    "TAIL",
    "TYPE_READ",
    "TYPE_REPLY",
    "TYPE_WRITE",
    "TYPE_WRITE_RIDER",
    "XgoDecoder",
    "XgoFrame",
    "checksum",
    "decode_one",
    "encode_frame",
    "is_one_frame",
    "read_frame",
    "reply_frame",
    "write_frame",
]

HEADER = b"\x55\x00"
TAIL = b"\x00\xaa"
TYPE_WRITE = 0x00
TYPE_WRITE_RIDER = 0x01
TYPE_READ = 0x02
TYPE_REPLY = 0x12
MIN_LENGTH = 8
MAX_LENGTH = 255
MAX_DATA = MAX_LENGTH - MIN_LENGTH


@dataclass(frozen=True)
class XgoFrame:
    """One decoded frame: its type byte, first register address and data bytes."""

    type: int
    address: int
    data: bytes

    @property
    def is_write(self) -> bool:
        return self.type in (TYPE_WRITE, TYPE_WRITE_RIDER)

    @property
    def is_read(self) -> bool:
        return self.type == TYPE_READ

    @property
    def is_reply(self) -> bool:
        return self.type == TYPE_REPLY

    def encode(self) -> bytes:
        return encode_frame(self.type, self.address, self.data)


def checksum(length: int, type_: int, address: int, data: bytes) -> int:
    """Sum of length, type, address and data bytes; low byte, inverted."""
    return (~(length + type_ + address + sum(data))) & 0xFF


def encode_frame(type_: int, address: int, data: bytes = b"") -> bytes:
    """Encode one frame. Raises :class:`ProtocolError` for values that do not fit a byte."""
    if not 0 <= type_ <= 0xFF or not 0 <= address <= 0xFF:
        raise ProtocolError(f"frame type 0x{type_:X} / address 0x{address:X} must be bytes")
    if len(data) > MAX_DATA:
        raise ProtocolError(f"frame data is {len(data)} bytes; at most {MAX_DATA} fit a frame")
    length = MIN_LENGTH + len(data)
    return b"".join(
        (
            HEADER,
            bytes((length, type_, address)),
            bytes(data),
            bytes((checksum(length, type_, address, data),)),
            TAIL,
        )
    )


def write_frame(address: int, data: bytes, *, write_type: int = TYPE_WRITE) -> bytes:
    """A write frame setting consecutive registers from ``address`` (no reply is sent)."""
    if not data:
        raise ProtocolError("a write frame needs at least one data byte")
    return encode_frame(write_type, address, data)


def read_frame(address: int, count: int) -> bytes:
    """A read request for ``count`` consecutive bytes from ``address``."""
    if not 1 <= count <= MAX_DATA:
        raise ProtocolError(f"read count {count} must be 1..{MAX_DATA}")
    return encode_frame(TYPE_READ, address, bytes((count,)))


def reply_frame(address: int, data: bytes) -> bytes:
    """A reply frame, as the robot sends it in answer to a read."""
    return encode_frame(TYPE_REPLY, address, data)


def decode_one(buf: bytes | bytearray) -> tuple[int, XgoFrame | None]:
    """Decode at the start of ``buf``.

    Returns ``(bytes_used, frame)``:

    - ``(0, None)``: ``buf`` starts a plausible frame but more bytes are needed;
    - ``(n, None)`` with ``n > 0``: the first ``n`` bytes are junk and were skipped;
    - ``(n, frame)``: a complete, valid frame of ``n`` bytes.

    A bad header, impossible length, bad checksum or bad tail skips one byte only, so that a
    real frame starting inside a false one is still found.

    Look-ahead trade-off: while the frame at the start is incomplete, a complete valid frame
    later in ``buf`` proves it false and it is skipped at once (a noise header claiming 255
    bytes would otherwise hold real frames back). The price: a frame whose *data* holds a whole
    valid frame, arriving slowly, yields that inner frame instead; fed whole, it decodes
    normally. Frames the compiler sends never carry frame-shaped data in practice.
    """
    n = len(buf)
    if n == 0:
        return 0, None
    if buf[0] != 0x55:
        # Skip straight to the next candidate header byte.
        nxt = buf.find(b"\x55", 1)
        return (n if nxt < 0 else nxt), None
    if n < 2:
        return 0, None
    if buf[1] != 0x00:
        return 1, None
    if n < 3:
        return 0, None
    length = buf[2]
    if length < MIN_LENGTH:
        return 1, None
    if n < length:
        # A false header with a large length would otherwise hold back real frames behind it
        # until enough junk arrives. If a complete valid frame already starts later in the
        # buffer, this header cannot be real: skip it now.
        return (1 if _valid_frame_after(buf) else 0), None
    type_, address = buf[3], buf[4]
    data = bytes(buf[5 : length - 3])
    if buf[length - 3] != checksum(length, type_, address, data):
        return 1, None
    if buf[length - 2] != 0x00 or buf[length - 1] != 0xAA:
        return 1, None
    return length, XgoFrame(type_, address, data)


def is_one_frame(buf: bytes) -> bool:
    """Whether ``buf`` is exactly one valid frame: what ``decode_one(buf)`` returning
    ``(len(buf), frame)`` says, at a fraction of its cost (a schedule file holds 100k's)."""
    n = len(buf)
    return (
        n >= MIN_LENGTH and buf[0] == 0x55 and buf[1] == 0x00 and buf[2] == n
        and buf[n - 2] == 0x00 and buf[n - 1] == 0xAA
        and buf[n - 3] == (~sum(buf[2 : n - 3])) & 0xFF
    )


def _valid_frame_after(buf: bytes | bytearray) -> bool:
    pos = buf.find(HEADER, 1)
    while pos >= 0:
        if _complete_frame_at(buf, pos):
            return True
        pos = buf.find(HEADER, pos + 1)
    return False


def _complete_frame_at(buf: bytes | bytearray, pos: int) -> bool:
    if len(buf) - pos < MIN_LENGTH:
        return False
    length = buf[pos + 2]
    end = pos + length
    if length < MIN_LENGTH or end > len(buf):
        return False
    data = bytes(buf[pos + 5 : end - 3])
    return (
        buf[end - 3] == checksum(length, buf[pos + 3], buf[pos + 4], data)
        and buf[end - 2] == 0x00
        and buf[end - 1] == 0xAA
    )


class XgoDecoder(StreamDecoder[XgoFrame]):
    """Streaming decoder: ``feed()`` any chunks, get complete frames out; never raises.

    ``discarded`` counts bytes thrown away as junk (line noise, torn or corrupt frames).
    """

    def __init__(self) -> None:
        super().__init__(decode_one)

    @property
    def frames(self) -> int:
        """Frames decoded so far."""
        return self.decoded
