"""Schedules from outside: check_schedule refuses what cannot be run, with one line each."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.choreo.resolved import ActionCue, MotionCue, SetCue
from xgo_show.compiler import compile_show
from xgo_show.compiler.schedule import Schedule, ScheduledFrame
from xgo_show.compiler.schedule_check import (
    MAX_PERFORMERS,
    check_schedule,
    schedule_problems,
)
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import ScheduleError


@pytest.fixture
def schedule(make_show, o) -> Schedule:  # type: ignore[no-untyped-def]
    show = make_show({"rex": ("mini", [
        SetCue(0.0, o("setup", 2), {"gait": "walk"}),
        MotionCue(0.5, o("crouch", 3), {"body_z": 90.0}, duration=1.0),
        ActionCue(2.0, o("dance", 5), 23, "dance", 6.0),
    ])}, bpm=120.0)
    return compile_show(show)


def _perf(s: Schedule, **changes: Any) -> Schedule:
    return dataclasses.replace(s, performers=(dataclasses.replace(s.performers[0], **changes),))


def _frame(s: Schedule, index: int, **changes: Any) -> Schedule:
    frames = list(s.performers[0].frames)
    f = frames[index]
    fields = {"t": f.t, "data": f.data, "origin": f.origin, "duration": f.duration, **changes}
    frames[index] = ScheduledFrame(fields["t"], fields["data"], fields["origin"],
                                   fields["duration"])
    return _perf(s, frames=tuple(frames))


def test_a_compiled_schedule_passes(schedule: Schedule) -> None:
    assert schedule_problems(schedule) == []


BAD: list[tuple[str, Callable[[Schedule], Schedule], str]] = [
    ("negative tempo", lambda s: dataclasses.replace(s, bpm=-120.0), "show.bpm"),
    ("zero tempo", lambda s: dataclasses.replace(s, bpm=0.0), "not a tempo"),
    ("NaN tempo", lambda s: dataclasses.replace(s, bpm=math.nan), "not a tempo"),
    ("zero beats per bar", lambda s: dataclasses.replace(s, beats_per_bar=0), "not a meter"),
    ("negative map tempo", lambda s: dataclasses.replace(s, tempo_map=((1, -5.0, 4),)), "bpm"),
    ("map not from bar 1", lambda s: dataclasses.replace(s, tempo_map=((3, 120.0, 4),)),
     "bar 1"),
    ("repeated map bar",
     lambda s: dataclasses.replace(s, tempo_map=((1, 120.0, 4), (1, 90.0, 4))), "increase"),
    ("map bar absurd", lambda s: dataclasses.replace(s, tempo_map=((1, 120.0, 4),
                                                                    (10**30, 90.0, 4))),
     "outside"),
    ("NaN rate", lambda s: dataclasses.replace(s, control_rate=math.nan), "control_rate"),
    ("infinite rate", lambda s: dataclasses.replace(s, control_rate=math.inf), "control_rate"),
    ("zero rate", lambda s: dataclasses.replace(s, control_rate=0.0), "control_rate"),
    ("negative rate", lambda s: dataclasses.replace(s, control_rate=-50.0), "control_rate"),
    ("unknown policy", lambda s: dataclasses.replace(s, on_failure="explode"), "on_failure"),
    ("battery floor", lambda s: dataclasses.replace(s, battery_floor=101), "percentage"),
    ("end before frames", lambda s: _perf(s, end=0.1), "after the performer's end"),
    ("NaN end", lambda s: _perf(s, end=math.nan), "end_us"),
    ("end past an hour", lambda s: _perf(s, end=1e9), "end_us"),
    ("duplicate performer",
     lambda s: dataclasses.replace(s, performers=s.performers * 2), "again"),
    ("no performer", lambda s: dataclasses.replace(s, performers=()), "no performer"),
    ("too many performers", lambda s: dataclasses.replace(s, performers=tuple(
        dataclasses.replace(s.performers[0], name=f"r{i}") for i in range(MAX_PERFORMERS + 1)
    )), f"at most {MAX_PERFORMERS}"),
    ("empty name", lambda s: _perf(s, name=""), "performer name"),
    ("escape in name", lambda s: _perf(s, name="\x1b[2Jrex"), "performer name"),
    ("escape in show name", lambda s: dataclasses.replace(s, name="\x1b]0;pwned\x07"), "\\x1b"),
    ("bidi override in source", lambda s: dataclasses.replace(s, source="a\u202eb"),
     "\\u202e"),
    ("escape in port", lambda s: _perf(s, port="sim:mini\x07"), "port"),
    ("zero baud", lambda s: _perf(s, link=dataclasses.replace(s.performers[0].link, baud=0)),
     "baud"),
    ("zero bits", lambda s: _perf(
        s, link=dataclasses.replace(s.performers[0].link, bits_per_byte=0)), "bits_per_byte"),
    ("gap of an hour", lambda s: _perf(
        s, link=dataclasses.replace(s.performers[0].link, gap=3600.0)), "gap_us"),
    ("frames out of order", lambda s: _frame(s, 1, t=-1.0), "time order"),
    ("empty frame", lambda s: _frame(s, 0, data=b""), "bytes"),
    ("NaN frame duration", lambda s: _frame(s, 0, duration=math.nan), "duration_us"),
    ("escape in origin", lambda s: _frame(s, 0, origin=Origin("\x1b[2J.yaml", 1, 1)),
     "origins.file"),
    ("negative origin line", lambda s: _frame(s, 0, origin=Origin("a.yaml", -3, 1)),
     "not a place"),
    ("escape in warning", lambda s: dataclasses.replace(
        s, warnings=(Diagnostic("warning", "hi\x1b[5m"),)), "warnings[0].message"),
]


@pytest.mark.parametrize(("what", "change", "expected"), BAD, ids=[b[0] for b in BAD])
def test_check_refuses(schedule: Schedule, what: str, change: Callable[[Schedule], Schedule],
                       expected: str) -> None:
    with pytest.raises(ScheduleError) as info:
        check_schedule(change(schedule), name="x.xshow.json")
    message = str(info.value)
    assert message.startswith("x.xshow.json: ") and expected in message
    assert "\n" not in message and "\x1b" not in message


@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # read only
@given(rate=st.floats(allow_nan=True, allow_infinity=True),
       bpm=st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True)),
       per_bar=st.integers(-10, 10**6), end=st.floats(allow_nan=True, allow_infinity=True))
def test_any_numbers_pass_or_raise_schedule_error(schedule: Schedule, rate: float,
                                                  bpm: float | None, per_bar: int,
                                                  end: float) -> None:
    changed = _perf(dataclasses.replace(schedule, control_rate=rate, bpm=bpm,
                                        beats_per_bar=per_bar), end=end)
    try:
        check_schedule(changed)
    except ScheduleError:
        return
    assert 0 < rate <= 1000 and 1 <= per_bar <= 64 and math.isfinite(end)
    assert bpm is None or 0 < bpm < math.inf
    changed.tempo()  # a schedule that passes has a usable tempo
