"""Schedules from outside: check_schedule refuses what cannot be run, with one line each."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.choreo.music import Music
from xgo_show.choreo.resolved import ActionCue, MotionCue, SetCue
from xgo_show.choreo.sections import Section, Wait
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


# --- each range at its ends, and the messages --------------------------------------------------


def _one_problem(s: Schedule) -> str:
    problems = schedule_problems(s)
    assert len(problems) == 1, problems
    return problems[0]


def _link(s: Schedule, **changes: Any) -> Schedule:
    return _perf(s, link=dataclasses.replace(s.performers[0].link, **changes))


R = dataclasses.replace


@pytest.mark.parametrize(("change", "ok"), [
    (lambda s: R(s, control_rate=1.0), True),
    (lambda s: R(s, control_rate=1000.0), True),
    (lambda s: R(s, control_rate=0.999), False),
    (lambda s: R(s, control_rate=1000.001), False),
    (lambda s: R(s, bpm=1.0), True),
    (lambda s: R(s, bpm=1000.0), True),
    (lambda s: R(s, bpm=0.99), False),
    (lambda s: R(s, bpm=1000.5), False),
    (lambda s: R(s, bpm=None), True),
    (lambda s: R(s, beats_per_bar=1), True),
    (lambda s: R(s, beats_per_bar=64), True),
    (lambda s: R(s, beats_per_bar=65), False),
    (lambda s: R(s, battery_floor=0), True),
    (lambda s: R(s, battery_floor=100), True),
    (lambda s: R(s, battery_floor=-1), False),
    (lambda s: R(s, on_failure="continue"), True),
    (lambda s: R(s, tempo_map=((1, 120.0, 4), (60_000, 90.0, 64))), True),
    (lambda s: R(s, tempo_map=((0, 120.0, 4),)), False),
    (lambda s: R(s, tempo_map=((1, 120.0, 4), (60_001, 90.0, 4))), False),
    (lambda s: R(s, tempo_map=((1, 1000.0, 1),)), True),
    (lambda s: R(s, tempo_map=((1, 1000.1, 4),)), False),
    (lambda s: R(s, tempo_map=((1, 120.0, 0),)), False),
    (lambda s: R(s, tempo_map=((1, 120.0, 65),)), False),
    (lambda s: _link(s, baud=1), True),
    (lambda s: _link(s, baud=10_000_000), True),
    (lambda s: _link(s, baud=10_000_001), False),
    (lambda s: _link(s, bits_per_byte=5), True),
    (lambda s: _link(s, bits_per_byte=16), True),
    (lambda s: _link(s, bits_per_byte=4), False),
    (lambda s: _link(s, bits_per_byte=17), False),
    (lambda s: _link(s, gap=0.0), True),
    (lambda s: _link(s, gap=1.0), True),
    (lambda s: _link(s, gap=-0.001), False),
    (lambda s: _perf(s, end=3600.0), True),
    (lambda s: _perf(s, end=3600.5), False),
    (lambda s: _perf(s, name="_rex-2"), True),
    (lambda s: _perf(s, name="Rex"), True),
    (lambda s: _perf(s, name="2rex"), False),
    (lambda s: _perf(s, name="-rex"), False),
    (lambda s: _perf(s, name="rex.1"), False),
    (lambda s: _perf(s, name="Xena"), True),
    (lambda s: _frame(s, 0, data=bytes(1)), True),
    (lambda s: _perf(s, port="sim:mini"), True),
    (lambda s: R(s, performers=tuple(R(s.performers[0], name=f"r{i}") for i in range(64))),
     True),
    (lambda s: _frame(s, 0, duration=3600.0), True),
    (lambda s: _frame(s, 0, duration=3600.5), False),
    (lambda s: _frame(s, 0, duration=-0.5), False),
    (lambda s: _frame(s, 0, data=bytes(1024)), True),
    (lambda s: _frame(s, 0, data=bytes(1025)), False),
    (lambda s: _frame(s, 0, origin=Origin("made-in-python", 0, 0)), True),
    (lambda s: _frame(s, 0, origin=Origin("a.yaml", 1, -1)), False),
    (lambda s: _frame(s, 0, origin=Origin("a.yaml", 1, 1, "bad\x07cue")), False),
])  # fmt: skip
def test_ranges_at_their_ends(schedule: Schedule, change: Callable[[Schedule], Schedule],
                              ok: bool) -> None:
    assert (schedule_problems(change(schedule)) == []) is ok


def test_frames_at_the_end_and_at_one_time_are_fine(schedule: Schedule) -> None:
    p = schedule.performers[0]
    last = p.frames[-1]
    assert schedule_problems(_frame(schedule, len(p.frames) - 1, t=p.end)) == []
    at_once = _frame(schedule, 1, t=p.frames[0].t)  # two frames at one time: in order
    assert schedule_problems(at_once) == []
    assert "time order" in _one_problem(_frame(schedule, 0, t=math.nan))
    assert last.t < p.end


def test_messages_name_the_field_and_the_value(schedule: Schedule) -> None:
    s = schedule
    assert _one_problem(R(s, bpm=0.5)) == "show.bpm: 0.5 is not a tempo (1 to 1000 bpm)"
    assert _one_problem(R(s, beats_per_bar=0)) == (
        "show.beats_per_bar: 0 is not a meter (1 to 64 beats per bar)")
    assert _one_problem(R(s, tempo_map=((1, 120.0, 4), (70_000, 90.0, 4)))) == (
        "show.tempo_map[1]: bar 70000 is outside 1..60,000")
    assert _one_problem(R(s, tempo_map=((1, -1.0, 4),))) == (
        "show.tempo_map[0]: bpm -1.0 is not a tempo (1 to 1000 bpm)")
    assert _one_problem(R(s, tempo_map=((1, 120.0, 99),))) == (
        "show.tempo_map[0]: 99 beats per bar is not a meter (1 to 64)")
    assert _one_problem(R(s, control_rate=0.5)) == "show.control_rate: 0.5 Hz is outside 1..1000"
    assert _one_problem(R(s, on_failure="boom")) == "show.on_failure: unknown policy 'boom'"
    assert _one_problem(R(s, battery_floor=101)) == (
        "show.battery_floor: 101 is not a percentage (0 to 100)")
    assert _one_problem(_perf(s, name="2x")) == (
        "performers[0].name: '2x' is not a performer name (letters, digits, '_' and '-', "
        "starting with a letter or '_')")
    assert _one_problem(_link(s, baud=0)) == "performers[0].link.baud: 0 is outside 1..10,000,000"
    assert _one_problem(_link(s, bits_per_byte=4)) == (
        "performers[0].link.bits_per_byte: 4 is outside 5..16")
    assert _one_problem(_link(s, gap=2.0)) == (
        "performers[0].link.gap_us: 2000000 us is outside 0..1 s")
    assert _one_problem(_perf(s, end=4000.0)) == (
        "performers[0].end_us: 4000.000000 s is outside 0..3600 s")
    assert _one_problem(_frame(s, 1, t=-1.0)) == (
        "performers[0].frames[1].t_us: frames must be in time order from 0 (at -1.000000 s)")
    assert _one_problem(_perf(s, end=0.25)) == (
        "performers[0].frames[1].t_us: the frame at 0.500000 s is after the performer's end "
        "(0.250000 s)")
    assert _one_problem(_frame(s, 0, duration=-1.0)) == (
        "performers[0].frames[0].duration_us: -1.000000 s is outside 0..3600 s")
    assert _one_problem(_frame(s, 0, data=b"")) == (
        "performers[0].frames[0].hex: 0 bytes (a frame is 1 to 1024 bytes)")
    assert _one_problem(_perf(s, port="a\x07")) == (
        "performers[0].port: holds the control character \\x07 (text must be printable)")
    two = R(s, performers=(s.performers[0], s.performers[0]))
    assert _one_problem(two) == (
        "performers[1].name: performer 'rex' again (first at performers[0]): one entry per "
        "performer")
    assert _one_problem(_frame(s, 0, origin=Origin("a.yaml", -1, 2))) == (
        "origins: a.yaml:-1:2 is not a place in a file (lines and columns count from 1)")


def test_a_bad_row_stops_the_tempo_map_checks(schedule: Schedule) -> None:
    # One problem for the first bad row: the rows after it, and the map as a whole, are not
    # judged on top of it.
    bad = R(schedule, tempo_map=((1, 120.0, 4), (0, -1.0, 99), (5, -2.0, 0)))
    assert schedule_problems(bad) == ["show.tempo_map[1]: bar 0 is outside 1..60,000"]
    bad_bpm = R(schedule, tempo_map=((1, -1.0, 99), (2, 120.0, 0)))
    assert len(schedule_problems(bad_bpm)) == 1


def test_a_performers_first_bad_frame_is_its_last_problem(schedule: Schedule) -> None:
    p = schedule.performers[0]
    frames = [ScheduledFrame(f.t, b"", f.origin, -1.0) for f in p.frames]
    problems = schedule_problems(_perf(schedule, frames=tuple(frames)))
    assert problems == ["performers[0].frames[0].duration_us: -1.000000 s is outside 0..3600 s"]
    late = _perf(schedule, end=math.nan)
    assert schedule_problems(late) == [
        "performers[0].end_us: nan s is outside 0..3600 s"]  # and no frame is judged


def test_sections_and_music_are_checked(schedule: Schedule) -> None:
    s = schedule
    waits = (Section("intro", 0.0), Section("drop", 2.0, Wait("go", 3600.0, "intro")),
             Section("outro", 3.0, Wait("go", 0.0)), Section("coda", 3.5, Wait("go", 0.5)))
    assert schedule_problems(R(s, sections=waits)) == []
    assert _one_problem(R(s, sections=(Section("intro", 3601.0),))) == (
        "show.sections[0].start_us: 3601.000000 s is outside 0..3600 s")
    assert _one_problem(R(s, sections=(Section("a", 0.0, Wait("go", -1.0)),))) == (
        "show.sections[0].wait.timeout_us: -1.000000 s is outside 0..3600 s")
    assert _one_problem(R(s, sections=(Section("a\x1b", 0.0),))).startswith(
        "show.sections[0].name: holds the control character \\x1b")
    assert _one_problem(R(s, sections=(Section("a", 0.0, Wait("g\x07")),))).startswith(
        "show.sections[0].wait.trigger: ")
    assert _one_problem(R(s, sections=(Section("a", 0.0, Wait("g", None, "b\x07")),))).startswith(
        "show.sections[0].wait.else: ")
    assert _one_problem(R(s, sections=(Section("a", 0.0, origin=Origin("s.yaml", -2, 1)),))) == (
        "origins: s.yaml:-2:1 is not a place in a file (lines and columns count from 1)")
    song = Music("song.flac", "/music/song.flac", 86_400.0)
    assert schedule_problems(R(s, music=song)) == []
    assert schedule_problems(R(s, music=R(song, offset=-3600.0))) == []
    assert _one_problem(R(s, music=R(song, offset=86_401.0))) == (
        "show.music.offset: 86401.0 s is outside -3600..86400 s")
    assert _one_problem(R(s, music=R(song, offset=-3601.0))).startswith("show.music.offset")
    assert _one_problem(R(s, music=R(song, file="a\x07"))).startswith("show.music.file: ")
    assert _one_problem(R(s, music=R(song, path="a\x07"))).startswith("show.music.path: ")


def test_warnings_and_origins_texts_are_checked(schedule: Schedule) -> None:
    s = schedule
    w = Diagnostic("warning", "fine", Origin("w.yaml", -1, 1), "cues[0]")
    assert _one_problem(R(s, warnings=(w,))).startswith("origins: w.yaml:-1:1")
    assert _one_problem(R(s, warnings=(Diagnostic("warning", "ok", path="a\x07"),))).startswith(
        "warnings[0].path: ")
    assert _one_problem(_frame(s, 0, origin=Origin("a.yaml", 1, 1, "c\x07"))).startswith(
        "origins.cue: ")


def test_the_show_texts_messages(schedule: Schedule) -> None:
    s = schedule
    assert _one_problem(R(s, name="a\x1bb")) == (
        "show.name: holds the control character \\x1b (text must be printable)")
    assert _one_problem(R(s, source="a\x07")) == (
        "show.source: holds the control character \\x07 (text must be printable)")
    assert _one_problem(R(s, performers=())) == "performers: the schedule has no performer"
    assert _one_problem(_frame(s, 0, origin=Origin("a\x07.yaml", 1, 1))) == (
        "origins.file: holds the control character \\x07 (text must be printable)")


def test_check_schedule_says_how_many_more_problems(schedule: Schedule) -> None:
    with pytest.raises(ScheduleError, match=r"^y: show\.control_rate: .* \(and 1 more\)$"):
        check_schedule(R(schedule, control_rate=0.0, on_failure="a"), name="y")
    with pytest.raises(ScheduleError, match=r"^x: show.on_failure: unknown policy 'a'$"):
        check_schedule(R(schedule, on_failure="a"), name="x")
    with pytest.raises(ScheduleError, match=r"^<schedule>: show\.control_rate: .* \(and 2 more\)$"):
        check_schedule(R(schedule, control_rate=0.0, on_failure="a", battery_floor=-1))
