"""The behaviour's stage over ports (behave/ports.py) in this process, on simulated robots
behind in-process transports (no pty) on the real clock, with routines of half a second or so:
what each seat writes and in which order (a routine's frames, the rest and the default posture
before a routine that pre-empts another, frames written beside, a safe stop), which play has
finished, one reader a port across executors, a start time given, and the runner's inputs
(triggers, routine ends, stop). Nothing here is timed: each test waits for what it checks.
test_behave_ports.py plays the same on ptys in real time; this file is what behave/ports.py's
mutation run measures."""

from __future__ import annotations

import datetime as dt
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.behave.conftest import write_behaviour
from tests.conftest import wait_until
from xgo_show.behave import load_behaviour
from xgo_show.behave.engine import BehaviourNote
from xgo_show.behave.loader import Behaviour
from xgo_show.behave.ports import WATCH_INTERVAL, BehaviourRunner, PortStage
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import Event, EventBus, FaultRaised, FrameSent, SafeStopped
from xgo_show.runtime.safety import rest_frames, stop_frames
from xgo_show.sim import create_robot
from xgo_show.transports.sim import SimTransport

ROUTINES = {"one": {"rex": 0.4}, "duo": {"rex": 0.4, "ada": 0.6}, "long": {"rex": 5.0},
            "aside": {"ada": 0.6}}
MODELS = {"rex": "mini", "ada": "rider"}


def _behaviour(tmp_path: Path, rules: str = "- {name: g, when: [{trigger: go}], "
               "do: [{play: one}, {set: {pace: slow}, performers: [rex]}]}\n",
               extra: str = "triggers: [go]\n") -> Behaviour:
    return load_behaviour(write_behaviour(tmp_path, ROUTINES, rules, extra))


def _links() -> dict[str, SimTransport]:
    links = {p: SimTransport(create_robot(m)) for p, m in MODELS.items()}
    for link in links.values():
        link.open()
    return links


class Staged:
    """A PortStage of rex and ada on simulated robots, every frame written noted."""

    def __init__(self, b: Behaviour, **options: object) -> None:
        self.behaviour = b
        self.events = EventBus()
        self.seen: list[FrameSent] = []
        self.events.subscribe(self.seen.append, FrameSent)  # type: ignore[arg-type]
        self.stopped: list[SafeStopped] = []
        self.events.subscribe(self.stopped.append, SafeStopped)  # type: ignore[arg-type]
        self.links = _links()
        self.stage = PortStage(b.routines, b.writes, MODELS, self.links,
                               clock=MonotonicClock(), events=self.events, **options)  # type: ignore[arg-type]

    def written(self, performer: str, *, reads: bool = False) -> list[tuple[str, bytes]]:
        """(kind, data) of each frame written to ``performer`` (telemetry reads left out)."""
        return [(e.kind, e.data) for e in list(self.seen)
                if e.performer == performer and (reads or e.kind != "read")]

    def frames(self, routine: str, performer: str) -> list[tuple[str, bytes]]:
        part = next(p for p in self.behaviour.routines[routine].performers
                    if p.name == performer)
        return [("frame", f.data) for f in part.frames]


@pytest.fixture
def staged(tmp_path: Path) -> Iterator[Staged]:
    s = Staged(_behaviour(tmp_path))
    s.stage.start()
    try:
        yield s
    finally:
        s.stage.close()


def _rest(performer: str, kind: str = "rest") -> list[tuple[str, bytes]]:
    """The rest frames: ``rest`` at a routine's end, ``set`` when the next executor sends
    them first (a routine cut)."""
    return [(kind, f.data) for f in rest_frames(get_profile(MODELS[performer]))]


def _posture(performer: str) -> list[tuple[str, bytes]]:
    profile = get_profile(MODELS[performer])
    return [("set", f.data) for f in stop_frames(profile)[len(rest_frames(profile)):]]


def test_each_seat_watches_from_the_start_with_one_reader(staged: Staged) -> None:
    seats = staged.stage.seats
    assert set(seats) == {"rex", "ada"}
    for name, seat in seats.items():
        assert seat.routine is None and seat.executor is not None
        assert seat.executor.schedule.frames == ()
        assert seat.transport is staged.links[name]
    readers = sorted(t.name for t in threading.enumerate() if "behave reader" in t.name)
    assert readers == ["xgo-show behave reader ada", "xgo-show behave reader rex"]
    # Telemetry is read while watching: requests go out and readings come back.
    wait_until(lambda: any(e.kind == "read" for e in list(staged.seen)), timeout=10.0)
    assert staged.stage.finished("rex") is None  # watching: no routine finished


