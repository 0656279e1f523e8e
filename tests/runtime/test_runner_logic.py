"""The show runner's decisions, in-process: performers that only record what they are told, a
fake clock, and the runner's own supervisor thread.

What is stated here: when the show starts (the lead, what the performers need, ``start_at``),
what every way of ending does to every performer (completed, failed, a fault under each
policy, a stop request, a signal, an exception, a stop that does not finish), what the run
publishes and returns, how pause/resume/seek reach every performer, and that the process is
left as it was found (signal handlers, switch interval, garbage collection). The same runner
against simulators on real ptys: test_show_runner.py.
"""

from __future__ import annotations

import gc
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import pytest

from tests.conftest import wait_until
from tests.runtime.recording import RecordsCommands
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import SetupError, UsageError
from xgo_show.runtime import show_runner as show_runner_module
from xgo_show.runtime.clock import FakeClock, MonotonicClock
from xgo_show.runtime.events import (
    EventBus,
    EventRecorder,
    FaultRaised,
    FrameSent,
    ProgressTick,
    RunnerFailed,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
)
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.realtime import HELPER_PRIORITY
from xgo_show.runtime.show_runner import ShowResult, ShowRunner, _Waker

T0 = 1000.0
S = ExecutorState
ENDED = (S.FINISHED, S.STOPPED, S.FAILED)


class Stub(RecordsCommands):
    """A performer that records every call and does only what a test tells it to."""

    def __init__(self, name: str, clock: FakeClock, *, lead: float = 0.0,
                 show_time: float = 0.0, readings: Mapping[str, float] | None = None,
                 stop_cost: float = 0.0) -> None:
        self.name = name
        self.model = "mini"
        self.clock = clock
        self.lead = lead
        self.show_time = show_time
        self.readings: Mapping[str, float] = dict(readings or {})
        self.stop_cost = stop_cost  # clock seconds a safe stop takes
        self.state = S.IDLE
        self.fault: str | None = None
        self.stop_result: SafeStopResult | None = None
        super().__init__()
        self.on_start: Callable[[], object] = lambda: None
        self.block_stop: threading.Event | None = None  # a stuck port: stop waits for it
        self.stopped_on: tuple[str, bool] | None = None  # the stop thread: name, daemon

    @property
    def done(self) -> bool:
        return self.state in ENDED

    @property
    def progress(self) -> Progress:
        return Progress(self.name, self.state, self.show_time, 0, 10, "cue", "")

    def names(self) -> list[str]:
        return [c[0] for c in self.calls]

    def lead_time(self, offset: float) -> float:
        self.calls.append(("lead_time", offset))
        return self.lead

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        self.calls.append(("start", start_at, offset))
        self.state = S.RUNNING
        self.on_start()

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        self.calls.append(("safe_stop", reason, timeout))
        me = threading.current_thread()
        self.stopped_on = (me.name, me.daemon)  # a stuck port must not keep the process up
        if self.block_stop is not None:
            self.block_stop.wait(5.0)
        self.clock.advance(self.stop_cost)
        self.state = S.STOPPED
        self.stop_result = SafeStopResult(self.name, reason, True, ("stop",))
        return self.stop_result

    def join(self, timeout: float | None = None) -> bool:
        self.calls.append(("join", timeout))
        return True

    def close(self) -> None:
        self.calls.append(("close",))

    def end(self, state: ExecutorState = S.FINISHED, fault: str | None = None) -> None:
        self.fault = fault
        self.state = state


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock(T0)


@pytest.fixture
def two(clock: FakeClock) -> dict[str, Stub]:
    return {"rex": Stub("rex", clock), "ivy": Stub("ivy", clock)}


@pytest.fixture
def schedule(perf: Any, sched: Any) -> Schedule:
    return sched(perf("rex", end=20.0), perf("ivy", end=20.0))  # type: ignore[no-any-return]


def runner_for(schedule: Schedule, stubs: Mapping[str, Stub], clock: FakeClock,
               **options: Any) -> ShowRunner:
    options.setdefault("progress_hz", 200.0)
    options.setdefault("hold_gc", False)
    return ShowRunner(schedule, stubs, events=EventBus(), clock=clock,  # type: ignore[arg-type]
                      **options)


