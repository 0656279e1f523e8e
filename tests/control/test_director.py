"""The director holds a running show at its waits and releases it on triggers (real ptys)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

from xgo_show.compiler.schedule import Schedule
from xgo_show.control.director import (
    ControlError,
    TriggerRefused,
    WaitReleased,
    WaitStarted,
)

Wait = Callable[..., None]


def _first_index_at(schedule: Schedule, performer: str, t: float) -> int:
    frames = schedule.performer(performer).frames
    return next(i for i, f in enumerate(frames) if f.t >= t - 1e-9)


def test_the_show_holds_at_a_wait_until_its_trigger_then_plays_on(
    triggered_schedule: Schedule, wait: Wait, directed: Callable[..., Any]
) -> None:
    with directed(triggered_schedule) as (director, played, go):
        go()
        wait(lambda: director.phase == "waiting", timeout=5.0)
        assert director.waiting_for is not None and director.waiting_for.name == "b"
        time.sleep(0.3)  # held: nothing of section b goes out
        released_at = time.monotonic()
        outcome = director.trigger("go")
        assert outcome.held and outcome.section == "b"
        wait(lambda: played.result is not None, timeout=10.0)
    result = played.result
    assert result is not None and result.completed, result.reason
    for name in ("rex", "ivy"):
        first_b = _first_index_at(triggered_schedule, name, 0.6)
        first_c = _first_index_at(triggered_schedule, name, 1.2)
        frames = played.scheduled(name)
        before = [f for f in frames if f.index is not None and f.index < first_b]
        after = [f for f in frames if f.index is not None and first_b <= f.index < first_c]
        # Frame by frame: every frame of section a went before the hold, none of b before
        # the trigger, and b's frames went out where they belong after it: section start
        # (0.6 s) on the trigger, within a few ms.
        assert before and after
        assert max(f.t for f in before) < released_at - 0.25
        assert min(f.t for f in after) >= released_at
        # After the release the section keeps its own timing: one timeline (planned times
        # re-anchored once), whose section start is the trigger plus the catch-up frames'
        # time. (The send-time error around those planned times is the runtime's business,
        # measured in tests/runtime; here, on a shared loaded machine, it says nothing.)
        anchors = [(f.planned or 0.0) - (f.planned_show or 0.0) for f in after]
        assert max(anchors) - min(anchors) < 1e-6
        assert 0.0 <= anchors[0] + 0.6 - released_at < 0.05
    # 'encore' never came: its wait timed out after 0.3 s and the show skipped to d.
    released = [e for e in played.events if isinstance(e, WaitReleased)]
    assert [(e.section, e.how, e.goto) for e in released] == [
        ("b", "trigger", "b"), ("c", "timeout", "d")
    ]
    first_c = _first_index_at(triggered_schedule, "rex", 1.2)
    first_d = _first_index_at(triggered_schedule, "rex", 1.8)
    sent = {f.index for f in played.scheduled("rex")}
    assert not sent & set(range(first_c, first_d))  # section c was skipped
    assert first_d in sent


def test_a_trigger_given_before_its_wait_is_kept_and_the_show_goes_through(
    triggered_schedule: Schedule, wait: Wait, directed: Callable[..., Any]
) -> None:
    with directed(triggered_schedule) as (director, played, go):
        go()
        wait(lambda: director.phase == "playing", timeout=5.0)
        outcome = director.trigger("go")
        assert not outcome.held and outcome.section == "b"
        wait(lambda: director.wait_ahead is not None and director.wait_ahead.name == "c",
             timeout=5.0)
        outcome = director.trigger("encore")
        assert outcome.section == "c"
        wait(lambda: played.result is not None, timeout=10.0)
    assert played.result is not None and played.result.completed
    released = [(e.section, e.how) for e in played.events if isinstance(e, WaitReleased)]
    assert released == [("b", "early"), ("c", "early")]
    # The whole show played, a to d, in about its own length (no hold).
    rex = played.scheduled("rex")
    assert len(rex) == len(triggered_schedule.performer("rex").frames)
    assert rex[-1].t - rex[0].t < triggered_schedule.duration + 0.2


def test_triggers_nobody_waits_for_are_refused_with_the_reason(
    triggered_schedule: Schedule, wait: Wait, directed: Callable[..., Any]
) -> None:
    with directed(triggered_schedule) as (director, played, go):
        with pytest.raises(ControlError, match="no show is running"):
            director.trigger("go")
        go()
        wait(lambda: director.phase == "waiting", timeout=5.0)
        with pytest.raises(ControlError, match=r"the show waits for 'go' \(section 'b'\)"):
            director.trigger("encore")
        with pytest.raises(ControlError, match="no section of this show waits for 'lights'"):
            director.trigger("lights")
        with pytest.raises(ControlError, match="waits for trigger 'go'"):
            director.resume()
        director.trigger("go")
        with pytest.raises(ControlError, match=r"already given|will wait for 'encore'"):
            director.trigger("go")
        wait(lambda: played.result is not None, timeout=10.0)
        with pytest.raises(ControlError, match="the show is over"):
            director.trigger("encore")
    refused = [e for e in played.events if isinstance(e, TriggerRefused)]
    assert [e.trigger for e in refused] == ["go", "encore", "lights", "go", "encore"]


def test_a_pause_before_a_wait_does_not_lose_it(
    triggered_schedule: Schedule, wait: Wait, directed: Callable[..., Any]
) -> None:
    with directed(triggered_schedule) as (director, played, go):
        go()
        wait(lambda: director.phase == "playing", timeout=5.0)
        time.sleep(0.2)
        director.pause()
        wait(lambda: director.phase == "paused")
        time.sleep(0.2)
        director.resume()
        wait(lambda: director.phase == "waiting", timeout=5.0)
        held = [e for e in played.events if isinstance(e, WaitStarted)]
        assert [e.section for e in held] == ["b"]
        director.seek_section("d")  # seek out of a wait: d plays, c is skipped
        wait(lambda: played.result is not None, timeout=10.0)
    assert played.result is not None and played.result.completed
    assert [(e.section, e.how) for e in played.events if isinstance(e, WaitReleased)] == [
        ("b", "seek")
    ]


def test_virtual_time_plays_the_waits_in_order(
    triggered_schedule: Schedule, wait: Wait, directed: Callable[..., Any]
) -> None:
    with directed(triggered_schedule, fast=True) as (director, played, go):
        seen: list[str] = []

        def on_wait(e: object) -> None:
            assert isinstance(e, WaitStarted)
            seen.append(e.section)
            if e.section == "b":
                import threading

                threading.Thread(target=director.trigger, args=("go",),
                                 name="xgo-show test trigger").start()
            else:
                import threading

                threading.Thread(target=director.expire, name="xgo-show test expire").start()

        director.events.subscribe(on_wait, WaitStarted)
        go()
        wait(lambda: played.result is not None, timeout=10.0)
    assert played.result is not None and played.result.completed
    assert seen == ["b", "c"]
    assert [(e.section, e.how, e.goto) for e in played.events if isinstance(e, WaitReleased)] \
        == [("b", "trigger", "b"), ("c", "timeout", "d")]


def test_a_pause_in_a_released_section_resumes_it_without_repeating_or_skipping_a_frame(
    triggered_schedule: Schedule, wait: Wait, directed: Callable[..., Any]
) -> None:
    with directed(triggered_schedule) as (director, played, go):
        go()
        wait(lambda: director.phase == "waiting", timeout=5.0)
        director.trigger("go")  # section b (0.6 to 1.2 s of show) plays
        time.sleep(0.3)
        paused_at = time.monotonic()
        director.pause()
        wait(lambda: director.phase == "paused")
        time.sleep(0.3)
        resumed_at = time.monotonic()
        director.resume()
        wait(lambda: played.result is not None, timeout=10.0)
    assert played.result is not None and played.result.completed, played.result
    for name in ("rex", "ivy"):
        frames = triggered_schedule.performer(name).frames
        first_b = _first_index_at(triggered_schedule, name, 0.6)
        first_c = _first_index_at(triggered_schedule, name, 1.2)
        first_d = _first_index_at(triggered_schedule, name, 1.8)
        sent = [f.index for f in played.scheduled(name)]
        # Each frame once, in order: a and b whole (the pause cut b in two), c skipped by its
        # timeout, d whole.
        assert sent == [*range(first_c), *range(first_d, len(frames))], name
        b = [f for f in played.scheduled(name) if f.index is not None
             and first_b <= f.index < first_c]
        before = [f for f in b if f.t < paused_at + 0.05]
        after = [f for f in b if f.t >= resumed_at]
        assert before and after and len(before) + len(after) == len(b), name  # cut by it
        # Posture moves only: the robot was at rest (no speed, no periodic motion), so the
        # pause sent no rest frames and the resume no catch-up (nothing to bring back: it held
        # where the pause left it); the rest of b keeps its own timing, 0.3 s later.
        between = [f.kind for f in played.frames if f.performer == name
                   and paused_at <= f.t < after[0].t]
        assert "reach" not in between and "rest" not in between, (name, between)
        shift = [(f.planned or 0.0) - (f.planned_show or 0.0) for f in after]
        assert max(shift) - min(shift) < 1e-6
