"""The streaming decoder's byte accounting: every byte fed is a frame's, junk, or pending."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.wire.xgo import XgoDecoder, encode_frame, write_frame

FRAME = write_frame(0x30, b"\x80\x81")


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["frame", "junk", "torn", "reset"]),
                          st.binary(max_size=12)), max_size=30))
def test_every_byte_is_counted_once_across_feeds_and_resets(
    steps: list[tuple[str, bytes]],
) -> None:
    dec = XgoDecoder()
    fed = frames = 0
    for kind, junk in steps:
        if kind == "reset":
            dec.reset()  # a partial frame's bytes become discarded ones
            assert dec.pending == 0
            continue
        chunk = {"frame": FRAME, "junk": junk, "torn": FRAME[: len(junk) % len(FRAME)]}[kind]
        out = dec.feed(chunk)
        fed += len(chunk)
        frames += len(out)
        assert all(f.address == 0x30 and f.data == b"\x80\x81" for f in out)
        assert dec.decoded == frames
        assert dec.discarded + dec.pending + frames * len(FRAME) == fed


def test_reset_counts_a_torn_frame_as_discarded_every_time() -> None:
    dec = XgoDecoder()
    for n in range(1, 4):
        assert dec.feed(FRAME[:5]) == [] and dec.pending == 5
        dec.reset()
        assert (dec.discarded, dec.pending) == (5 * n, 0)
    assert [f.data for f in dec.feed(encode_frame(0x02, 0x31, b"\x01"))] == [b"\x01"]
