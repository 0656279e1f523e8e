"""behave/ports.py without waiting on the real clock where it can be helped: the seat's reader
driven one read at a time with bytes handed in (a scripted port, a fake clock), the watcher's
part, a routine on a seat that never watched (a fake clock: it plays in no time), hand-overs
that repeat, how long a closing seat waits for a port that hangs, the engine's one stage over
here and the relays (recording stand-ins), and the runner's loop on a fake clock (each wait it
asks for is recorded). test_behave_ports_logic.py plays the same code on simulated robots in
real time; both are what behave/ports.py's mutation run measures."""

from __future__ import annotations

import datetime as dt
import queue
import threading
import time
from dataclasses import replace
from pathlib import Path

import pytest

from tests.behave.test_behave_ports_logic import MODELS, Staged, _behaviour, _posture, _rest
from tests.conftest import wait_until
from xgo_show.behave.ports import BehaviourRunner, PortStage, _Stages
from xgo_show.compiler.schedule import PerformerSchedule
from xgo_show.errors import TransportError
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Link
from xgo_show.runtime.clock import FakeClock, MonotonicClock
from xgo_show.runtime.events import (
    Event,
    EventBus,
    FaultRaised,
    FrameSent,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, PerformerExecutor
from xgo_show.sim import create_robot
from xgo_show.transports.base import Transport
from xgo_show.transports.sim import SimTransport
from xgo_show.wire.xgo import reply_frame

T0 = 500.0


class AlwaysOpen(Transport):
    """A port with nothing to open or close: the test ports below differ in reads and writes."""

    def open(self) -> None:
        pass

    def close(self) -> None:
        pass

    @property
    def is_open(self) -> bool:
        return True


class Scripted(AlwaysOpen):
    """A port whose reads return the chunks a test queues (``b""`` when none are left) or
    raise ``failure``; every read's (size, timeout) is recorded, every write kept."""

    def __init__(self, url: str = "scripted:rex") -> None:
        super().__init__(url)
        self.chunks: list[bytes] = []
        self.reads: list[tuple[int, float]] = []
        self.written: list[bytes] = []
        self.failure: Exception | None = None

    def write(self, data: bytes) -> None:
        self.written.append(bytes(data))

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        self.reads.append((size, timeout))
        if self.failure is not None:
            raise self.failure
        return self.chunks.pop(0) if self.chunks else b""


def _reply(model: str, item: str, byte: int) -> bytes:
    return reply_frame(get_profile(model).register(item).address, bytes((byte,)))


def _seat_stage(port: Transport, model: str = "mini", name: str = "rex") -> PortStage:
    """A stage of one performer on ``port`` and a fake clock at T0; nothing started."""
    return PortStage({}, {}, {name: model}, {name: port}, clock=FakeClock(T0), events=EventBus())


def _feed(stage: PortStage, name: str = "rex") -> tuple[PerformerExecutor, list[Event]]:
    """An executor (not started) that the seat's reads go to, and what it publishes."""
    seat = stage.seats[name]
    events: list[Event] = []
    bus = EventBus()
    bus.subscribe(events.append)
    executor = PerformerExecutor(seat.idle, seat.transport, clock=stage.clock,
                                 profile=seat.profile, telemetry=seat.poller, events=bus,
                                 read_port=False)
    seat._feed = executor
    return executor, events


def _reads(events: list[Event]) -> list[tuple[float, str, str, float]]:
    return [(e.t, e.performer, e.name, e.value) for e in events if isinstance(e, TelemetryRead)]


def test_each_read_hands_its_bytes_to_the_latest_executor_at_the_clocks_time() -> None:
    port = Scripted()
    stage = _seat_stage(port)
    seat, clock = stage.seats["rex"], stage.clock
    assert isinstance(clock, FakeClock)
    first, seen_first = _feed(stage)
    status = _reply("mini", "status", 1)
    port.chunks = [_reply("mini", "battery", 87) + status[:3], status[3:]]
    assert seat._read_once() is True
    assert _reads(seen_first) == [(T0, "rex", "battery", 87.0)]
    clock.advance(0.25)
    assert seat._read_once() is True  # a reply split across reads is whole at the second
    assert _reads(seen_first)[1:] == [(T0 + 0.25, "rex", "status", 1.0)]
    # A hand-over: the next executor gets the next bytes, the last one nothing more.
    _, seen_second = _feed(stage)
    port.chunks = [_reply("mini", "battery", 86)]
    assert seat._read_once() is True
    assert _reads(seen_second) == [(T0 + 0.25, "rex", "battery", 86.0)]
    assert len(_reads(seen_first)) == 2
    # Nothing there: nothing handed on, and the reader reads on.
    assert seat._read_once() is True
    assert len(_reads(seen_second)) == 1
    # Up to 256 bytes a read, waiting at most 50 ms (the stop flag is seen that often).
    assert port.reads == [(256, 0.05)] * 4
    assert first.state is ExecutorState.IDLE  # readings only: no fault


def test_bytes_read_before_any_executor_are_dropped() -> None:
    port = Scripted()
    stage = _seat_stage(port)
    port.chunks = [_reply("mini", "battery", 87)]
    assert stage.seats["rex"]._read_once() is True
    assert port.chunks == [] and stage.seats["rex"].poller.samples == 0
    port.failure = TransportError("unplugged")
    assert stage.seats["rex"]._read_once() is False  # nobody to tell, and no error


def test_a_fallen_robot_watched_is_a_reading_for_the_engine_not_a_fault() -> None:
    # The engine's rules decide what a fall does (the seat's poller does not stop the robot).
    port = Scripted("scripted:ada")
    stage = _seat_stage(port, "rider", "ada")
    executor, seen = _feed(stage, "ada")
    port.chunks = [_reply("rider", "status", 0)]  # 0x00: a Rider that has fallen
    assert stage.seats["ada"]._read_once() is True
    assert _reads(seen) == [(T0, "ada", "status", 0.0)]
    assert not any(isinstance(e, FaultRaised) for e in seen)
    assert executor.state is ExecutorState.IDLE and executor.fault is None


@pytest.mark.parametrize("failure, said", [
    (TransportError("unplugged"), "unplugged"), (OSError(5, "Input/output error"),
                                                 "[Errno 5] Input/output error")])
def test_a_port_that_fails_is_a_fault_at_the_clocks_time_and_ends_the_reading(
    failure: Exception, said: str,
) -> None:
    port = Scripted()
    stage = _seat_stage(port)
    seat, clock = stage.seats["rex"], stage.clock
    assert isinstance(clock, FakeClock)
    executor, seen = _feed(stage)
    clock.advance(1.5)
    port.failure = failure
    assert seat._read_once() is False
    faults = [(e.t, e.performer, e.reason) for e in seen if isinstance(e, FaultRaised)]
    assert faults == [(T0 + 1.5, "rex", f"port scripted:rex: {said}")]
    assert executor.state is ExecutorState.FAILED


def test_a_port_that_fails_while_the_seat_closes_is_no_fault() -> None:
    port = Scripted()
    stage = _seat_stage(port)
    seat = stage.seats["rex"]
    executor, seen = _feed(stage)
    seat._reader_stop.set()  # closing (the port may be closed under the reader)
    port.failure = TransportError("not open")
    assert seat._read_once() is False
    assert seen == [] and executor.state is ExecutorState.IDLE


def test_the_reader_reads_until_the_seat_closes_then_stops(tmp_path: Path) -> None:
    s = Staged(_behaviour(tmp_path))
    s.stage.start()
    try:
        readers = [t for t in threading.enumerate() if "behave reader" in t.name]
        assert len(readers) == 2
        # daemons: a behaviour that dies without closing its seats leaves no thread to wait on
        assert all(t.daemon for t in readers)
        wait_until(lambda: any(e.kind == "read" for e in list(s.seen)), timeout=10.0)
    finally:
        s.stage.close()
    assert not any(t.is_alive() for t in readers)


def test_the_watcher_plays_nothing_on_the_link_its_routines_were_made_for(
    tmp_path: Path,
) -> None:
    b = _behaviour(tmp_path)
    slow = Link(9600, 0.004)
    routines = {name: replace(s, performers=tuple(
        replace(p, link=slow) if p.name == "rex" else p for p in s.performers))
        for name, s in b.routines.items() if name == "one"}  # rex's alone
    stage = PortStage(routines, {}, MODELS, {p: Scripted(f"scripted:{p}") for p in MODELS},
                      clock=FakeClock(T0), events=EventBus())
    assert stage.seats["rex"].idle == PerformerSchedule("rex", "mini", slow, (), 0.0)
    # ada plays in none of them: her model's own link
    assert stage.seats["ada"].idle == PerformerSchedule(
        "ada", "rider", get_profile("rider").link, (), 0.0)


def _one_seat_on_fake_time(tmp_path: Path) -> tuple[PortStage, list[Event], SimTransport]:
    b = _behaviour(tmp_path)
    bus = EventBus()
    seen: list[Event] = []
    bus.subscribe(seen.append)
    link = SimTransport(create_robot("mini"))
    link.open()
    stage = PortStage(b.routines, b.writes, {"rex": "mini"}, {"rex": link},
                      clock=FakeClock(T0), events=bus)
    return stage, seen, link


def test_a_routine_on_a_seat_that_never_watched_plays_from_its_first_frame_and_ends_with_it(
    tmp_path: Path,
) -> None:
    stage, seen, _ = _one_seat_on_fake_time(tmp_path)
    try:
        stage.play("one", ("rex",), 1, 0.0)  # before start(): nothing was cut
        executor = stage.seats["rex"].executor
        assert executor is not None and executor.join(10.0)
        part = next(p for p in stage.routines["one"].performers if p.name == "rex")
        sent = [(e.kind, e.data) for e in seen if isinstance(e, FrameSent) and e.kind != "read"]
        assert sent == [("frame", f.data) for f in part.frames] + _rest("rex")
        # Finished right after its rest, not held to watch (the seat's watcher does that).
        (finished,) = [e for e in seen if isinstance(e, StateChanged)
                       and e.state is ExecutorState.FINISHED]
        assert part.end == pytest.approx(0.4)
        assert T0 + part.end <= finished.t < T0 + part.end + 0.01
    finally:
        stage.close()


def test_every_cut_hands_over_through_the_same_rest_and_posture(tmp_path: Path) -> None:
    s = Staged(_behaviour(tmp_path))
    stage = s.stage
    stage.start()
    try:
        for play_id in (1, 2):
            before = len(s.written("rex"))
            stage.play("long", ("rex",), play_id, 0.0)
            wait_until(lambda n=before: [k for k, _ in s.written("rex")[n:]].count("frame") >= 2,
                       timeout=10.0)
            assert stage.finished("rex") is None  # still playing
        stage.play("one", ("rex",), 3, 0.0)
        executor = stage.seats["rex"].executor
        assert executor is not None and executor.join(10.0)
    finally:
        stage.close()
    kinds = "".join("s" if k == "set" else "f" if k == "frame" else "r"
                    for k, _ in s.written("rex"))
    handover = _rest("rex", "set") + _posture("rex")
    sent = s.written("rex")
    starts = [i for i in range(len(kinds)) if kinds[i] == "s" and (i == 0 or kinds[i - 1] != "s")]
    assert len(starts) == 2  # the two cuts
    for i in starts:
        assert sent[i:i + len(handover)] == handover
        assert sent[i + len(handover)][0] == "frame"  # then the next routine from its start


class Hanging(AlwaysOpen):
    """A port whose writes (``hang_writes``) or reads (``hang_reads``) block until
    ``release`` is set, whatever their timeout."""

    def __init__(self, *, hang_writes: bool = False, hang_reads: bool = False) -> None:
        super().__init__("hanging:rex")
        self.hang_writes, self.hang_reads = hang_writes, hang_reads
        self.release = threading.Event()
        self.blocked = threading.Event()

    def write(self, data: bytes) -> None:
        if self.hang_writes:
            self.blocked.set()
            self.release.wait()

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        if self.hang_reads:
            self.blocked.set()
            self.release.wait()
        else:
            time.sleep(timeout)
        return b""


def _joins(waiter: object) -> list[float | None]:
    """The timeout of every ``waiter.join`` from now on (the join itself still happens)."""
    asked: list[float | None] = []
    real = waiter.join  # type: ignore[attr-defined]

    def join(timeout: float | None = None) -> object:
        asked.append(timeout)
        return real(timeout)

    waiter.join = join  # type: ignore[attr-defined]
    return asked


def _timed(action: object) -> float:
    """Seconds ``action()`` took in a thread (10 s at most: then the test fails)."""
    done: list[float] = []

    def run() -> None:
        begun = time.monotonic()
        action()  # type: ignore[operator]
        done.append(time.monotonic() - begun)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(10.0)
    assert done, "it did not return"
    return done[0]


def test_a_hand_over_waits_at_most_a_second_for_a_writer_stuck_in_the_port(
    tmp_path: Path,
) -> None:
    port = Hanging(hang_writes=True)
    b = _behaviour(tmp_path)
    stage = PortStage(b.routines, b.writes, {"rex": "mini"}, {"rex": port},
                      clock=FakeClock(T0), events=EventBus(), telemetry_interval=0.25)
    try:
        stage.play("long", ("rex",), 1, 0.0)
        assert port.blocked.wait(10.0)
        seat = stage.seats["rex"]
        asked = _joins(seat.executor)
        took = _timed(lambda: seat.end(rest=True))
        assert asked == [1.0] and took >= 1.0  # waited its second, then went on
        assert seat._pending == seat.rest  # the next executor still rests the robot first
    finally:
        port.release.set()
        stage.close()


def test_closing_waits_at_most_a_second_for_a_reader_stuck_in_the_port() -> None:
    port = Hanging(hang_reads=True)
    stage = PortStage({}, {}, {"rex": "mini"}, {"rex": port}, clock=MonotonicClock(),
                      events=EventBus())
    try:
        stage.start()
        assert port.blocked.wait(10.0)
        asked = _joins(stage.seats["rex"]._reader)
        took = _timed(stage.close)
        assert asked == [1.0] and took >= 1.0  # waited its second, then went on
    finally:
        port.release.set()
        stage.close()


class Side:
    """A stand-in for either side of the engine's stage: it records each call as made; as
    the relays' side, it reaches ``hosts`` relays with a lead of ``lead`` seconds."""

    def __init__(self, seats: tuple[str, ...] = (), *, hosts: int = 0, lead: float = 0.0) -> None:
        self.seats = dict.fromkeys(seats)
        self.clock = FakeClock(T0)
        self.calls: list[tuple[object, ...]] = []
        self._hosts, self._lead = hosts, lead

    def hosts(self, performers: tuple[str, ...]) -> int:
        return self._hosts

    def lead(self, performers: tuple[str, ...]) -> float:
        return self._lead

    def __getattr__(self, op: str) -> object:
        if op not in ("play", "rest", "safe_stop", "write"):
            raise AttributeError(op)
        return lambda *args: self.calls.append((op, *args))


def _stages(here: tuple[str, ...], *, hosts: int | None) -> tuple[_Stages, Side, Side | None]:
    local = Side(here)
    remote = None if hosts is None else Side(hosts=hosts, lead=0.25)
    return _Stages(local, remote), local, remote  # type: ignore[arg-type]


@pytest.mark.parametrize("here, hosts, at", [
    (("rex",), 1, T0 + 0.25),  # here and behind a relay: together, after the relay's lead
    ((), 2, T0 + 0.25),  # behind two relays
    ((), 1, None),  # behind one relay alone: as the command arrives
    (("rex",), 0, None),  # here alone, relays elsewhere: at once
])
def test_a_play_on_several_hosts_starts_together_after_the_slowest_relays_lead(
    here: tuple[str, ...], hosts: int, at: float | None,
) -> None:
    stages, local, remote = _stages(here, hosts=hosts)
    stages.play("duo", ("rex", "ada"), 7, 3.0)
    assert remote is not None and remote.calls == [("play", "duo", ("rex", "ada"), 7, 3.0, at)]
    assert local.calls == [("play", "duo", here, 7, 3.0, at)]


def test_the_engines_stage_passes_each_call_to_both_sides_as_made() -> None:
    stages, local, remote = _stages(("rex",), hosts=1)
    stages.rest(("rex", "ada"), 1.0)
    stages.safe_stop(("ada", "rex"), "rule h", 2.0)
    stages.write("h.do[2]", ("rex", "ada"), 3.0)
    assert remote is not None and remote.calls == [
        ("rest", ("rex", "ada"), 1.0), ("safe_stop", ("ada", "rex"), "rule h", 2.0),
        ("write", "h.do[2]", ("rex", "ada"), 3.0)]
    assert local.calls == [("rest", ("rex",), 1.0), ("safe_stop", ("rex",), "rule h", 2.0),
                           ("write", "h.do[2]", ("rex",), 3.0)]
    # No relays: only the seats here, and a play without a start time.
    alone, here, _ = _stages(("rex",), hosts=None)
    alone.play("duo", ("rex", "ada"), 4, 5.0)
    alone.rest(("ada",), 6.0)
    assert here.calls == [("play", "duo", ("rex",), 4, 5.0), ("rest", (), 6.0)]


class Inbox(queue.SimpleQueue[tuple[str, object]]):
    """The runner's queue, noting how long each wait for an input may last."""

    def __init__(self) -> None:
        super().__init__()
        self.waits: list[float | None] = []

    def get(self, block: bool = True, timeout: float | None = None) -> tuple[str, object]:
        self.waits.append(timeout)
        return super().get(block, timeout)


Running = tuple[BehaviourRunner, FakeClock, Inbox, list[tuple[float, str]], threading.Thread,
                list[BaseException]]


def _runner_on_fake_time(tmp_path: Path, rules: str, duration: float | None,
                         extra: str = "triggers: [go]\n") -> Running:
    from tests.behave.test_behave_ports_logic import _running

    clock = FakeClock(T0)
    said: list[tuple[float, str]] = []
    runner = BehaviourRunner(_behaviour(tmp_path, rules, extra), {}, clock=clock,
                             say=lambda t, line: said.append((t, line)))
    inbox = Inbox()
    runner._inbox = inbox
    thread, errors = _running(runner, duration)
    wait_until(lambda: inbox.waits != [], timeout=10.0)  # started, at T0
    return runner, clock, inbox, said, thread, errors


def test_the_runner_waits_until_the_next_deadline_on_its_clock_and_ends_at_its_end(
    tmp_path: Path,
) -> None:
    runner, clock, inbox, said, thread, errors = _runner_on_fake_time(tmp_path, """\
        - {name: tick, mode: parallel, when: [{every: 0.25}], do: [{publish: tick}]}
        - {name: g, mode: parallel, when: [{trigger: go}], do: [{publish: went}]}
        - {name: fall, mode: parallel, when: [{tilt_beyond: 60, performers: [rex]}],
           do: [{publish: fell}]}
        - {name: low, mode: parallel, when: [{battery_below: 60, performers: [rex]}],
           do: [{publish: low}]}
        """, 2.0)
    try:
        assert inbox.waits[0] == 0.25  # the tick's deadline, before the end (2 s)
        clock.advance(0.125)
        wait_until(lambda: 0.125 in inbox.waits, timeout=10.0)
        clock.advance(0.125)
        wait_until(lambda: said != [], timeout=10.0)
        assert said == [(T0 + 0.25, "rule tick: fired: every 0.25 s"),
                        (T0 + 0.25, "rule tick: published: tick")]
        # Inputs are handled at the runner's clock's time.
        clock.advance(0.0625)
        runner.trigger("go")
        runner.events.publish(TelemetryRead(T0 + 0.3, "rex", "battery", 50.0))
        runner.events.publish(FaultRaised(T0 + 0.3, "rex", "mini reports status (fallen)"))
        runner.events.publish(StateChanged(T0 + 0.3, "rex", ExecutorState.RUNNING, 0.3))
        wait_until(lambda: len(said) == 8, timeout=10.0)
        assert said[2:] == [
            (T0 + 0.3125, "rule g: fired: trigger go"), (T0 + 0.3125, "rule g: published: went"),
            (T0 + 0.3, "rule low: fired: rex battery 50% < 60%"),
            (T0 + 0.3, "rule low: published: low"),
            (T0 + 0.3, "rule fall: fired: rex tilted 90 deg > 60"),
            (T0 + 0.3, "rule fall: published: fell")]
        # The end, exactly: the runner stops there (the next tick is not before it).
        clock.advance(2.0 - 0.3125)
        thread.join(10.0)
        assert not thread.is_alive() and errors == []
    finally:
        runner.stop()
        thread.join(10.0)
    # every tick at its own time (those the jump to the end passed too, if the runner saw
    # them before its end)
    ticks = [t for t, line in said if "fired: every" in line]
    assert ticks == [T0 + 0.25 * (k + 1) for k in range(len(ticks))]
    assert all(w is not None and 0.0 <= w <= 0.5 for w in inbox.waits)


def test_without_deadlines_the_runner_looks_at_its_clock_every_half_second(
    tmp_path: Path,
) -> None:
    ahead = (dt.datetime.now() + dt.timedelta(hours=1)).strftime("%H:%M:%S")
    runner, _, inbox, said, thread, errors = _runner_on_fake_time(tmp_path, f"""\
        - {{name: hour, when: [{{at: "{ahead}"}}], do: [{{publish: hour}}]}}
        """, None, "")
    try:
        wait_until(lambda: len(inbox.waits) >= 2, timeout=10.0)
        # An hour ahead on the wall clock is an hour ahead on the runner's clock.
        deadline = runner.engine.next_deadline()
        assert deadline is not None and abs(deadline - (T0 + 3600.0)) <= 2.0
        assert set(inbox.waits) == {0.5}
    finally:
        runner.stop()
        thread.join(10.0)
    assert not thread.is_alive() and errors == []
    assert said == []