def test_a_routine_plays_on_its_performers_then_is_finished_once(staged: Staged) -> None:
    stage = staged.stage
    stage.play("duo", ("rex",), 3, 0.0)
    seat = stage.seats["rex"]
    assert seat.routine == "duo" and seat.play_id == 3
    assert stage.seats["ada"].routine is None  # ada was not asked
    executor = seat.executor
    assert executor is not None
    assert executor.join(5.0)
    assert staged.written("rex") == staged.frames("duo", "rex") + _rest("rex")
    assert staged.written("ada") == []
    assert stage.finished("ada") is None  # watching
    assert stage.finished("rex") == 3
    assert seat.routine is None and seat.executor is not executor  # watching again
    assert stage.finished("rex") is None  # once


def test_a_routine_pre_empted_hands_over_through_rest_and_default_posture(
    staged: Staged,
) -> None:
    stage = staged.stage
    stage.play("long", ("rex",), 1, 0.0)
    wait_until(lambda: len(staged.written("rex")) >= 3, timeout=10.0)
    stage.play("one", ("rex",), 2, 0.5)
    seat = stage.seats["rex"]
    assert (seat.routine, seat.play_id) == ("one", 2)
    assert seat.executor is not None and seat.executor.join(5.0)
    sent = staged.written("rex")
    cut = next(i for i, (kind, _) in enumerate(sent) if kind != "frame")
    # Cut mid-move: the next executor's first frames rest the robot (speeds to neutral) and
    # bring it to its default posture, then the routine from its first frame.
    assert sent[cut:] == (_rest("rex", "set") + _posture("rex") + staged.frames("one", "rex")
                          + _rest("rex"))


def test_a_rest_ends_the_routine_through_the_rest_posture_and_watches(staged: Staged) -> None:
    stage = staged.stage
    stage.play("long", ("rex",), 1, 0.0)
    wait_until(lambda: len(staged.written("rex")) >= 3, timeout=10.0)
    stage.rest(("rex",), 0.5)
    seat = stage.seats["rex"]
    assert seat.routine is None and seat.executor is not None
    wait_until(lambda: staged.written("rex")[-3:] == _rest("rex", "set"), timeout=10.0)
    sent = staged.written("rex")
    cut = next(i for i, (kind, _) in enumerate(sent) if kind != "frame")
    assert sent[cut:] == _rest("rex", "set")  # by the watcher; then telemetry reads alone
    assert stage.finished("rex") is None


def test_a_safe_stop_sends_the_stop_then_watches(staged: Staged) -> None:
    stage = staged.stage
    stage.play("long", ("rex",), 1, 0.0)
    wait_until(lambda: len(staged.written("rex")) >= 3, timeout=10.0)
    stage.safe_stop(("rex",), "rule fall", 0.5)
    seat = stage.seats["rex"]
    assert seat.routine is None and seat.executor is not None
    sent = staged.written("rex")
    cut = next(i for i, (kind, _) in enumerate(sent) if kind != "frame")
    profile = get_profile("mini")
    assert sent[cut:] == [("stop", f.data) for f in stop_frames(profile)]
    assert [e.result.reason for e in staged.stopped] == ["rule fall"]


def test_writes_go_beside_what_plays_or_before_what_comes_next(staged: Staged) -> None:
    stage = staged.stage
    pace = [("set", f.data) for f in staged.behaviour.writes["g.do[1]"].performers[0].frames]
    stage.write("g.do[1]", ("rex",), 0.0)  # beside the watcher
    wait_until(lambda: staged.written("rex") == pace, timeout=10.0)
    stage.write("g.do[1]", ("ada",), 0.0)  # not ada's: the write is rex's alone
    stage.play("long", ("rex",), 1, 0.0)
    wait_until(lambda: len(staged.written("rex")) >= 4, timeout=10.0)
    stage.write("g.do[1]", ("rex",), 0.2)  # beside the routine
    wait_until(lambda: staged.written("rex").count(pace[0]) == 2, timeout=10.0)
    assert staged.written("ada") == []
    # Between two executors (none writing), frames wait for the next one's start.
    seat = stage.seats["rex"]
    seat.end(rest=True)  # the routine cut: its rest waits for the next executor
    seat.send([(data, "pace") for _, data in pace])
    assert seat._pending == [(f.data, f.label) for f in rest_frames(get_profile("mini"))] + [
        (data, "pace") for _, data in pace]
    seat.watch()
    wait_until(lambda: staged.written("rex").count(pace[0]) == 3, timeout=10.0)
    assert staged.written("rex")[-4:] == _rest("rex", "set") + pace
    assert seat._pending == []