def in_thread(runner: ShowRunner, **options: Any) -> Callable[[], ShowResult]:
    """Run the show in a thread; the function returned waits for its result."""
    out: list[ShowResult] = []
    th = threading.Thread(target=lambda: out.append(runner.run(handle_signals=False, **options)))
    th.start()

    def result() -> ShowResult:
        th.join(5.0)
        assert out, "the runner did not return"
        return out[0]

    return result


def started(stubs: Mapping[str, Stub]) -> None:
    wait_until(lambda: all(s.state is not S.IDLE for s in stubs.values()))


# ---------------------------------------------------------------------- building a runner


def test_a_performer_without_a_port_is_named(schedule: Schedule, clock: FakeClock) -> None:
    with pytest.raises(SetupError, match=r"^no port for performer\(s\) rex, ivy$"):
        runner_for(schedule, {}, clock)
    with pytest.raises(SetupError, match=r"^no port for performer\(s\) ivy$"):
        runner_for(schedule, {"rex": Stub("rex", clock)}, clock)


def test_the_failure_policy_and_battery_floor_default_to_the_schedule(
    perf: Any, sched: Any, clock: FakeClock, two: dict[str, Stub]
) -> None:
    schedule = sched(perf("rex"), perf("ivy"), on_failure="continue")
    runner = runner_for(schedule, two, clock)
    assert runner.on_failure == "continue"
    assert runner.battery_floor == schedule.battery_floor
    runner = runner_for(schedule, two, clock, on_failure="halt_all", battery_floor=33.5)
    assert (runner.on_failure, runner.battery_floor) == ("halt_all", 33.5)
    assert runner_for(schedule, two, clock, battery_floor=0.0).battery_floor == 0.0
    with pytest.raises(SetupError, match=r"^unknown failure policy 'stop'; one of "
                       r"halt_all, continue$"):
        runner_for(schedule, two, clock, on_failure="stop")


def test_performers_come_in_schedule_order_then_those_that_play_no_robot(
    schedule: Schedule, clock: FakeClock
) -> None:
    stubs = {n: Stub(n, clock) for n in ("music", "ivy", "rex")}
    runner = runner_for(schedule, stubs, clock)
    assert list(runner.performers) == ["rex", "ivy", "music"]
    assert set(runner.stats) == {"rex", "ivy", "music"}


def test_the_options_default_to_four_progress_ticks_a_second_and_a_100_ms_stop(
    schedule: Schedule, two: dict[str, Stub]
) -> None:
    runner = ShowRunner(schedule, two, events=EventBus())  # type: ignore[arg-type]
    assert isinstance(runner.clock, MonotonicClock)
    assert runner.progress_interval == 0.25
    assert (runner.stop_timeout, runner.command_lead, runner.hold_gc) == (0.1, 0.0, True)
    assert runner.result is None and not runner.paused


# ---------------------------------------------------------------------- when the show starts


@pytest.mark.parametrize(("lead", "need", "start_at", "begin"), [
    (0.05, 0.0, None, T0 + 0.05),  # the lead
    (0.05, 0.2, None, T0 + 0.2),  # what the slowest performer needs, if longer
    (0.05, 0.0, T0 + 3.0, T0 + 3.0),  # a later start time
    (0.05, 0.2, T0 + 0.1, T0 + 0.2),  # never earlier than what the performers need
    (0.3, 0.2, T0 + 0.25, T0 + 0.3),
])
def test_every_performer_starts_at_the_same_time(
    schedule: Schedule, clock: FakeClock, lead: float, need: float, start_at: float | None,
    begin: float
) -> None:
    stubs = {"rex": Stub("rex", clock), "ivy": Stub("ivy", clock, lead=need)}
    runner = runner_for(schedule, stubs, clock)
    rec = EventRecorder(runner.events, ShowStarted)
    for s in stubs.values():
        s.on_start = s.end
    result = runner.run(handle_signals=False, lead=lead, start_at=start_at, offset=1.5)
    assert result.start_at == pytest.approx(begin) and result.offset == 1.5
    for s in stubs.values():
        assert s.calls[0] == ("lead_time", 1.5)
        assert s.calls[1][0] == "start" and s.calls[1][1] == pytest.approx(begin)
        assert s.calls[1][2] == 1.5
    [ev] = rec.events
    assert ev == ShowStarted(T0, "test", 1.5, ev.start_at, ("rex", "ivy"), "halt_all",  # type: ignore[attr-defined]
                             schedule.battery_floor)
    assert ev.start_at == pytest.approx(begin)  # type: ignore[attr-defined]


