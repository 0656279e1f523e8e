"""The sampling loop's byte tables agree with Register.to_byte everywhere."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from xgo_show.choreo.resolved import FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show, describe_frame
from xgo_show.compiler.bytetable import ByteTable, _bisect_threshold, _step_to_threshold
from xgo_show.compiler.state import format_fields
from xgo_show.errors import ValueRangeError
from xgo_show.profiles import Encoding, get_profile

# One register per distinct mapping (range and zero handling): the table depends on nothing else.
_DISTINCT: dict[tuple[object, ...], tuple[str, object]] = {}
for _model in ("mini", "lite", "rider"):
    for _reg in get_profile(_model).registers:
        if _reg.limits is not None:
            _DISTINCT.setdefault((_reg.minimum, _reg.maximum, _reg.zero_at_neutral),
                                 (_model, _reg))
TRAJECTORY_REGISTERS = list(_DISTINCT.values())


_TABLES: dict[tuple[str, str], ByteTable] = {}


def _table(model: str, reg) -> ByteTable:  # type: ignore[no-untyped-def]
    key = (model, reg.name)
    if key not in _TABLES:
        _TABLES[key] = ByteTable(reg)
    return _TABLES[key]


@pytest.mark.parametrize(("model", "reg"), TRAJECTORY_REGISTERS,
                         ids=[f"{m}-{r.name}" for m, r in TRAJECTORY_REGISTERS])
def test_table_matches_to_byte_at_every_threshold(model: str, reg) -> None:  # type: ignore[no-untyped-def]
    table = _table(model, reg)
    for x in table.thresholds:
        assert table(x) == reg.to_byte(x)
        below = math.nextafter(x, -math.inf)
        assert table(below) == reg.to_byte(below)
    assert table(reg.minimum) == reg.to_byte(reg.minimum)
    assert table(reg.maximum) == reg.to_byte(reg.maximum)
    with pytest.raises(ValueRangeError):
        table(reg.maximum + 1.0)


def test_thresholds_are_those_a_bisection_finds() -> None:
    # Built by stepping from a guess; the bisection over the whole range is the reference (and
    # the fallback when the guess is far: here, a guess at the minimum).
    for model in ("mini", "lite", "rider"):
        for reg in get_profile(model).registers:
            if reg.encoding is not Encoding.U8 or not reg.linear or reg.size != 1:
                continue
            lo, hi = float(reg.minimum), float(reg.maximum)
            table = ByteTable(reg)
            bytes_ = range(table.base + 1, reg.to_byte(hi) + 1)
            assert table.thresholds == [_bisect_threshold(reg, b, lo, hi) for b in bytes_]
            middle = (table.base + reg.to_byte(hi)) // 2
            assert _step_to_threshold(reg, middle, lo, lo, hi) is None


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(TRAJECTORY_REGISTERS), st.floats(0.0, 1.0))
def test_table_matches_to_byte_anywhere(entry, fraction: float) -> None:  # type: ignore[no-untyped-def]
    model, reg = entry
    x = reg.minimum + (reg.maximum - reg.minimum) * fraction
    assert _table(model, reg)(x) == reg.to_byte(x)


def test_labels_say_what_the_bytes_say(make_show, o) -> None:  # type: ignore[no-untyped-def]
    schedule = compile_show(make_show({
        "rex": ("mini", [
            SetCue(0.0, o("s"), {"gait": "high_walk", "vx": -3.0, "mark_time": 20.0}),
            MotionCue(0.1, o("m"), {"body_z": 80.0, "yaw": -10.0, "leg2_x": 12.0}),
        ]),
        "wheels": ("rider", [FadeCue(0.0, o("f"), "led4", (9, 99, 199), 0.5)]),
    }))
    for perf in schedule.performers:
        profile = get_profile(perf.model)
        for frame in perf.frames:
            assert frame.label == format_fields(profile, describe_frame(profile, frame.data))
