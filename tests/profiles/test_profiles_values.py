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
from xgo_show.profiles import MODELS, Access, Encoding, Link, Register, get_profile

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
    assert reg.decode_value(raw) == expect and type(reg.decode_value(raw)) is type(expect)
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
    assert rgb.encode_value((0, 128, 255)) == b"\x00\x80\xff"  # both ends are colours
    for bad in ((1, 2, 256), (-1, 0, 0), (0, 0), (0, 0, 0, 0), (0.5, 0, 0)):
        with pytest.raises(ValueRangeError, match=r"^c takes three bytes r, g, b in 0\.\.255$"):
            rgb.encode_value(bad)


def test_decoded_values_have_the_documented_types() -> None:
    # 5 and 5.0 compare equal, so the types are checked on their own: a raw byte stays an int,
    # a physical value is a float, neutral decodes to 0.0 (never printed as "-0").
    for _, reg in REGISTERS:
        value = reg.decode_value(reg.encode_value(_some_value(reg)))
        expected = {Encoding.FLOAT32: float, Encoding.INT16: int, Encoding.RGB: tuple,
                    Encoding.ASCII: str, Encoding.BLOCK: bytes, Encoding.ENUM: str}.get(
            reg.encoding, float if reg.linear else int)
        assert type(value) is expected, (reg.name, value)
    for _, reg in LINEAR:
        if reg.encoding is Encoding.U8 and reg.zero_at_neutral and reg.minimum < 0:  # type: ignore[operator]
            assert str(reg.decode_value(b"\x80")) == "0.0", reg.name
    plain = Register(0x10, "raw", Access.READ_WRITE)
    assert type(plain.to_physical(7)) is float and plain.to_physical(7) == 7.0


def _some_value(reg: Register) -> object:
    return {Encoding.ENUM: next(iter(reg.choices), 0), Encoding.FLOAT32: 1.5,
            Encoding.INT16: -3, Encoding.RGB: (1, 2, 3), Encoding.ASCII: "ab",
            Encoding.BLOCK: bytes(reg.size)}.get(reg.encoding, reg.maximum or 7)


def test_an_unnamed_enum_code_read_back_decodes_to_its_number() -> None:
    gait = get_profile("mini").register("gait")
    assert gait.decode_value(b"\x07") == 7 and type(gait.decode_value(b"\x07")) is int


def test_ascii_decoding_replaces_bytes_that_are_not_ascii() -> None:
    txt = Register(0x07, "firmware", Access.READ, encoding=Encoding.ASCII, size=6)
    # b"\xc3\xa9" is UTF-8 for "é": the firmware string is ASCII, so it is two unknowns.
    assert txt.decode_value(b"M\xc3\xa9\0\0\0") == "M\ufffd\ufffd"
    assert txt.decode_value(b"\xffabc\0\0") == "\ufffdabc"


def test_a_range_ending_at_zero_maps_linearly() -> None:
    # Only a range with zero strictly inside is piecewise through 0x80.
    low = Register(0x10, "low", Access.WRITE, minimum=-10.0, maximum=0.0)
    assert [low.to_byte(v) for v in (-10.0, -5.0, 0.0)] == [0, 128, 255]
    assert [low.to_physical(b) for b in (0, 255)] == [-10.0, 0.0]
    assert low.to_physical(0x80) == pytest.approx(-10.0 + 0x80 / 0xFF * 10.0)


def test_the_range_check_tolerates_float_noise_only() -> None:
    reg = Register(0x10, "tilt", Access.WRITE, unit="deg", minimum=-20.0, maximum=20.0)
    reg.check(-20.0 - 1e-9)
    reg.check(20.0 + 1e-9)
    for outside in (-20.0 - 1e-8, 20.0 + 1e-8):
        with pytest.raises(ValueRangeError, match=r"^tilt = .* deg is out of range \[-20, 20\] "
                                                  r"deg$"):
            reg.check(outside)
    bare = Register(0x11, "level", Access.WRITE, minimum=0.0, maximum=1.0)
    with pytest.raises(ValueRangeError) as err:
        bare.check(2.0)
    assert str(err.value) == "level = 2 is out of range [0, 1]"


def test_errors_name_the_register_and_what_it_takes() -> None:
    raw = Register(0x10, "raw", Access.WRITE)
    pace = get_profile("mini").register("pace")
    block = Register(0x65, "imu_block", Access.READ, encoding=Encoding.BLOCK, size=4)
    cases = [
        (lambda: raw.encode_value(1.5), "raw takes a whole byte value, not 1.5"),
        (lambda: raw.encode_value(256), "raw = 256 is not a byte (0..255)"),
        (lambda: pace.encode_value("warp"),
         "pace: unknown value 'warp'; one of normal, slow, fast"),
        (lambda: pace.encode_value(True), "pace takes one of normal, slow, fast, not True"),
        (lambda: block.encode_value(b"\x00"), "imu_block is a 4-byte block"),
    ]
    for call, message in cases:
        with pytest.raises(ValueRangeError) as err:
            call()
        assert str(err.value) == message


def test_profile_lookups_list_what_is_valid() -> None:
    from xgo_show.errors import ProfileError

    mini = get_profile("mini")
    with pytest.raises(ProfileError) as err:
        mini.register("nope")
    valid = sorted(r.name for r in mini.registers if not r.unsafe)
    assert str(err.value) == f"mini has no register 'nope'; valid: {', '.join(valid)}"
    assert "servo_zero" not in str(err.value)  # unsafe registers are not offered
    with pytest.raises(ProfileError) as err:
        mini.action("nope")
    first = mini.actions[0]
    assert str(err.value).startswith(f"mini has no action 'nope'; valid: {first.id} {first.name}, ")
    known = {r.address for r in mini.registers}
    hole = next(a for a in range(0x100) if a not in known)
    with pytest.raises(ProfileError, match=f"^mini has no register at 0x{hole:02X}$"):
        mini.walk(hole, 1)
    wide = next(r for r in mini.registers if r.size > 1)
    with pytest.raises(ProfileError) as err:
        mini.walk(wide.address, wide.size - 1)
    assert str(err.value) == (f"{wide.name} at 0x{wide.address:02X} is {wide.size} bytes; "
                              f"only {wide.size - 1} remain")


def test_imu_block_size_is_checked_with_its_sizes_named() -> None:
    imu = get_profile("mini").imu
    assert imu is not None
    with pytest.raises(ValueRangeError) as err:
        imu.unpack(bytes(imu.size - 1))
    assert str(err.value) == f"IMU block is {imu.size} bytes, not {imu.size - 1}"


def test_wire_time_is_ten_bits_a_byte_at_the_baud_rate() -> None:
    for model in MODELS:
        link = get_profile(model).link
        assert link.wire_time(9) == pytest.approx(9 * 10 / link.baud)
    assert Link(115200, 0.001).wire_time(0) == 0.0
