"""XGO frames at their edges: the value bounds from both sides, the quick one-frame check
against the full decoder, what a decoder waits for, and frames whose data looks like frames."""

from __future__ import annotations

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from xgo_show.errors import ProtocolError
from xgo_show.wire.xgo import (
    HEADER,
    MAX_DATA,
    MIN_LENGTH,
    XgoDecoder,
    XgoFrame,
    decode_one,
    encode_frame,
    is_one_frame,
    read_frame,
    write_frame,
)

frames = st.builds(XgoFrame, st.integers(0, 255), st.integers(0, 255), st.binary(max_size=40))


def test_every_value_bound_holds_from_both_sides() -> None:
    assert len(encode_frame(0xFF, 0xFF)) == MIN_LENGTH  # no data: the shortest frame
    assert encode_frame(2, 0x10) == encode_frame(2, 0x10, b"")
    assert len(encode_frame(0, 0, bytes(MAX_DATA))) == 255
    assert decode_one(read_frame(0x50, 1))[1] == XgoFrame(2, 0x50, b"\x01")
    assert decode_one(read_frame(0x50, MAX_DATA))[1] == XgoFrame(2, 0x50, bytes((MAX_DATA,)))
    refused = [
        (lambda: encode_frame(0x100, 0), "frame type 0x100 / address 0x0 must be bytes"),
        (lambda: encode_frame(0, 0x100), "frame type 0x0 / address 0x100 must be bytes"),
        (lambda: encode_frame(-1, 0), "frame type 0x-1 / address 0x0 must be bytes"),
        (lambda: encode_frame(0, 0, bytes(MAX_DATA + 1)),
         f"frame data is {MAX_DATA + 1} bytes; at most {MAX_DATA} fit a frame"),
        (lambda: write_frame(0x30, b""), "a write frame needs at least one data byte"),
        (lambda: read_frame(0x50, 0), f"read count 0 must be 1..{MAX_DATA}"),
        (lambda: read_frame(0x50, MAX_DATA + 1),
         f"read count {MAX_DATA + 1} must be 1..{MAX_DATA}"),
    ]
    for call, message in refused:
        with pytest.raises(ProtocolError) as err:
            call()
        assert str(err.value) == message


@settings(max_examples=400, deadline=None)
@given(frames, st.integers(0, 300), st.integers(0, 255),
       st.sampled_from(["keep", "set", "cut", "extend", "relength"]))
def test_the_quick_check_agrees_with_the_decoder(
    frame: XgoFrame, index: int, value: int, how: str,
) -> None:
    # is_one_frame is a shortcut for "decode_one uses all of it and finds a frame": on valid
    # frames and on every kind of near miss (a byte changed, cut short, one byte too many).
    raw = bytearray(frame.encode())
    if how == "set":
        raw[index % len(raw)] = value
    elif how == "cut":
        raw = raw[: index % len(raw)]
    elif how == "extend":
        raw.append(value)
    elif how == "relength":
        raw[2] = value
    used, decoded = decode_one(bytes(raw))
    assert is_one_frame(bytes(raw)) == (decoded is not None and used == len(raw))


def test_the_decoder_waits_only_for_a_prefix_a_frame_could_start_with() -> None:
    # Any two bytes, and any length byte after a header: 0 ("need more") only where a valid
    # frame could follow; anything else is junk skipped at once (one byte, or up to the next
    # 0x55 when the first byte is not one).
    for a in range(256):
        assert decode_one(bytes((a,))) == ((0 if a == 0x55 else 1), None)
        for b in range(256):
            used, frame = decode_one(bytes((a, b)))
            expect = (0 if b == 0x00 else 1) if a == 0x55 else (1 if b == 0x55 else 2)
            assert (used, frame) == (expect, None), (a, b)
    for length in range(256):
        assert decode_one(HEADER + bytes((length,))) == (0 if length >= MIN_LENGTH else 1, None)
    assert decode_one(b"\x01\x02\x03") == (3, None)  # no header byte at all: all junk
    assert decode_one(b"\x01\x02\x55\x00") == (2, None)


def _near_frames() -> st.SearchStrategy[bytes]:
    # Data full of things that look like frames: headers, torn frames, frames with a bad tail.
    def spoil(f: XgoFrame, cut: int, tail: bool) -> bytes:
        raw = bytearray(f.encode())
        if tail:
            raw[-1] ^= 0x01
            return bytes(raw)
        return bytes(raw[: cut % len(raw)])

    piece = st.one_of(st.binary(max_size=6), st.just(HEADER),
                      st.builds(spoil, frames, st.integers(0, 60), st.booleans()))
    return st.lists(piece, max_size=5).map(b"".join)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 255), st.integers(0, 255), _near_frames(), st.integers(1, 7))
def test_a_frame_whose_data_looks_like_frames_still_decodes_whatever_the_chunks(
    type_: int, address: int, data: bytes, step: int,
) -> None:
    assume(len(data) <= MAX_DATA)
    raw = encode_frame(type_, address, data)
    # (A frame whose data holds a whole valid frame is the documented exception.)
    assume(not any(decode_one(raw[i:])[1] is not None for i in range(1, len(raw))))
    dec = XgoDecoder()
    out = []
    for i in range(0, len(raw), step):
        out += dec.feed(raw[i : i + step])
    assert out == [XgoFrame(type_, address, data)] and dec.discarded == 0


@settings(max_examples=200, deadline=None)
@given(st.integers(MIN_LENGTH + 20, 255), _near_frames(), frames, _near_frames())
def test_a_false_header_never_holds_back_a_real_frame_behind_it(
    claimed: int, junk: bytes, frame: XgoFrame, after: bytes,
) -> None:
    # Noise that reads as a header claiming more bytes than have come, then look-alikes, then
    # a real frame and the start of whatever comes next: the real frame comes out as soon as
    # it is complete, before the claimed length has arrived.
    raw = frame.encode()
    head = HEADER + bytes((claimed,)) + junk
    assume(len(head) + len(raw) + len(after) < claimed)
    dec = XgoDecoder()
    out = dec.feed(head)
    out += dec.feed(raw + after)
    assert frame in out
