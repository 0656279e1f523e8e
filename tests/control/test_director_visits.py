"""Waits as visits: every performer holds at each wait and leaves it at the time decided once
for all, however far apart the performers run (virtual time: each writer on its own clock).

The first test replays, event by event, the order that used to lose a robot: one performer
reaches the second wait and it times out while the other has been told to leave the first
wait but has not yet said it runs. The property test plays random triggered routines with
random trigger scripts in virtual time on in-process simulators and compares what every robot
did with the timeline the script gives in real time.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.director import Director, WaitReleased, WaitStarted
from xgo_show.control.script import ScriptCue, ScriptPlayer, TriggerScript
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import (
    Event,
    EventBus,
    FrameSent,
    ShowStarted,
    StateChanged,
)
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.show_runner import ShowRunner
from xgo_show.transports.sim import open_sim

RUNNING, PAUSED = ExecutorState.RUNNING, ExecutorState.PAUSED


def _us(t: float | None) -> float | None:
    return None if t is None else round(t, 6)


@dataclass
class Recorder:
    """A performer that only records what it is told (the director's side of the protocol),
    times rounded to the microsecond."""

    name: str
    calls: list[tuple[object, ...]] = field(default_factory=list)

    def pause(self, *, at: float | None = None) -> None:
        self.calls.append(("pause", _us(at)))

    def resume(self, *, at: float | None = None) -> None:
        self.calls.append(("resume", _us(at)))

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        self.calls.append(("seek", show_time, _us(at)))


def test_a_timeout_while_a_robot_is_still_leaving_the_wait_before_is_applied_at_its_hold(
    triggered_schedule: Schedule,
) -> None:
    # Sections: a; b at 0.6 waits for 'go'; c at 1.2 waits for 'encore' 0.3 s, else d (1.8).
    clock = FakeClock(100.0)
    bus = EventBus()
    rex, ivy = Recorder("rex"), Recorder("ivy")
    runner = ShowRunner(triggered_schedule, {"rex": rex, "ivy": ivy},  # type: ignore[dict-item]
                        events=bus, clock=clock, hold_gc=False)
    director = Director(runner, clock=clock)
    seen: list[Event] = []
    bus.subscribe(seen.append, WaitStarted, WaitReleased)
    t0 = 100.05

    def at(offset: float) -> float:
        return round(t0 + offset, 6)

    def state(who: str, what: ExecutorState, t: float, show: float) -> None:
        bus.publish(StateChanged(t, who, what, show))

    try:
        bus.publish(ShowStarted(100.0, "t", 0.0, t0, ("rex", "ivy"), "halt_all", 20))
        state("rex", RUNNING, t0, 0.0)
        state("ivy", RUNNING, t0, 0.0)
        assert rex.calls == ivy.calls == [("pause", at(0.6))]
        state("ivy", PAUSED, t0 + 0.6, 0.6)  # ivy holds at b first
        director.trigger("go")  # virtual time: at the instant the show holds
        assert ivy.calls[-1] == ("resume", at(0.6))
        state("ivy", RUNNING, t0 + 0.6, 0.6)
        assert ivy.calls[-1] == ("pause", at(1.2))
        state("rex", PAUSED, t0 + 0.6, 0.6)  # rex gets to b after the release: leaves at once
        assert rex.calls[-1] == ("resume", at(0.6))
        state("ivy", PAUSED, t0 + 1.2, 1.2)  # ivy holds at c ...
        director.expire()  # ... which times out, before rex says it runs again
        assert ivy.calls[-2:] == [("seek", 1.8, at(1.5)), ("resume", at(1.5))]
        # The bad order: rex used to get pause + seek + resume here, at the director's clock
        # time (not rex's), on top of the resume it had not acted on yet; the executor kept
        # one of the two resumes and rex stayed paused at a wrong show time. Now rex, told one
        # thing at a time, gets nothing until it runs; then it plays section b, holds at c
        # like ivy, and leaves c as the timeout said, at the same time.
        assert rex.calls == [("pause", at(0.6)), ("resume", at(0.6))]
        state("rex", RUNNING, t0 + 0.6, 0.6)
        assert rex.calls[-1] == ("pause", at(1.2))
        state("rex", PAUSED, t0 + 1.2, 1.2)
        assert rex.calls[-2:] == [("seek", 1.8, at(1.5)), ("resume", at(1.5))]
        state("rex", RUNNING, t0 + 1.5, 1.8)
        state("ivy", RUNNING, t0 + 1.5, 1.8)
        assert len(rex.calls) == len(ivy.calls) == 5  # no wait after d: nothing more
        assert [(type(e).__name__, e.section) for e in seen] == [  # type: ignore[attr-defined]
            ("WaitStarted", "b"), ("WaitReleased", "b"), ("WaitStarted", "c"),
            ("WaitReleased", "c"),
        ]
        assert director.phase == "playing" and director.wait_ahead is None
    finally:
        director.close()


# ---------------------------------------------------------------------- the property


@dataclass(frozen=True)
class Sec:
    name: str
    start: float
    trigger: str | None = None
    timeout: float | None = None
    otherwise: str = "continue"


@dataclass(frozen=True)
class Routine:
    performers: tuple[str, ...]  # models, one performer each
    sections: tuple[Sec, ...]
    duration: float

    def yaml(self) -> str:
        lines = ["show: Random triggered", "performers:"]
        lines += [f"  p{i}: {{model: {m}}}" for i, m in enumerate(self.performers)]
        lines.append("sections:")
        for s in self.sections:
            wait = ""
            if s.trigger is not None:
                extra = "" if s.timeout is None else f", timeout: {s.timeout}, else: {s.otherwise}"
                wait = f", wait: {{trigger: {s.trigger}{extra}}}"
            lines.append(f"  - {{name: {s.name}, at: {s.start}{wait}}}")
        lines.append("tracks:")
        bounds = [s.start for s in self.sections] + [self.duration]
        for i in range(len(self.performers)):
            lines.append(f"  p{i}:")
            for k, start in enumerate(bounds[:-1]):
                length = round((bounds[k + 1] - start) * 0.9, 3)
                pitch = 1 if (i + k) % 2 else 0
                lines.append(f"    - {{at: {start}, move: {{pitch: {pitch}}}, duration: {length}}}")
        return "\n".join(lines) + "\n"


@st.composite
def routines(draw: st.DrawFn) -> Routine:
    models = tuple(draw(st.lists(st.sampled_from(["mini", "lite"]), min_size=2, max_size=3)))
    lengths = draw(st.lists(st.sampled_from([0.3, 0.4, 0.5]), min_size=2, max_size=4))
    starts = [round(sum(lengths[:i]), 3) for i in range(len(lengths))]
    names = [f"s{i}" for i in range(len(lengths))]
    sections = [Sec(names[0], 0.0)]
    for i in range(1, len(lengths)):
        if not draw(st.booleans()):
            sections.append(Sec(names[i], starts[i]))
            continue
        timeout = draw(st.sampled_from([None, 0.15, 0.35]))
        # else: forward only (a jump back could loop for ever when nobody triggers)
        otherwise = draw(st.sampled_from(["continue", "end", *names[i + 1:]]))
        sections.append(Sec(names[i], starts[i], f"t{i}", timeout, otherwise))
    if all(s.trigger is None for s in sections):
        last = sections[-1]
        sections[-1] = Sec(last.name, last.start, f"t{len(sections) - 1}", 0.15)
    return Routine(models, tuple(sections), round(sum(lengths), 3))


@st.composite
def scripts(draw: st.DrawFn, routine: Routine) -> tuple[ScriptCue, ...]:
    triggers = [s.trigger for s in routine.sections if s.trigger is not None]
    cues = []
    for _ in range(draw(st.integers(1, 4))):
        name = draw(st.sampled_from(triggers))
        value = draw(st.sampled_from([0.0, 0.1, 0.25, 0.5, 0.9, 1.3]))
        if draw(st.booleans()):
            cues.append(ScriptCue(trigger=name, at=value))
        else:
            cues.append(ScriptCue(trigger=name, after=value))
    return tuple(cues)


@dataclass
class Expected:
    """The real-time timeline: segments (clock time, from show time, to show time) played,
    relative to the show's start, and how it ends."""

    segments: list[tuple[float, float, float]]
    completed: bool
    end: float  # clock time of the end (completed) or of the hold it stopped at
    # The closest a cue came to its wait's timeout (s): at a tie, which wins is float rounding
    # (the director counts from its clock's origin, this model from 0), not a rule to test.
    tie: float = float("inf")


def expected(routine: Routine, cues: tuple[ScriptCue, ...], duration: float) -> Expected:
    """What the script does to the show in real time: each section starts at max(trigger
    time, hold reached), or at the timeout; entries fire one after another, each once.
    ``duration``: the compiled show's (its last frame's time, not the routine's end)."""
    todo = list(cues)
    t, pos, after, turn = 0.0, 0.0, False, 0.0
    segments: list[tuple[float, float, float]] = []
    tie = float("inf")
    while True:
        wait = next((s for s in routine.sections if s.trigger is not None
                     and (s.start > pos + 1e-9 or (not after and s.start >= pos - 1e-9))), None)
        if wait is None:
            segments.append((t, pos, duration))
            return Expected(segments, True, t + duration - pos, tie)
        hold = t + wait.start - pos
        segments.append((t, pos, wait.start))
        expiry = None if wait.timeout is None else hold + wait.timeout
        released = None
        while todo:
            cue = todo[0]
            if cue.at is not None:
                due = max(turn, cue.at)
            elif cue.trigger == wait.trigger:
                due = max(hold, turn) + (cue.after or 0.0)
            else:
                break
            if expiry is not None:
                tie = min(tie, abs(due - expiry))
                if due > expiry:
                    break
            todo.pop(0)
            turn = due
            if cue.trigger == wait.trigger:
                released = max(due, hold)
                break
        if released is not None:
            t, pos, after = released, wait.start, True
        elif expiry is None:
            return Expected(segments, False, hold, tie)
        elif wait.otherwise == "continue":
            t, pos, after = expiry, wait.start, True
        elif wait.otherwise == "end":
            t, pos, after = expiry, duration, False
        else:
            target = next(s for s in routine.sections if s.name == wait.otherwise)
            t, pos, after = expiry, target.start, False


def rehearse(schedule: Schedule, cues: tuple[ScriptCue, ...]) -> tuple[
        ShowRunner, list[Event], float]:
    """Play ``schedule`` in virtual time on in-process simulators with the script."""
    clock = FakeClock(1000.0, keep_waits=False)
    transports = {p.name: open_sim(f"sim:{p.model}") for p in schedule.performers}
    for tr in transports.values():
        tr.open()
    runner = local_runner(schedule, transports, clock=clock, telemetry=False, hold_gc=False)
    seen: list[Event] = []
    runner.events.subscribe(seen.append, FrameSent, StateChanged, ShowStarted)
    director = Director(runner, clock=clock)
    player = ScriptPlayer(TriggerScript(triggers=list(cues)), director, say=lambda _: None)
    try:
        started = time.monotonic()
        runner.run(handle_signals=False, lead=0.05)
        return runner, seen, time.monotonic() - started
    finally:
        player.close()
        director.close()
        for tr in transports.values():
            tr.close()


_LATE = 0.25  # s: the most a real-time event may trail its virtual time on a loaded machine
TOLERANCE = 0.03  # s per hold: the rest and catch-up frames before a section goes on


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_a_virtual_rehearsal_keeps_the_real_time_timeline(data: st.DataObject) -> None:
    routine = data.draw(routines(), label="routine")
    cues = data.draw(scripts(routine), label="script")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "show.yaml"
        path.write_text(routine.yaml(), encoding="utf-8")
        schedule = compile_show(load_show(path))
    want = expected(routine, cues, schedule.duration)
    assume(want.tie > 1e-6)  # a cue exactly at a timeout: either outcome is right
    runner, seen, took = rehearse(schedule, cues)
    result = runner.result
    assert result is not None
    assert took < 5.0, "virtual time waits for nothing"  # it always ends, and fast
    start = next(e for e in seen if isinstance(e, ShowStarted)).start_at
    if not want.completed:
        assert not result.completed and "no trigger" in result.reason, result.reason
        return
    assert result.completed, result.reason
    slack = TOLERANCE * len(want.segments)
    for perf in schedule.performers:
        frames = perf.frames
        sent = [e for e in seen if isinstance(e, FrameSent) and e.performer == perf.name
                and e.kind == "frame"]
        # Every frame of each part played goes out once, none of what was skipped.
        expect_idx = [i for i, f in enumerate(frames)
                      if any(lo - 1e-9 <= f.t < hi - 1e-9 for _, lo, hi in want.segments)]
        assert sorted(e.index for e in sent) == expect_idx  # type: ignore[type-var]
        # Each part goes out on the real-time timeline: its section starts at the trigger,
        # the hold or the timeout.
        for e in sent:
            assert e.index is not None and e.planned is not None
            f = frames[e.index].t
            clock_t, lo, _ = next(s for s in want.segments if s[1] - 1e-9 <= f < s[2] - 1e-9)
            assert -1e-9 <= (e.planned - start) - (clock_t + f - lo) <= slack, (
                perf.name, e.index, f, e.planned - start, clock_t + f - lo)
        # Every robot ends at the show's end time.
        finished = [e for e in seen if isinstance(e, StateChanged) and e.performer == perf.name
                    and e.state is ExecutorState.FINISHED]
        assert len(finished) == 1
        assert 0.0 <= finished[0].show_time - schedule.duration < 0.02  # (+ its rest frames)
        assert -1e-9 <= finished[0].t - start - want.end <= slack + 0.02


def test_a_script_plays_the_same_in_virtual_and_in_real_time(triggered_schedule: Schedule) -> None:
    """The same script, once in real time on simulators (real ptys), once in virtual time:
    the same holds, triggers and releases, at the same times from the start."""
    from tests.conftest import wait_until
    from tests.control.conftest import directed_show

    script = TriggerScript(triggers=[
        ScriptCue(trigger="go", after=0.2),  # released 0.2 s into the hold at b (0.6 s)
        ScriptCue(trigger="go", at=0.3),  # its turn comes then: refused, already given
        ScriptCue(trigger="encore", at=0.4),  # and then: kept for c, which is played through
    ])
    runs: list[list[tuple[str, str, str, float]]] = []
    fired: list[list[float]] = []
    for fast in (False, True):
        with directed_show(triggered_schedule, fast=fast) as (director, played, go):
            player = ScriptPlayer(script, director, say=lambda _: None)
            go()
            wait_until(lambda: played.result is not None, timeout=10.0)
            player.close()
        assert played.result is not None and played.result.completed
        start = next(e for e in played.events if isinstance(e, ShowStarted)).start_at
        runs.append([
            (type(e).__name__, e.section, getattr(e, "how", ""), e.t - start)
            for e in played.events if isinstance(e, (WaitStarted, WaitReleased))
        ])
        assert [(f.trigger, f.result.split(":")[0]) for f in player.fired] == [
            ("go", "released section 'b'"),
            ("go", "trigger 'go' refused"),
            ("encore", "kept for section 'c'"),
        ]
        fired.append([f.t for f in player.fired])
    real, virtual = runs
    assert [r[:3] for r in real] == [v[:3] for v in virtual] == [
        ("WaitStarted", "b", ""), ("WaitReleased", "b", "trigger"),
        ("WaitReleased", "c", "early"),
    ]
    # Virtual time is exact: every entry's turn comes at 0.8 s (0.6 + 0.2, then no earlier
    # than the turn before). Real time is the same times, never earlier, and later only by
    # how late this shared machine wakes threads (a few ms idle; tens under load 8-16, and the
    # three firings' lateness adds up, as each turn starts when the one before was fired).
    assert fired[1] == pytest.approx([0.8] * 3, abs=1e-9)
    for times, ideal in ((fired[0], fired[1]), ([r[3] for r in real], [v[3] for v in virtual])):
        late = [t - i for t, i in zip(times, ideal, strict=True)]
        assert all(-0.005 < x < _LATE for x in late), (real, virtual, fired)
