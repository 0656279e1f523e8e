"""sources.py: a source's sample as bytes, each register's span in it, its Writes, any tick entry
as Writes, which registers changed since the last sample (byte by byte, whole, by span), and
the change codes of a stretch of samples.
"""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from tests.compiler.conftest import origin
from xgo_show.compiler.frames import Write
from xgo_show.compiler.sources import Samples, Source, change_codes, changes, entry_writes
from xgo_show.profiles import get_profile

MINI = get_profile("mini")
RIDER = get_profile("rider")
ROLL, PITCH, YAW = (MINI.register(n) for n in ("roll", "pitch", "yaw"))
LED1, LED2 = RIDER.register("led1"), RIDER.register("led2")


def test_a_moves_source_spans_one_byte_a_register() -> None:
    src = Source((ROLL, PITCH, YAW), origin("m"), 3)
    assert src.addresses == (0x36, 0x37, 0x38) and src.address_set == {0x36, 0x37, 0x38}
    assert src.spans == ((0, 1), (1, 2), (2, 3))
    assert src.unit and not src.one
    assert (src.origin, src.order, src.prev) == (origin("m"), 3, None)


def test_a_fade_source_is_one_register_of_three_bytes() -> None:
    src = Source((LED1,), origin("f"), 1)
    assert src.spans == ((0, 3),) and src.one and not src.unit


def test_two_leds_span_three_bytes_each() -> None:
    src = Source((LED1, LED2), None, 0)
    assert src.spans == ((0, 3), (3, 6)) and not src.one and not src.unit


def test_a_sample_as_writes_one_per_register() -> None:
    src = Source((LED1, LED2), origin("f"), 2)
    assert src.writes(b"\x01\x02\x03\x04\x05\x06") == [
        Write(LED1.address, b"\x01\x02\x03", origin("f"), 2, True),
        Write(LED2.address, b"\x04\x05\x06", origin("f"), 2, True),
    ]


def test_any_entry_as_writes() -> None:
    move = Source((ROLL, PITCH), origin("m"), 0)
    fade = Source((LED1,), origin("f"), 1)
    assert entry_writes((move, b"\x10\x20")) == move.writes(b"\x10\x20")
    assert entry_writes(Samples([(move, b"\x10\x20"), (fade, b"\x01\x02\x03")])) == [
        *move.writes(b"\x10\x20"), *fade.writes(b"\x01\x02\x03")]
    writes = [Write(0x09, b"\x01", origin("s"), 4, False)]
    assert entry_writes(writes) is writes


def test_changes_name_the_registers_that_differ_from_the_last_sample() -> None:
    move = Source((ROLL, PITCH, YAW), None, 0)
    assert changes(move, b"\x01\x02\x03", b"\x01\x09\x03") == (False, True, False)
    assert changes(move, b"\x01\x02\x03", b"\x01\x02\x03") == (False, False, False)
    fade = Source((LED1,), None, 0)
    assert changes(fade, b"\x01\x02\x03", b"\x01\x02\x04") == (True,)
    assert changes(fade, b"\x01\x02\x03", b"\x01\x02\x03") == (False,)
    leds = Source((LED1, LED2), None, 0)
    assert changes(leds, b"\x01\x02\x03\x04\x05\x06", b"\x01\x02\x03\x04\x05\x07") == (
        False, True)
    assert changes(leds, b"\x01\x02\x03\x04\x05\x06", b"\x00\x02\x03\x04\x05\x06") == (
        True, False)


def test_change_codes_mark_each_changed_byte_of_each_sample_with_0x80() -> None:
    assert change_codes([b"\x01\x02", b"\x01\x03", b"\x00\x03", b"\x00\x03", b"\xff\x7f"]) == [
        b"\x00\x80", b"\x80\x00", b"\x00\x00", b"\x80\x80"]
    # One bit, the top one or the lowest, is a change; a byte's change never spills into its
    # neighbours (0x7f + 0x7f carries no further than its own top bit).
    assert change_codes([b"\x00\x00\x00", b"\x00\x80\x00", b"\x00\x81\x00", b"\x7f\xff\x7f",
                         b"\x7e\xff\xff"]) == [
        b"\x00\x80\x00", b"\x00\x80\x00", b"\x80\x80\x80", b"\x80\x00\x80"]
    assert change_codes([b"\x05", b"\x05", b"\x06"]) == [b"\x00", b"\x80"]
    assert change_codes([b"\x05\x06", b"\x05\x07"]) == [b"\x00\x80"]


def test_no_code_without_a_sample_before() -> None:
    assert change_codes([]) == [] and change_codes([b"\x01\x02"]) == []


@given(st.sampled_from([(ROLL, PITCH, YAW), (LED1,), (LED1, LED2), (YAW,)]),
       st.lists(st.binary(min_size=6, max_size=6), min_size=1, max_size=12))
def test_change_codes_say_which_bytes_and_so_which_registers_changed(regs, raw) -> None:  # type: ignore[no-untyped-def]
    # Each of a stretch's samples against the one before, all at once: a code byte for each
    # byte that differs, so that equal codes give equal changes() (unit, one-register and
    # spanned sources alike).
    src = Source(regs, None, 0)
    size = src.spans[-1][1]
    samples = [r[:size] for r in raw]
    # Repeats, and samples differing in one register only, as well as random ones.
    samples += [samples[-1], samples[-1][:1] + bytes(size - 1)]
    codes = change_codes(samples)
    assert codes == [bytes(0x80 if x != y else 0 for x, y in zip(a, b, strict=True))
                     for a, b in zip(samples[1:], samples[:-1], strict=True)]
    for code, a, b in zip(codes, samples[1:], samples[:-1], strict=True):
        assert changes(src, a, b) == tuple(any(code[lo:hi]) for lo, hi in src.spans)