def test_a_routine_given_a_start_time_starts_then(tmp_path: Path) -> None:
    s = Staged(_behaviour(tmp_path))
    s.stage.start()
    try:
        at = s.stage.clock.now() + 0.3
        s.stage.play("one", ("rex",), 1, 0.0, at=at)
        wait_until(lambda: any(k == "frame" for k, _ in s.written("rex")), timeout=10.0)
        first = next(e for e in s.seen if e.kind == "frame")
        assert first.t >= at and first.planned == pytest.approx(at, abs=1e-9)
        # A time already past: now.
        before = s.stage.clock.now()
        s.stage.play("one", ("rex",), 2, 0.0, at=before - 10.0)
        executor = s.stage.seats["rex"].executor
        assert executor is not None and executor.join(5.0)
        second = [e for e in s.seen if e.kind == "frame" and e.index == 0][-1]
        assert second.planned is not None and second.planned >= before
    finally:
        s.stage.close()


def test_telemetry_rates_reach_the_seats_poller(tmp_path: Path) -> None:
    s = Staged(_behaviour(tmp_path), telemetry_interval=0.5, watch_interval=None)
    seat = s.stage.seats["rex"]
    assert seat.poller.interval == 0.5
    assert seat.poller.watch == {}
    t = Staged(_behaviour(tmp_path))
    assert t.stage.seats["rex"].poller.interval == 0.25
    assert t.stage.seats["rex"].poller.watch == {"status": WATCH_INTERVAL,
                                                 "attitude": WATCH_INTERVAL}
    assert WATCH_INTERVAL == 0.02


def test_close_ends_every_executor_and_reader(tmp_path: Path) -> None:
    s = Staged(_behaviour(tmp_path))
    s.stage.start()
    s.stage.play("long", ("rex",), 1, 0.0)
    executors = [seat.executor for seat in s.stage.seats.values()]
    s.stage.close()
    assert all(e is not None and e.join(0.0) for e in executors)
    assert all(seat.executor is None for seat in s.stage.seats.values())
    assert not any("behave reader" in t.name for t in threading.enumerate())


