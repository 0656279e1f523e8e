"""A compiled performer's frames kept as columns (schedule.Frames) until read."""

from __future__ import annotations

import dataclasses

import pytest

from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.compiler import compile_show
from xgo_show.compiler.artifact import schedule_from_bytes, schedule_to_bytes
from xgo_show.compiler.report import totals
from xgo_show.compiler.schedule import (
    FrameColumns,
    Frames,
    PerformerSchedule,
    ScheduledFrame,
    frame_columns,
    ready_frames,
)
from xgo_show.compiler.state import link_use
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile


@pytest.fixture
def compiled(make_show, o):  # type: ignore[no-untyped-def]
    return compile_show(make_show({
        "rex": ("mini", [
            SetCue(0.0, o("setup", 2), {"gait": "walk"}),
            MotionCue(0.5, o("crouch", 3), {"body_z": 90.0, "pitch": 10.0}, duration=1.0),
            ActionCue(2.0, o("dance", 5), 23, "dance", 6.0),
        ]),
        "wheels": ("rider", [FadeCue(0.0, o("glow", 7), "led1", (255, 40, 0), 0.5),
                             MotionCue(0.0, o("lean", 8), {"roll": 5.0}, duration=0.6)]),
        "arm": ("xarm", [ArmCue(1.0, o("reach", 9), {1: 500, 2: 300}, 1.5)]),
    }))


def _as_tuples(schedule):  # type: ignore[no-untyped-def]
    """The same schedule with every performer's frames made into a tuple of frames."""
    return dataclasses.replace(schedule, performers=tuple(
        dataclasses.replace(p, frames=tuple(p.frames)) for p in schedule.performers))


def test_compiled_frames_are_columns_made_into_frames_when_read(compiled) -> None:  # type: ignore[no-untyped-def]
    for p in compiled.performers:
        frames = p.frames
        assert isinstance(frames, Frames)
        starts, data, origins, durations, labels = frames.columns
        assert len(frames) == len(data) > 0
        made = frames.frames()
        assert frames.frames() is made  # made once
        assert made == tuple(
            ScheduledFrame(s / 1_000_000, d, o, u, labels)
            for s, d, o, u in zip(starts, data, origins, durations, strict=True))
        assert frames[0] is made[0] and frames[-1] is made[-1] and frames[1:] == made[1:]
        assert list(frames) == list(made)
        assert frames == made and made == frames and hash(frames) == hash(made)
        assert frames[0].label  # labels derived from the bytes as ever
    dance = [f for f in compiled.performer("rex").frames if f.duration]
    assert [f.duration for f in dance] == [6.0]


def test_columns_and_frames_write_the_same_file_and_totals(compiled) -> None:  # type: ignore[no-untyped-def]
    plain = _as_tuples(compiled)
    assert all(isinstance(p.frames, tuple) for p in plain.performers)
    assert plain == compiled
    assert schedule_to_bytes(plain) == schedule_to_bytes(compiled)
    assert totals(plain) == totals(compiled)
    for a, b in zip(plain.performers, compiled.performers, strict=True):
        assert a.total_bytes == b.total_bytes == sum(len(f.data) for f in a.frames)
        assert link_use(a.link, a.frames, a.end) == link_use(b.link, b.frames, b.end)
        assert frame_columns(a.frames)[:4] == tuple(map(list, frame_columns(b.frames)[:4]))
    again = schedule_from_bytes(schedule_to_bytes(compiled))
    assert again == compiled


def test_frames_refuse_columns_of_different_lengths() -> None:
    with pytest.raises(ValueError, match="different lengths"):
        Frames(FrameColumns([0, 1], [b"a"], [None], [0.0], None))


def test_frames_compare_with_tuples_only() -> None:
    origin = Origin("show.yaml", 3, 5, "crouch")
    frames = Frames(FrameColumns([1_500_000], [b"\x55"], [origin], [0.0], None))
    one = (ScheduledFrame(1.5, b"\x55", origin),)
    assert frames == one and frames == Frames(FrameColumns([1_500_000], [b"\x55"], [origin],
                                                            [0.0], None))
    assert frames != list(one) and frames != ()
    assert repr(frames) == repr(one)
    none = Frames(FrameColumns([], [], [], [], None))
    empty = PerformerSchedule("rex", "mini", get_profile("mini").link, none, 0.0)
    assert empty.frames == () and empty.total_bytes == 0


def test_an_executor_makes_the_frames_while_it_sets_up(compiled) -> None:  # type: ignore[no-untyped-def]
    from xgo_show.runtime.clock import FakeClock
    from xgo_show.runtime.executor import PerformerExecutor
    from xgo_show.sim import create_robot
    from xgo_show.transports.sim import SimTransport

    rex = compiled.performer("rex")
    assert isinstance(rex.frames, Frames) and rex.frames._frames is None
    clock = FakeClock()
    link = SimTransport(create_robot("mini"), clock=clock.now, sleep=clock.advance)
    PerformerExecutor(rex, link, clock=clock, profile=get_profile("mini"))
    assert rex.frames._frames is not None  # made: the show thread will not make them
    ready_frames(rex.frames)
    ready_frames(())  # a tuple: nothing to make