def test_the_default_lead_is_50_ms(schedule: Schedule, clock: FakeClock,
                                   two: dict[str, Stub]) -> None:
    for s in two.values():
        s.on_start = s.end
    result = runner_for(schedule, two, clock).run(handle_signals=False)
    assert result.start_at == pytest.approx(T0 + 0.05)
    assert result.offset == 0.0 and two["rex"].calls[1] == ("start", result.start_at, 0.0)


def test_a_show_without_performers_starts_after_the_lead_and_is_over(
    sched: Any, clock: FakeClock
) -> None:
    runner = runner_for(sched(), {}, clock)
    assert runner.snapshot().show_time == 0.0
    result = runner.run(handle_signals=False, lead=0.2)
    assert result.start_at == T0 + 0.2 and (result.completed, result.reason) == (True, "completed")


# ---------------------------------------------------------------------- how the show ends


def test_a_show_every_performer_finishes_is_completed(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    runner = runner_for(schedule, two, clock)
    rec = EventRecorder(runner.events, ShowEnded)
    result = in_thread(runner)
    started(two)
    two["rex"].end()
    time.sleep(0.03)
    assert runner.result is not None and runner.result.reason == ""  # ivy still plays
    two["ivy"].end()
    res = result()
    assert res is runner.result
    assert (res.completed, res.reason, res.stops, res.faults) == (True, "completed", {}, {})
    assert res.performers == two and res.stats is runner.stats and res.stop_latency is None
    assert runner.events.listener_errors == 0  # the runner listens only for what it reads
    for s in two.values():
        assert s.names() == ["lead_time", "start", "join", "close"]  # no stop
        assert s.calls[2] == ("join", 1.0)
    [ended] = rec.events
    assert ended == ShowEnded(T0, True, "completed", {}, {"rex": "finished", "ivy": "finished"},
                              None)


def test_a_performer_that_fails_without_a_fault_event_ends_the_show_uncompleted(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    runner = runner_for(schedule, two, clock)
    rec = EventRecorder(runner.events, ShowEnded)
    result = in_thread(runner)
    started(two)
    two["rex"].end(S.FAILED, "port closed")
    two["ivy"].end()
    res = result()
    assert (res.completed, res.reason) == (False, "performer(s) failed")
    assert res.faults == {"rex": "port closed"}
    [ended] = rec.events
    assert ended.faults == {"rex": "port closed"}  # type: ignore[attr-defined]
    assert ended.states == {"rex": "failed", "ivy": "finished"}  # type: ignore[attr-defined]


def fault(runner: ShowRunner, who: str, reason: str, t: float) -> None:
    runner.events.publish(FaultRaised(t, who, reason))


def test_a_fault_halts_every_performer_by_default(
    schedule: Schedule, clock: FakeClock
) -> None:
    stubs = {n: Stub(n, clock, stop_cost=0.02) for n in ("rex", "ivy")}
    runner = runner_for(schedule, stubs, clock, stop_timeout=0.3)
    rec = EventRecorder(runner.events, ShowEnded)
    result = in_thread(runner)
    started(stubs)
    clock.advance(1.0)
    stubs["rex"].end(S.FAILED, "port closed")
    fault(runner, "rex", "port closed", clock.now() - 0.01)
    res = result()
    why = "fault on rex: port closed"
    assert (res.completed, res.reason) == (False, why)
    assert set(res.stops) == {"rex", "ivy"}
    for name, s in stubs.items():
        assert s.names()[2:] == ["abort", "safe_stop", "join", "close"]
        assert s.calls[3] == ("safe_stop", why, 0.3)
        assert res.stops[name] == SafeStopResult(name, why, True, ("stop",))
        assert s.stopped_on == (f"xgo-show stop {name}", True)
    # From the fault's time to the end of the last stop: the two stops advance the clock
    # 20 ms each, in parallel threads on one fake clock.
    assert res.stop_latency == pytest.approx(0.01 + 0.04)
    [ended] = rec.events
    assert ended.reason == why and ended.faults == {"rex": "port closed"}  # type: ignore[attr-defined]
    assert ended.stop_latency == res.stop_latency  # type: ignore[attr-defined]


def test_with_continue_only_the_failing_performer_is_stopped(
    perf: Any, sched: Any, clock: FakeClock
) -> None:
    schedule = sched(perf("rex"), perf("ivy"), on_failure="continue")
    stubs = {n: Stub(n, clock) for n in ("rex", "ivy")}
    runner = runner_for(schedule, stubs, clock)
    result = in_thread(runner)
    started(stubs)
    stubs["rex"].fault = "fell over"
    fault(runner, "rex", "fell over", T0 - 0.25)  # reported late: the latency counts from it
    wait_until(lambda: stubs["rex"].state is S.STOPPED)
    fault(runner, "rex", "fell over again", T0)  # stopped once only
    time.sleep(0.03)
    assert stubs["ivy"].names() == ["lead_time", "start"]  # ivy plays on
    stubs["ivy"].end()
    res = result()
    assert (res.completed, res.reason) == (False, "performer(s) failed")
    assert list(res.stops) == ["rex"]
    assert stubs["rex"].names() == ["lead_time", "start", "abort", "safe_stop", "join", "close"]
    assert stubs["rex"].calls[3][1] == "fault on rex: fell over"
    assert res.faults == {"rex": "fell over"}
    assert res.stop_latency == pytest.approx(0.25)


def test_a_stop_request_safe_stops_everyone_and_keeps_the_first_reason(
    schedule: Schedule, clock: FakeClock
) -> None:
    stubs = {n: Stub(n, clock, stop_cost=0.01) for n in ("rex", "ivy")}
    runner = runner_for(schedule, stubs, clock)
    runner.stop()  # before the run even starts: it starts, then stops at once
    clock.advance(0.5)
    runner.stop("second")
    res = runner.run(handle_signals=False)
    assert (res.completed, res.reason) == (False, "stop requested")
    for name, s in stubs.items():
        assert s.names()[2:] == ["abort", "safe_stop", "join", "close"]
        assert s.calls[3][1] == "stop requested"
        assert res.stops[name].reason == "stop requested"
    assert res.stop_latency == pytest.approx(0.5 + 0.02)  # from the first request


def test_a_stop_that_does_not_finish_in_time_is_reported_and_delays_no_one(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    stuck = threading.Event()
    two["rex"].block_stop = stuck
    runner = runner_for(schedule, two, clock, stop_timeout=0.5)
    result = in_thread(runner)
    started(two)
    began = time.monotonic()
    runner.stop("enough")
    res = result()
    took = time.monotonic() - began
    stuck.set()
    assert res.stops["rex"] == SafeStopResult("rex", "enough", False,
                                              error="safe stop did not finish in time")
    assert res.stops["ivy"].ok
    assert 0.95 < took < 1.4  # twice the stop timeout for the stuck one, no more


def test_an_exception_in_the_coordinating_thread_stops_everyone_then_is_raised(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub], show_thread: list[object]
) -> None:
    runner = runner_for(schedule, two, clock)
    rec = EventRecorder(runner.events, RunnerFailed, ShowEnded)

    def boom() -> None:
        raise RuntimeError("boom")

    two["ivy"].on_start = boom
    with pytest.raises(RuntimeError, match="boom"):
        runner.run(handle_signals=False)
    res = runner.result
    assert res is not None
    why = "exception: RuntimeError('boom')"
    assert (res.completed, res.reason) == (False, why)
    for s in two.values():
        assert s.names()[-4:] == ["abort", "safe_stop", "join", "close"]
        assert s.calls[-3][1] == why
    failed, ended = rec.events
    assert show_thread == []  # never raised, so never lowered
    assert failed == RunnerFailed(T0, "RuntimeError('boom')", "RuntimeError")
    assert (ended.completed, ended.reason) == (False, why)  # type: ignore[attr-defined]


# ---------------------------------------------------------------------- steering the show


def test_pause_resume_and_seek_reach_every_performer_at_one_time(
    schedule: Schedule, clock: FakeClock
) -> None:
    stubs = {"rex": Stub("rex", clock, show_time=2.0), "ivy": Stub("ivy", clock, show_time=2.5)}
    runner = runner_for(schedule, stubs, clock, command_lead=0.1)
    rec = EventRecorder(runner.events, ShowPaused, ShowResumed, ShowSought)
    assert runner.paused is False
    runner.pause()
    assert runner.paused is True
    runner.resume(at=T0 + 3.0)
    assert runner.paused is False
    clock.advance(1.0)
    stubs["ivy"].lead = 0.4  # a seek waits for the slowest performer's catch-up
    runner.seek(4.0)
    runner.seek(5.0, at=T0 + 9.0)
    runner.pause(at=T0 + 5.0)
    runner.resume()
    for s in stubs.values():
        assert s.calls[0] == ("pause", pytest.approx(T0 + 0.1))
        assert s.calls[1] == ("resume", T0 + 3.0)
        assert s.calls[2] == ("lead_time", 4.0)
        assert s.calls[3] == ("seek", 4.0, pytest.approx(T0 + 1.4))
        assert s.calls[5] == ("seek", 5.0, T0 + 9.0)
        assert s.calls[6:] == [("pause", T0 + 5.0), ("resume", pytest.approx(T0 + 1.1))]
    assert rec.events[:2] == [ShowPaused(T0, 2.5), ShowResumed(T0, 2.5)]
    assert rec.events[2] == ShowSought(T0 + 1.0, 4.0, pytest.approx(T0 + 1.4))
    assert rec.events[3] == ShowSought(T0 + 1.0, 5.0, T0 + 9.0)


def test_a_seek_starts_no_earlier_than_the_command_lead(schedule: Schedule,
                                                       clock: FakeClock) -> None:
    stubs = {"rex": Stub("rex", clock, lead=0.05), "ivy": Stub("ivy", clock)}
    runner = runner_for(schedule, stubs, clock, command_lead=0.2)
    runner.seek(0.0)
    assert stubs["ivy"].calls[-1] == ("seek", 0.0, pytest.approx(T0 + 0.2))


@pytest.mark.parametrize("show_time", [-0.001, 20.0, 25.0])
def test_a_seek_outside_the_show_is_refused(schedule: Schedule, clock: FakeClock,
                                           two: dict[str, Stub], show_time: float) -> None:
    runner = runner_for(schedule, two, clock)
    with pytest.raises(UsageError, match=rf"^seek to {show_time:g} s: outside the show "
                       r"\(0 to 20 s\)$"):
        runner.seek(show_time)
    assert two["rex"].calls == []
    runner.seek(19.999)  # the last instant is inside
    assert two["rex"].calls[-1][:2] == ("seek", 19.999)


def test_a_snapshot_is_the_furthest_performer_and_the_readings_there_are(
    schedule: Schedule, clock: FakeClock
) -> None:
    stubs = {"rex": Stub("rex", clock, show_time=3.0, readings={"battery": 80.0}),
             "ivy": Stub("ivy", clock, show_time=4.5)}
    snap = runner_for(schedule, stubs, clock).snapshot()
    assert snap.show_time == 4.5 and snap.duration == 20.0
    assert [p.performer for p in snap.performers] == ["rex", "ivy"]
    assert snap.telemetry == {"rex": {"battery": 80.0}}


def test_progress_ticks_come_once_per_interval_of_clock_time(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub], monkeypatch: pytest.MonkeyPatch
) -> None:
    # The interval alone (moved to just after an instant of the grid: the test of that below).
    monkeypatch.setattr(show_runner_module, "PROGRESS_AFTER", None)
    runner = runner_for(schedule, two, clock, progress_hz=128.0)  # every 2**-7 s
    ticks = EventRecorder(runner.events, ProgressTick)
    result = in_thread(runner)
    started(two)
    wait_until(lambda: len(ticks.events) == 1)
    time.sleep(0.05)  # six intervals of real time, none of clock time
    assert len(ticks.events) == 1
    clock.advance(2**-8)
    time.sleep(0.03)
    assert len(ticks.events) == 1
    clock.advance(2**-8)
    wait_until(lambda: len(ticks.events) == 2)
    for s in two.values():
        s.end()
    result()
    first, second = ticks.events
    assert first.t == T0 and second.t == T0 + 2**-7
    assert first.progress.duration == 20.0  # type: ignore[attr-defined]


def test_the_first_progress_tick_comes_at_once_whatever_the_clock_reads(
    schedule: Schedule, two: dict[str, Stub]
) -> None:
    clock = FakeClock(0.0)
    runner = runner_for(schedule, two, clock)
    ticks = EventRecorder(runner.events, ProgressTick)
    result = in_thread(runner)
    started(two)
    wait_until(lambda: len(ticks.events) == 1)
    for s in two.values():
        s.end()
    result()
    assert ticks.events[0].t == 0.0


def test_frames_sent_count_in_their_performers_stats_until_the_run_ends(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    runner = runner_for(schedule, two, clock)

    def sent(who: str) -> None:
        runner.events.publish(FrameSent(T0, who, "frame", 0, T0, b"\x55\x00", "", 0.0, 0.0))

    sent("rex")
    sent("nobody")  # not a performer of this runner: ignored
    assert (runner.stats["rex"].frames, runner.stats["ivy"].frames) == (1, 0)
    for s in two.values():
        s.on_start = s.end
    runner.run(handle_signals=False)
    sent("rex")
    assert runner.stats["rex"].frames == 1  # the run let go of the bus


# ---------------------------------------------------------------------- the process around it


def test_a_run_holds_garbage_collection_and_gives_it_back(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    seen: list[tuple[bool, float]] = []
    two["rex"].on_start = lambda: seen.append((gc.isenabled(), sys.getswitchinterval()))
    two["ivy"].on_start = two["ivy"].end
    switch = sys.getswitchinterval()
    assert gc.isenabled()
    runner = runner_for(schedule, two, clock, hold_gc=True)
    result = in_thread(runner)
    started(two)
    assert gc.get_freeze_count() > 0
    two["rex"].end()
    result()
    assert seen == [(False, 0.0005)]
    assert gc.isenabled() and gc.get_freeze_count() == 0
    assert sys.getswitchinterval() == switch
    # Without hold_gc collection goes on; a disabled collector stays disabled either way.
    two["rex"].state = two["ivy"].state = S.IDLE
    two["rex"].on_start = lambda: (seen.append((gc.isenabled(), 0.0)), two["rex"].end())
    runner_for(schedule, two, clock, hold_gc=False).run(handle_signals=False)
    assert seen[-1] == (True, 0.0)
    gc.disable()
    try:
        two["rex"].state = two["ivy"].state = S.IDLE
        runner_for(schedule, two, clock, hold_gc=True).run(handle_signals=False)
        assert not gc.isenabled() and gc.get_freeze_count() == 0
    finally:
        gc.enable()


def test_a_longer_switch_interval_is_shortened_and_a_shorter_one_kept(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    seen: list[float] = []
    switch = sys.getswitchinterval()

    def note() -> None:
        seen.append(sys.getswitchinterval())
        two["rex"].end()

    try:
        for interval in (0.005, 0.0001):
            sys.setswitchinterval(interval)
            for s in two.values():
                s.state = S.IDLE
            two["rex"].on_start, two["ivy"].on_start = note, two["ivy"].end
            runner_for(schedule, two, clock).run(handle_signals=False)
            assert sys.getswitchinterval() == pytest.approx(interval, abs=2e-6)
    finally:
        sys.setswitchinterval(switch)
    assert seen == [0.0005, pytest.approx(0.0001, abs=2e-6)]


@pytest.fixture
def show_thread(monkeypatch: pytest.MonkeyPatch) -> list[object]:
    calls: list[object] = []
    monkeypatch.setattr(show_runner_module, "enter_show_thread",
                        lambda priority: calls.append(("enter", priority)) or True)
    monkeypatch.setattr(show_runner_module, "leave_show_thread",
                        lambda: calls.append("leave"))
    return calls


def test_the_coordinating_thread_runs_at_helper_priority_on_a_real_clock(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub], show_thread: list[object]
) -> None:
    for s in two.values():
        s.on_start = s.end
    ShowRunner(schedule, two, events=EventBus(), clock=MonotonicClock(),  # type: ignore[arg-type]
               hold_gc=False).run(handle_signals=False)
    assert show_thread == [("enter", HELPER_PRIORITY), "leave"]
    show_thread.clear()
    for s in two.values():
        s.state = S.IDLE
    runner_for(schedule, two, clock).run(handle_signals=False)
    assert show_thread == []  # virtual time: nothing to raise


def tstp() -> None:
    """Ctrl-Z, only while a handler other than the default is there (the default would
    suspend the test run)."""
    if signal.getsignal(signal.SIGTSTP) not in (signal.SIG_DFL, None):
        os.kill(os.getpid(), signal.SIGTSTP)


def send(sig: int, stubs: Mapping[str, Stub]) -> None:
    """``sig`` to this process if the runner handles it; else end the show (a default
    handler would end the test run)."""
    if signal.getsignal(sig) in (signal.SIG_DFL, signal.default_int_handler, None):
        for s in stubs.values():
            s.end()
        return
    os.kill(os.getpid(), sig)


def test_signals_stop_or_pause_the_show_in_the_main_thread(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    assert threading.current_thread() is threading.main_thread()
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGTSTP)}
    for sig, name in ((signal.SIGINT, "SIGINT"), (signal.SIGTERM, "SIGTERM")):
        for s in two.values():
            s.state, s.calls = S.IDLE, []
        two["rex"].on_start = lambda sig=sig: send(sig, two)  # type: ignore[misc]
        res = runner_for(schedule, two, clock).run()
        assert res.reason == name
        assert all(s.names()[2:4] == ["abort", "safe_stop"] for s in two.values())
        assert {s: signal.getsignal(s) for s in before} == before
    # Ctrl-Z pauses the show instead of suspending the process; a second one resumes it.
    for s in two.values():
        s.state, s.calls = S.IDLE, []
    two["rex"].on_start = tstp
    runner = runner_for(schedule, two, clock)
    rec = EventRecorder(runner.events, ShowPaused, ShowResumed)

    def script() -> None:
        try:
            wait_until(lambda: two["ivy"].names().count("pause") == 1)
            tstp()
            wait_until(lambda: two["ivy"].names().count("resume") == 1)
        finally:
            for s in two.values():
                s.end()

    th = threading.Thread(target=script)
    th.start()
    try:
        result = runner.run()
    finally:
        th.join(5.0)
    assert result.completed
    assert two["ivy"].names() == ["lead_time", "start", "pause", "resume", "join", "close"]
    assert [type(e) for e in rec.events] == [ShowPaused, ShowResumed]
    assert {s: signal.getsignal(s) for s in before} == before


def test_two_quick_ctrl_zs_pause_and_resume(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    two["rex"].on_start = lambda: (tstp(), tstp())  # both before the supervisor looks
    runner = runner_for(schedule, two, clock)

    def script() -> None:
        try:
            wait_until(lambda: "resume" in two["ivy"].names())
        finally:
            for s in two.values():
                s.end()

    th = threading.Thread(target=script)
    th.start()
    try:
        result = runner.run()
    finally:
        th.join(5.0)
    assert result.completed and not runner.paused
    assert two["ivy"].names() == ["lead_time", "start", "pause", "resume", "join", "close"]


def test_without_signal_handling_or_outside_the_main_thread_no_handler_changes(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    before = signal.getsignal(signal.SIGINT)
    seen: list[object] = []

    def note() -> None:
        seen.append(signal.getsignal(signal.SIGINT))
        two["rex"].end()

    two["rex"].on_start, two["ivy"].on_start = note, two["ivy"].end
    runner_for(schedule, two, clock).run(handle_signals=True)
    assert seen[-1] is not before  # the runner's own, in the main thread
    for s in two.values():
        s.state = S.IDLE
    runner_for(schedule, two, clock).run(handle_signals=False)
    assert seen[-1] is before
    for s in two.values():
        s.state = S.IDLE
    th = threading.Thread(target=lambda: runner_for(schedule, two, clock).run())
    th.start()
    th.join(5.0)
    assert seen[-1] is before and len(seen) == 3
    assert signal.getsignal(signal.SIGINT) is before


# ---------------------------------------------------------------------- the wake-up pipe


@pytest.fixture
def waker() -> Iterator[_Waker]:
    w = _Waker()
    yield w
    w.close()


def test_a_wake_up_ends_a_wait_at_once_and_only_once(
    waker: _Waker, capfd: pytest.CaptureFixture[str]
) -> None:
    waker.wake()  # before open: nowhere to write, and nothing to wait for
    assert capfd.readouterr() == ("", "")
    t = time.monotonic()
    waker.wait(1.0)
    assert time.monotonic() - t < 0.05
    waker.open()
    for _ in range(3):
        waker.wake()
    t = time.monotonic()
    waker.wait(1.0)
    assert time.monotonic() - t < 0.05
    t = time.monotonic()
    waker.wait(0.05)  # every wake-up was taken in by the first wait
    assert 0.04 < time.monotonic() - t < 0.5


def test_a_full_pipe_is_a_wake_up_already_pending(waker: _Waker) -> None:
    waker.open()
    for _ in range(100_000):  # more than a pipe holds
        waker.wake()
    t = time.monotonic()
    waker.wait(1.0)
    assert time.monotonic() - t < 0.05


def test_a_wake_up_from_another_thread_ends_the_wait(waker: _Waker) -> None:
    waker.open()
    t = time.monotonic()  # before the timer starts: on a busy machine it may fire at once
    threading.Timer(0.02, waker.wake).start()
    waker.wait(2.0)
    assert 0.015 < time.monotonic() - t < 1.0


def test_a_closed_waker_gives_back_its_pipe_and_can_open_again(waker: _Waker) -> None:
    waker.open()
    r, w = waker._r, waker._w
    waker.open()  # already open: the same pipe
    assert (waker._r, waker._w) == (r, w)
    waker.close()
    assert (waker._r, waker._w) == (-1, -1)
    with pytest.raises(OSError):
        os.fstat(r)
    with pytest.raises(OSError):
        os.fstat(w)
    waker.wake()  # closed: nothing happens
    waker.close()
    waker.open()
    assert waker._r >= 0 and waker._w >= 0


def test_a_negative_wait_is_a_poll(waker: _Waker) -> None:
    waker.open()
    t = time.monotonic()
    waker.wait(-1.0)
    assert time.monotonic() - t < 0.05


def test_a_short_stop_timeout_gives_up_on_a_stuck_stop_as_soon(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    """The wait for a stuck stop is twice the stop timeout however short it is: 0.1 s for a
    50 ms timeout, never a floor of a second."""
    stuck = threading.Event()
    two["rex"].block_stop = stuck
    runner = runner_for(schedule, two, clock, stop_timeout=0.05)
    result = in_thread(runner)
    started(two)
    began = time.monotonic()
    runner.stop("enough")
    res = result()
    took = time.monotonic() - began
    stuck.set()
    assert res.stops["rex"].error == "safe stop did not finish in time" and res.stops["ivy"].ok
    assert took < 0.9


# ---------------------------------------------------------------------- progress between instants


def test_progress_is_published_just_after_an_instant_of_the_grid(
    schedule: Schedule, two: dict[str, Stub], monkeypatch: pytest.MonkeyPatch
) -> None:
    # A listener (the live table: 2-12 ms) holds Python's lock; right after an instant it
    # delays no frame (show_runner.PROGRESS_AFTER).
    runner = runner_for(schedule, two, FakeClock(T0))
    step = 1.0 / schedule.control_rate
    after = show_runner_module.PROGRESS_AFTER
    assert after is not None
    # Show time 3.007 at clock 100.0: 0.25 s later is show time 3.257; the next instant of
    # the grid is the one at or after it, then PROGRESS_AFTER more.
    when = runner._after_instant(100.25, 100.0, 3.007)
    instant = -(-3.257 // step) * step
    assert when == pytest.approx(100.25 + (instant - 3.257) + after)
    assert 100.25 < when <= 100.25 + step + 0.001
    # Off the grid on both clocks: the show time 0.2537 s later is 3.2607.
    off = runner._after_instant(100.2648, 100.0111, 3.007)
    assert off == pytest.approx(100.2648 + (-(-3.2607 // step) * step - 3.2607) + after)
    on_grid = runner._after_instant(100.25, 100.0, 3.0)  # already on an instant
    assert on_grid == pytest.approx(100.25 + after)
    monkeypatch.setattr(show_runner_module, "PROGRESS_AFTER", None)
    assert runner._after_instant(100.25, 100.0, 3.007) == 100.25


def test_the_supervisor_wakes_for_the_next_tick_not_a_whole_interval_later(
    schedule: Schedule, clock: FakeClock, two: dict[str, Stub]
) -> None:
    # Ticks every 0.5 s of clock time, moved to just after an instant: the next is due 1 ms
    # after the interval. The supervisor waits only until it (not another whole interval).
    runner = runner_for(schedule, two, clock, progress_hz=2.0)
    ticks = EventRecorder(runner.events, ProgressTick)
    result = in_thread(runner)
    started(two)
    wait_until(lambda: len(ticks.events) == 1)
    clock.advance(0.5)  # the interval, not yet the instant after it
    time.sleep(0.6)  # the supervisor's first wait (0.5 s of real time) is over
    assert len(ticks.events) == 1
    advanced = time.monotonic()
    clock.advance(0.002)
    seen = wait_until(lambda: len(ticks.events) == 2)
    for s in two.values():
        s.end()
    result()
    assert ticks.events[1].t == pytest.approx(T0 + 0.502)
    # Waiting a whole interval again would have seen it up to 0.5 s later.
    assert seen - advanced < 0.25
