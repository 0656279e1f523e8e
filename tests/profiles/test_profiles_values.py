"""Register values both ways: what ``encode_value`` accepts, and ``decode_value`` as its inverse.

Every register of every shipped profile is checked, so a profile added later is covered too.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.choreo import check_file
from xgo_show.errors import ValueRangeError
from xgo_show.profiles import MODELS, Access, Encoding, Register, get_profile

REGISTERS = [(model, reg) for model in MODELS for reg in get_profile(model).registers]
ENUMS = [(m, r) for m, r in REGISTERS if r.encoding is Encoding.ENUM]
LINEAR = [(m, r) for m, r in REGISTERS
          if r.encoding in (Encoding.U8, Encoding.U8_PERIODIC) and r.linear]


def test_an_enum_register_takes_exactly_its_named_codes() -> None:
    # Every byte value: the named codes encode to themselves, every other byte is refused
    # (a firmware would act on an unnamed code in ways no document describes).
    assert ENUMS
    for _, reg in ENUMS:
        accepted = set()
        for byte in range(256):
            try:
                raw = reg.encode_value(byte)
            except ValueRangeError as err:
                assert str(err).startswith(f"{reg.name}: {byte} is not one of")
            else:
                assert raw == bytes((byte,))
                accepted.add(byte)
        assert accepted == set(reg.choices.values())
        for label, code in reg.choices.items():
            assert reg.encode_value(label) == bytes((code,))
            assert reg.decode_value(bytes((code,))) == label
        with pytest.raises(ValueRangeError, match="unknown value 'nope'"):
            reg.encode_value("nope")


def test_set_gait_to_an_unnamed_code_is_refused_where_it_was_written(tmp_path: Path) -> None:
    show = tmp_path / "show.yaml"
    text = ("show: T\ntempo: {bpm: 120}\nperformers:\n  rex: {model: mini}\ntracks:\n"
            "  rex:\n    - {at: 0, set: {gait: %s}}\n")
    show.write_text(text % "7", encoding="utf-8")
    _, diags = check_file(show)
    (err,) = [d for d in diags if d.is_error]
    assert err.path == "tracks.rex[0].set.gait" and "gait: 7 is not one of" in err.message
    assert err.origin is not None and err.origin.line == 7
    show.write_text(text % "2", encoding="utf-8")  # high_walk by its code: accepted
    assert [d for d in check_file(show)[1] if d.is_error] == []


def test_every_byte_of_a_linear_register_decodes_and_encodes_back() -> None:
    assert LINEAR
    for _, reg in LINEAR:
        assert reg.minimum is not None and reg.maximum is not None
        for byte in range(256):
            value = reg.decode_value(bytes((byte,)))
            assert isinstance(value, float)
            assert reg.minimum - 1e-9 <= value <= reg.maximum + 1e-9 or value == 0.0
            assert reg.encode_value(value) == bytes((byte,)), (reg.name, byte, value)
        # Bytes rise with the value (a wrong sign on one side of zero would fold the range).
        first = 1 if reg.encoding is Encoding.U8_PERIODIC else 0
        values = [reg.decode_value(bytes((b,))) for b in range(first, 256)]
        assert values == sorted(values) and len(set(values)) == len(values)


def test_the_ends_and_zero_of_a_linear_register() -> None:
    for _, reg in LINEAR:
        lo, hi = reg.minimum, reg.maximum
        assert lo is not None and hi is not None
        first = 1 if reg.encoding is Encoding.U8_PERIODIC else 0
        assert reg.encode_value(lo) == bytes((first,)) and reg.encode_value(hi) == b"\xff"
        if reg.encoding is Encoding.U8_PERIODIC:
            assert reg.encode_value(0) == b"\x00" and reg.decode_value(b"\x00") == 0.0
        elif lo < 0 < hi and reg.zero_at_neutral:
            assert reg.encode_value(0.0) == b"\x80" and reg.decode_value(b"\x80") == 0.0
        span = hi - lo
        for outside in (lo - span / 100, hi + span / 100, math.nan):
            with pytest.raises(ValueRangeError, match=reg.name):
                reg.encode_value(outside)


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(LINEAR), st.floats(0.0, 1.0))
def test_a_linear_value_comes_back_within_half_a_step(pair: tuple[str, Register],
                                                      where: float) -> None:
    _, reg = pair
    lo, hi = reg.minimum, reg.maximum
    assert lo is not None and hi is not None
    value = lo + where * (hi - lo)
    if reg.encoding is Encoding.U8_PERIODIC and value == 0:
        return  # 0 means "off", not a rate
    back = reg.decode_value(reg.encode_value(value))
    assert isinstance(back, float)
    # The widest step: 254 steps over the range (periodic), or 127 over the positive half.
    if reg.encoding is Encoding.U8_PERIODIC:
        step = (hi - lo) / 254
    elif lo < 0 < hi and reg.zero_at_neutral:
        step = max(hi / 0x7F, -lo / 0x80)
    else:
        step = (hi - lo) / 0xFF
    assert abs(back - value) <= step / 2 + 1e-9


def _float32_values() -> st.SearchStrategy[float]:
    return st.floats(width=32, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_decode_inverts_encode_for_every_encoding(data: st.DataObject) -> None:
    _, reg = data.draw(st.sampled_from(REGISTERS))
    enc = reg.encoding
    if enc in (Encoding.U8, Encoding.U8_PERIODIC) and not reg.linear:
        value: object = data.draw(st.integers(0, 255))
        expect: object = value
    elif enc in (Encoding.U8, Encoding.U8_PERIODIC):
        return  # linear registers: the tests above, byte by byte
    elif enc is Encoding.ENUM:
        label = data.draw(st.sampled_from(sorted(reg.choices)))
        value, expect = data.draw(st.sampled_from([label, reg.choices[label]])), label
    elif enc is Encoding.FLOAT32:
        value = expect = data.draw(_float32_values())
    elif enc is Encoding.INT16:
        value = expect = data.draw(st.integers(-0x8000, 0x7FFF))
    elif enc is Encoding.RGB:
        value = expect = data.draw(st.tuples(*[st.integers(0, 255)] * 3))
    elif enc is Encoding.ASCII:
        value = expect = data.draw(st.text(st.characters(min_codepoint=1, max_codepoint=127),
                                           max_size=reg.size))
    else:
        value = expect = data.draw(st.binary(min_size=reg.size, max_size=reg.size))
    raw = reg.encode_value(value)
    assert len(raw) == reg.size
    assert reg.decode_value(raw) == expect
    assert reg.encode_value(reg.decode_value(raw)) == raw


def test_decode_refuses_bytes_of_the_wrong_size() -> None:
    for _, reg in REGISTERS:
        for size in (reg.size - 1, reg.size + 1):
            with pytest.raises(ValueRangeError, match=f"{reg.size} bytes, not {size}"):
                reg.decode_value(bytes(size))


def test_fixed_layouts_of_the_wide_encodings() -> None:
    # The byte orders the firmware uses: float32 little-endian, int16 big-endian, RGB in order,
    # ASCII NUL padded (text after the first NUL is not part of the value).
    f32 = Register(0x62, "f", Access.READ_WRITE, encoding=Encoding.FLOAT32, size=4)
    i16 = Register(0x66, "i", Access.READ_WRITE, encoding=Encoding.INT16, size=2)
    rgb = Register(0x69, "c", Access.READ_WRITE, encoding=Encoding.RGB, size=3)
    txt = Register(0x07, "t", Access.READ_WRITE, encoding=Encoding.ASCII, size=6)
    assert f32.encode_value(1.5) == struct.pack("<f", 1.5)
    assert f32.decode_value(struct.pack("<f", -2.25)) == -2.25
    assert i16.encode_value(-2) == b"\xff\xfe" and i16.decode_value(b"\x01\x00") == 256
    assert rgb.decode_value(b"\x01\x02\x03") == (1, 2, 3)
    assert txt.encode_value("ab") == b"ab\0\0\0\0"
    assert txt.decode_value(b"ab\0cd\0") == "ab"
    with pytest.raises(ValueRangeError, match="at most 6"):
        txt.encode_value("abcdefg")
    with pytest.raises(ValueRangeError, match="three bytes"):
        rgb.encode_value((1, 2, 256))