def test_the_runner_plays_on_triggers_and_routine_ends_and_stops_safely(
    tmp_path: Path,
) -> None:
    b = _behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        - {name: e, when: [{routine_ended: duo, performers: [ada]}], do: [{publish: done}]}
        - {name: low, when: [{battery_below: 60, performers: [rex]}], do: [{publish: low}]}
        """)
    bus = EventBus()
    notes: list[str] = []
    said: list[str] = []

    def note(e: Event) -> None:
        if isinstance(e, BehaviourNote):
            notes.append(f"{e.rule} {e.kind}: {e.text}")

    bus.subscribe(note)
    links = _links()
    links["rex"] = SimTransport(create_robot("mini", battery=50.0))
    links["rex"].open()
    runner = BehaviourRunner(b, links, events=bus, say=lambda t, line: said.append(line))
    thread = threading.Thread(target=runner.run, kwargs={"duration": 20.0})
    thread.start()
    try:
        runner.trigger("go")
        wait_until(lambda: "e published: done" in notes, timeout=10.0)
        # the robots' telemetry reaches the engine (rex's battery is at 50 %)
        wait_until(lambda: "low published: low" in notes, timeout=10.0)
        assert runner.stage.seats["rex"].poller.interval == 0.25  # the runner's defaults
        assert runner.stage.seats["rex"].poller.watch == {"status": WATCH_INTERVAL,
                                                          "attitude": WATCH_INTERVAL}
    finally:
        runner.stop()
        thread.join(10.0)
    assert not thread.is_alive()
    assert [n for n in notes if not n.startswith("low ")] == [
        "g fired: trigger go", "g action: rex, ada plays duo", "e fired: duo ended on ada",
        "e published: done"]
    assert said == [f"rule {n.split(' ', 1)[0]}: {n.split(' ', 1)[1]}" for n in notes]
    assert all(seat.executor is None for seat in runner.stage.seats.values())
    # The robots were stopped safely at the end, and the port is read by no one.
    assert not any("behave reader" in t.name for t in threading.enumerate())


def test_the_runner_plays_here_and_behind_a_relay_together(tmp_path: Path) -> None:
    # rex on a port here, ada behind relay yard (over a recording session, no Zenoh).
    from tests.behave.relays import AHEAD, Relays
    from tests.relay.recording import RecordingSession
    from xgo_show.behave.relayed import RelayAccess
    from xgo_show.net import messages as msg

    b = _behaviour(tmp_path, """\
        - {name: g, when: [{trigger: go}], do: [{play: duo}]}
        - {name: e, when: [{routine_ended: duo, performers: [ada]}], do: [{publish: done}]}
        - {name: f, when: [{routine_ended: duo, performers: [rex]}], do: [{publish: here}]}
        - {name: a, when: [{trigger: aside}], do: [{play: aside}]}
        - {name: h, mode: parallel, when: [{trigger: hush}],
           do: [{stop: [rex, ada]}, {safe_stop: [ada, rex]}, {set: {body_z: 95}}]}
        """, "triggers: [go, hush, aside]\n")
    relays = Relays()
    session = RecordingSession(relays)
    access = RelayAccess({"ada": "zenoh:yard/rio"}, session,  # type: ignore[arg-type]
                         msg.Conductor("c1", "alice"), namespace="ns", watchdog=5.0,
                         timeout=1.0)
    bus = EventBus()
    notes: list[str] = []
    times: list[object] = []

    def note(e: Event) -> None:
        if isinstance(e, BehaviourNote):
            notes.append(f"{e.rule} {e.kind}: {e.text}")
            times.append(e.t)

    bus.subscribe(note)
    links = _links()
    runner = BehaviourRunner(b, {"rex": links["rex"]}, events=bus, relays=access,
                             telemetry_interval=0.5, watch_interval=0.05)
    frames: list[FrameSent] = []
    bus.subscribe(frames.append, FrameSent)  # type: ignore[arg-type]
    stopped: list[SafeStopped] = []
    bus.subscribe(stopped.append, SafeStopped)  # type: ignore[arg-type]
    faults: list[FaultRaised] = []
    bus.subscribe(faults.append, FaultRaised)  # type: ignore[arg-type]

    def sent(op: str) -> list[dict[str, object]]:
        return [q.request for q in list(session.queries) if q.payload and q.op == op]

    thread, errors = _running(runner, 60.0)
    try:
        wait_until(lambda: sent("stage_open") != [], timeout=10.0)
        (opened,) = sent("stage_open")
        assert {k: opened[k] for k in ("robots", "watch", "telemetry", "watchdog_ms")} == {
            "robots": ["rio"], "watch": 0.05, "telemetry": 0.5, "watchdog_ms": 5000}
        assert opened["conductor"] == {"id": "c1", "name": "alice"}
        seat = runner.stage.seats["rex"]  # the same rates here
        assert (seat.poller.interval, seat.poller.watch) == (
            0.5, {"status": 0.05, "attitude": 0.05})
        assert {q.key for q in session.queries} == {"ns/relay/yard/cmd"}
        assert round(session.of("hello")[0].timeout) == 1
        remote = runner.remote
        assert remote is not None
        asked = runner.clock.now()
        runner.trigger("go")
        wait_until(lambda: sent("stage_play") != [] and any(
            f.kind == "frame" and f.performer == "rex" for f in list(frames)), timeout=10.0)
        (play,) = sent("stage_play")
        first = next(f for f in frames if f.kind == "frame" and f.performer == "rex")
        # One start for both hosts, a lead after the trigger; the relay's on its own clock.
        assert first.planned is not None and first.planned >= asked + 0.002
        # (the relay's clock offset as its answers show it, to within their round trip)
        assert play["at"] == pytest.approx(first.planned + AHEAD["yard"], abs=0.05)
        assert play["robots"] == ["rio"]
        assert play["sha256"] == remote.relays["yard"].hashes["duo"]
        with relays.lock:
            relays.status["yard"] = {"stage": {"ended": [["rio", play["play"]]]},
                                     "events": [["x", "rio", "fell", 1.0]]}
        wait_until(lambda: "e published: done" in notes, timeout=10.0)
        wait_until(lambda: "f published: here" in notes, timeout=10.0)  # rex's part, here
        # the relay's events on the runner's bus, at this clock's time
        assert [(e.performer, e.reason) for e in list(faults)] == [("ada", "fell")]
        # On the relay alone: one host, so no start time: it plays as the command arrives.
        runner.trigger("aside")
        wait_until(lambda: len(sent("stage_play")) == 2, timeout=10.0)
        assert sent("stage_play")[1]["at"] is None
        assert sent("stage_play")[1]["sha256"] == remote.relays["yard"].hashes["aside"]
        relays.refuse[("yard", "stage_rest")] = "not now"
        runner.trigger("hush")
        wait_until(lambda: sent("stage_write") != [], timeout=10.0)
        wait_until(lambda: len(faults) == 2, timeout=10.0)
        assert (faults[1].performer, faults[1].reason) == (
            "ada", "stage_rest: relay yard: not now")
        assert 0.0 <= runner.clock.now() - faults[1].t < 10.0
        assert sent("stage_write")[0]["sha256"] == remote.relays["yard"].hashes["h.do[2]"]
        body_z = next(p for p in b.writes["h.do[2]"].performers if p.name == "rex").frames[0].data
        wait_until(lambda: any(f.kind == "set" and f.performer == "rex" and f.data == body_z
                               for f in list(frames)), timeout=10.0)
        staged = [(r["op"], r["robots"]) for r in (q.request for q in list(session.queries))
                  if r["op"] in ("stage_rest", "stage_stop", "stage_write")]
        assert staged == [("stage_rest", ["rio"]), ("stage_stop", ["rio"]),
                          ("stage_write", ["rio"])]
        assert sent("stage_stop")[0]["reason"] == "rule h"
        # and here: rex's seat stopped too
        wait_until(lambda: "stop" in [f.kind for f in list(frames) if f.performer == "rex"],
                   timeout=10.0)
        wall = runner._wall(runner.clock.now() + 60.0)
        assert abs((wall - dt.datetime.now()).total_seconds() - 60.0) < 5.0
        stops = len(sent("stage_stop"))
    finally:
        runner.stop()
        thread.join(20.0)
    assert not thread.is_alive() and errors == []
    assert all(isinstance(t, float) for t in times)  # every decision at a clock time
    # At the end: the relay's robots stopped and the relay released; rex stopped here.
    assert [r["reason"] for r in sent("stage_stop")[stops:]] == ["behaviour ended"]
    assert sent("release") != []
    assert [e.result.reason for e in stopped] == ["rule h", "behaviour ended"]


def test_a_relay_lost_takes_its_performers_offline_at_once(tmp_path: Path) -> None:
    from tests.behave.relays import Relays
    from tests.relay.recording import RecordingSession
    from xgo_show.behave.relayed import RelayAccess
    from xgo_show.net import messages as msg

    b = _behaviour(tmp_path, """\
        - {name: gone, when: [{offline: 30, performers: [ada]}], do: [{publish: lost}]}
        """, "")
    session = RecordingSession(Relays())
    access = RelayAccess({"ada": "zenoh:yard/rio"}, session,  # type: ignore[arg-type]
                         msg.Conductor("c1", "alice"), namespace="ns", watchdog=5.0,
                         timeout=1.0)
    said: list[str] = []
    times: list[object] = []
    runner = BehaviourRunner(b, {}, relays=access,
                             say=lambda t, line: (said.append(line), times.append(t)))
    thread, errors = _running(runner, 60.0)
    try:
        wait_until(lambda: session.of("stage_open") != [], timeout=10.0)
        remote = runner.remote
        assert remote is not None
        # as the relay's heartbeats' watchdog says it
        remote._on_lost("yard", remote.relays["yard"], 5.0)
        wait_until(lambda: "rule gone: published: lost" in said, timeout=10.0)
    finally:
        runner.stop()
        thread.join(20.0)
    assert not thread.is_alive() and errors == []
    assert said == ["rule gone: fired: ada offline (relay yard lost: no answer for 5000 ms "
                    "(watchdog 5000 ms); it safe-stops its robots)", "rule gone: published: lost"]
    assert all(isinstance(t, float) for t in times)


def _running(runner: BehaviourRunner, duration: float | None) -> tuple[threading.Thread,
                                                                      list[BaseException]]:
    """``runner.run(duration)`` in a thread; what it raised, if anything, collected."""
    errors: list[BaseException] = []

    def run() -> None:
        try:
            runner.run(duration)
        except BaseException as exc:  # the test says what went wrong
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    return thread, errors


def test_the_runner_ends_after_its_duration_acting_on_its_timers_on_the_way(
    tmp_path: Path,
) -> None:
    # No port here: nothing but the engine's own timers wakes the runner.
    b = _behaviour(tmp_path, """\
        - {name: up, when: [{startup: true}], do: [{publish: up}]}
        - {name: tick, mode: parallel, when: [{every: 0.1}], do: [{publish: tick}]}
        - {name: gone, when: [{offline: 100}], do: [{publish: gone}]}
        """, "")
    notes: list[tuple[float, str]] = []
    runner = BehaviourRunner(b, {}, say=lambda t, line: notes.append((t, line)))
    begun = time.monotonic()
    thread, errors = _running(runner, 0.5)
    thread.join(10.0)
    assert not thread.is_alive() and errors == []
    assert time.monotonic() - begun >= 0.5
    start = notes[0][0]
    assert notes[:2] == [(start, "rule up: fired: start-up"), (start, "rule up: published: up")]
    ticks = [t - start for t, line in notes if line == "rule tick: fired: every 0.1 s"]
    # each at its own time, however late the runner woke for it (none after the end)
    assert 1 <= len(ticks) <= 5
    assert ticks == pytest.approx([0.1 * (k + 1) for k in range(len(ticks))], abs=1e-9)


def test_the_runner_waits_for_inputs_as_long_as_needed_and_stops_on_request(
    tmp_path: Path,
) -> None:
    b = _behaviour(tmp_path, """\
        - {name: g, mode: parallel, when: [{trigger: go}], do: [{publish: went}]}
        """)
    said: list[tuple[float, str]] = []
    runner = BehaviourRunner(b, {}, say=lambda t, line: said.append((t, line)))
    thread, errors = _running(runner, None)  # no deadline and no end: it waits for inputs
    try:
        time.sleep(0.7)
        sent = runner.clock.now()
        runner.trigger("go")
        wait_until(lambda: (said[-1:] or [(0, "")])[0][1] == "rule g: published: went",
                   timeout=10.0)
    finally:
        runner.stop()
        thread.join(10.0)
    assert not thread.is_alive() and errors == []
    assert [line for _, line in said] == ["rule g: fired: trigger go", "rule g: published: went"]
    assert said[0][0] == said[1][0] and 0.0 <= said[0][0] - sent < 5.0  # when it arrived


def test_a_port_that_cannot_be_read_is_a_fault_of_its_performer(tmp_path: Path) -> None:
    from xgo_show.errors import TransportError
    from xgo_show.runtime.events import FaultRaised

    class Breaking(SimTransport):
        broken = False

        def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
            if self.broken:
                raise TransportError("unplugged")
            return super().read(size, timeout)

    s = Staged(_behaviour(tmp_path))
    faults: list[FaultRaised] = []
    s.events.subscribe(faults.append, FaultRaised)  # type: ignore[arg-type]
    link = Breaking(create_robot("mini"), url="sim:rex")
    link.open()
    s.stage.seats["rex"].transport = link
    s.stage.start()
    try:
        wait_until(lambda: any(e.kind == "read" and e.performer == "rex" for e in list(s.seen)),
                   timeout=10.0)
        link.broken = True
        wait_until(lambda: faults != [], timeout=10.0)
        assert [(e.performer, e.reason) for e in faults] == [("rex", "port sim:rex: unplugged")]
        wait_until(lambda: not any(t.name == "xgo-show behave reader rex"
                                   for t in threading.enumerate()), timeout=10.0)
    finally:
        s.stage.close()
