"""The compiled schedule's value types and the compiler's time grid (schedule.py, frames.py)."""

from __future__ import annotations

import pytest

from xgo_show.choreo.timebase import TempoMap
from xgo_show.compiler.frames import cue_label, first_tick, tick_us
from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame, to_us
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile

LINK = get_profile("mini").link


def test_to_us_rounds_to_the_nearest_microsecond_half_to_even() -> None:
    assert to_us(1.0) == 1_000_000
    assert to_us(0.0000014) == 1 and to_us(0.0000016) == 2
    assert to_us(-0.25) == -250_000
    # Halves go to the even neighbour, so equal inputs give equal outputs on every platform.
    assert (to_us(0.5e-6), to_us(1.5e-6), to_us(2.5e-6)) == (0, 2, 2)


def test_ticks_are_on_the_control_rate_grid_in_microseconds() -> None:
    assert [tick_us(k, 50.0) for k in range(4)] == [0, 20_000, 40_000, 60_000]
    assert tick_us(1, 3.0) == 333_333 and tick_us(2, 3.0) == 666_667  # rounded, not truncated
    assert tick_us(7, 0.5) == 14_000_000


def test_first_tick_is_at_or_after_the_time_within_float_noise() -> None:
    assert first_tick(0.0, 50.0) == 0
    assert first_tick(0.02, 50.0) == 1  # on a tick: that tick
    assert first_tick(0.0201, 50.0) == 2  # just after one: the next
    assert first_tick(0.0199, 50.0) == 1
    # 0.3 * 10 is 3.0000000000000004 in floats: still tick 3, not 4.
    assert first_tick(0.3, 10.0) == 3
    assert first_tick(0.3 + 1e-8, 10.0) == 4  # more than float noise late: the next tick
    assert first_tick(1e-9, 10.0) == 1


def test_cue_label_names_the_cue_else_its_line() -> None:
    assert cue_label(Origin("show.yaml", 12, 3, "intro")) == "cue 'intro'"
    assert cue_label(Origin("show.yaml", 12, 3)) == "the cue at line 12"


def _frame(t: float = 0.5, data: bytes = b"\x01\x02", **kw: object) -> ScheduledFrame:
    return ScheduledFrame(t, data, **kw)  # type: ignore[arg-type]


def test_a_frame_is_a_value_of_time_bytes_origin_and_duration() -> None:
    o = Origin("show.yaml", 4, 1, "hop")
    a = _frame(origin=o, duration=2.0, labels=lambda b: "one")
    b = _frame(origin=o, duration=2.0, labels=lambda b: "other")
    assert a == b and hash(a) == hash(b)  # the labels function is not part of the value
    assert len({a, b}) == 1
    for other in (_frame(t=0.6, origin=o, duration=2.0), _frame(data=b"\x01", origin=o,
                  duration=2.0), _frame(duration=2.0), _frame(origin=o)):  # fmt: skip
        assert a != other
    assert a != (0.5, b"\x01\x02", o, 2.0)  # not equal to anything but a frame
    assert a.__eq__("frame") is NotImplemented
    assert repr(_frame(origin=None, duration=1.5)) == (
        "ScheduledFrame(t=0.5, data=b'\\x01\\x02', origin=None, duration=1.5)"
    )


def test_distinct_frames_hash_apart() -> None:
    # Frames go into sets and dicts by the hundred thousand: a hash shared by every frame
    # would keep them correct but make each lookup walk all of them.
    frames = [ScheduledFrame(i / 50, bytes((i % 256,))) for i in range(200)]
    assert len({hash(f) for f in frames}) > 190


def test_a_frame_defaults_and_label() -> None:
    plain = ScheduledFrame(0.25, b"\xaa")
    assert (plain.origin, plain.duration, plain.labels) == (None, 0.0, None)
    assert plain.label == ""
    labelled = ScheduledFrame(0.25, b"\xaa", labels=lambda data: f"{len(data)} byte")
    assert labelled.label == "1 byte"


def _performer(name: str, end: float, *sizes: int) -> PerformerSchedule:
    frames = tuple(ScheduledFrame(0.1 * i, bytes(n)) for i, n in enumerate(sizes))
    return PerformerSchedule(name, "mini", LINK, frames, end)


def test_a_performers_total_bytes_count_every_frame() -> None:
    assert _performer("rex", 1.0, 11, 9, 12).total_bytes == 32
    assert _performer("rex", 1.0).total_bytes == 0


def test_a_schedules_duration_and_performers() -> None:
    rex, fido = _performer("rex", 3.5, 11), _performer("fido", 7.25, 9)
    schedule = Schedule("show", "show.yaml", (rex, fido), 50.0)
    assert schedule.duration == 7.25  # the last performer's end
    assert Schedule("show", "show.yaml", (fido, rex), 50.0).duration == 7.25
    assert Schedule("empty", "show.yaml", (), 50.0).duration == 0.0
    assert schedule.performer("fido") is fido and schedule.performer("rex") is rex
    with pytest.raises(KeyError, match="spot"):
        schedule.performer("spot")


def test_a_schedules_tempo_map() -> None:
    rex = (_performer("rex", 1.0),)
    assert Schedule("show", "s.yaml", rex, 50.0).tempo() is None
    assert Schedule("show", "s.yaml", rex, 50.0, bpm=0.0).tempo() is None
    constant = Schedule("show", "s.yaml", rex, 50.0, bpm=120.0, beats_per_bar=3).tempo()
    assert isinstance(constant, TempoMap)
    assert constant.position(2) == pytest.approx(1.5)  # bar 2 after 3 beats of 0.5 s
    changing = Schedule("show", "s.yaml", rex, 50.0, bpm=120.0,
                        tempo_map=((1, 120.0, 4), (3, 60.0, 2))).tempo()  # fmt: skip
    assert changing is not None
    assert changing.position(3) == pytest.approx(4.0)  # 8 beats of 0.5 s
    assert changing.position(4) == pytest.approx(6.0)  # then 2 beats of 1 s
