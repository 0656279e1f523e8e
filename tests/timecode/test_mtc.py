"""MTC bytes -> positions: real quarter-frame and full-frame bytes, every rate, any chunking."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.timecode.mtc import RATES, MtcDecoder, full_frame, quarter_frames

RATE_CODES = st.integers(0, 3)
FRAMES = st.integers(0, 24 * 3600 * 24 - 100)  # frame counts within a day at 24 fps


def _time(frames: int, rate_code: int) -> float:
    return frames / RATES[rate_code]


@settings(max_examples=300, deadline=None)
@given(frames=FRAMES, rate_code=RATE_CODES)
def test_a_cycle_of_quarter_frames_gives_its_time_plus_seven_quarters(
    frames: int, rate_code: int
) -> None:
    t = _time(frames, rate_code)
    (pos,) = MtcDecoder().feed(quarter_frames(t, rate_code))
    assert pos.fps == RATES[rate_code] and not pos.full
    assert pos.seconds == pytest.approx(t + 7 / (4 * pos.fps), abs=1e-6)


@settings(max_examples=100, deadline=None)
@given(frames=FRAMES, rate_code=RATE_CODES, cuts=st.lists(st.integers(1, 31), max_size=8))
def test_then_every_quarter_frame_is_a_quarter_frame_later_however_the_bytes_arrive(
    frames: int, rate_code: int, cuts: list[int]
) -> None:
    fps = RATES[rate_code]
    t = _time(frames, rate_code)
    data = quarter_frames(t, rate_code) + quarter_frames(t + 2 / fps, rate_code)
    decoder = MtcDecoder()
    got = []
    start = 0
    for cut in sorted(set(cuts)):
        got += decoder.feed(data[start:cut])
        start = max(start, cut)
    got += decoder.feed(data[start:])
    assert len(got) == 9
    for i, pos in enumerate(got):
        assert pos.seconds == pytest.approx(t + (7 + i) / (4 * fps), abs=1e-6)


@settings(max_examples=200, deadline=None)
@given(frames=FRAMES, rate_code=RATE_CODES)
def test_a_full_frame_locates_exactly(frames: int, rate_code: int) -> None:
    t = _time(frames, rate_code)
    (pos,) = MtcDecoder().feed(full_frame(t, rate_code))
    assert pos.full and pos.seconds == pytest.approx(t, abs=1e-6)


def test_a_piece_out_of_order_drops_the_cycle() -> None:
    data = bytearray(quarter_frames(10.0))
    del data[6:8]  # piece 3 lost
    decoder = MtcDecoder()
    assert decoder.feed(bytes(data)) == []
    (pos,) = decoder.feed(quarter_frames(11.0))  # the next whole cycle locates again
    assert pos.seconds == pytest.approx(11.0 + 7 / 120)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=64))
def test_any_bytes_never_raise(data: bytes) -> None:
    for pos in MtcDecoder().feed(data):
        assert pos.seconds >= 0
