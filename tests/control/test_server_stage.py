"""``serve``'s server (control/server.py) with shows on stand-in robots (tests/control/staging.py)
over the recording session: the real launch, show runner and director, robots that play
nothing, so a start, a hold, a release and a stop take milliseconds. What a start arms and with
what, where and when it starts, what each stage's refusal leaves behind (nothing armed, every
port closed), what a show's end leaves (its last result, its line, every port closed), what a
stop, a panic and a close answer, the status while a show starts, holds and plays, and the run
log's trigger times. ``scripts/mutation.sh`` runs server.py against these (fast) tests."""

from __future__ import annotations

import dataclasses
import json
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from tests.conftest import wait_until as _wait_until
from tests.control.conftest import ROUTINE
from tests.control.serving import Serve, refusal
from tests.control.staging import Stage
from tests.relay.recording import RecordingSession
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.control import server as server_module
from xgo_show.control.protocol import PROTOCOL_VERSION
from xgo_show.errors import XgoShowError
from xgo_show.runtime.events import FrameSent, StateChanged
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.realtime import HELPER_PRIORITY
from xgo_show.runtime.show_runner import ShowResult
from xgo_show.timecode.osc import Command

STANDS = {"rex": "stand:rex", "ivy": "stand:ivy"}


def wait_until(predicate: Callable[[], object], timeout: float = 10.0) -> None:
    """Wait for what another thread does (generous: a loaded machine is slow)."""
    _wait_until(predicate, timeout)
S = ExecutorState


def serving(schedule: Schedule, **opts: Any) -> Serve:
    """A server (stand-in robots for rex and ivy unless ``maps`` says otherwise) with
    ``schedule`` loaded."""
    s = Serve(**{"sim": False, "maps": dict(STANDS), **opts})
    assert s.ask("load", schedule=schedule_to_bytes(schedule).decode())["ok"]
    return s


@pytest.fixture
def server(stage: Stage, triggered_schedule: Schedule) -> Iterator[Serve]:
    """A server whose two performers are stand-ins, the triggered show loaded."""
    s = serving(triggered_schedule)
    yield s
    s.close()


def started(stage: Stage) -> None:
    """Every stand-in robot has been started."""
    wait_until(lambda: len(stage.performers) == 2 and all(
        any(c[0] == "start" for c in p.calls) for p in stage.performers.values()))


def state(s: Serve) -> str:
    return str(s.server.status()["state"])


def ended(s: Serve) -> dict[str, Any]:
    """The last result, once the show's thread has said it: the result is in the status a
    moment before its "ended" line is said, so both are waited for."""
    wait_until(lambda: s.server.status()["last_result"] is not None
               and any(line.startswith("show ") and " ended: " in line for line in s.said))
    last: dict[str, Any] = s.server.status()["last_result"]
    return last


def held_at_b(s: Serve) -> None:
    assert s.ask("start", section="b")["ok"]
    wait_until(lambda: state(s) == "waiting")


# --- a show played ---------------------------------------------------------------------------

def test_a_show_started_at_a_wait_holds_there_and_its_trigger_releases_it(
    server: Serve, stage: Stage
) -> None:
    held_at_b(server)
    status = server.server.status()
    assert status["waiting_for"] == {"section": "b", "trigger": "go", "timeout": None}
    assert status["next_wait"] == {"section": "b", "trigger": "go"}
    assert status["show_time"] == 0.6 and status["section"] == "b"
    assert status["duration"] == 2.3 and status["faults"] == {}
    assert {n: r["state"] for n, r in status["robots"].items()} == {
        "rex": "paused", "ivy": "paused"}
    got = server.trigger("go", b'{"source": "desk", "data": {"n": 1}}').answer()
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "trigger", "trigger": "go",
                   "section": "b", "held": True}
    wait_until(lambda: state(server) == "playing")
    status = server.server.status()
    assert status["waiting_for"] is None
    assert status["next_wait"] == {"section": "c", "trigger": "encore"}
    wait_until(lambda: [e for e in server.events("trigger") if e["accepted"]])
    (event,) = [e for e in server.events("trigger") if e["accepted"]]
    assert (event["trigger"], event["section"], event["held"], event["source"],
            event["data"]) == ("go", "b", True, "desk", {"n": 1})
    counters = server.server.counters
    assert (counters["triggers"], counters["accepted"], counters["refused"]) == (1, 1, 0)
    got = server.ask("stop", reason="enough")
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "stop", "state": "ended",
                   "reason": "enough", "stops": {"rex": {"ok": True, "error": ""},
                                                 "ivy": {"ok": True, "error": ""}}}
    assert [c for c in stage.p("rex").calls if c[0] == "safe_stop"] == [
        ("safe_stop", "enough", 0.1)]


def test_a_show_that_ends_leaves_its_result_its_line_and_no_port_open(
    server: Serve, stage: Stage
) -> None:
    before = time.time()
    assert server.ask("start")["ok"]
    started(stage)
    for p in stage.performers.values():
        p.finish()
    last = ended(server)
    assert last == {"show": "Triggered test", "completed": True, "reason": "completed",
                    "faults": {}, "time": last["time"]}
    assert before <= last["time"] <= time.time() and last["time"] == round(last["time"], 6)
    assert server.said[-1] == "show 'Triggered test' ended: completed"
    assert stage.closed == [("rex", "ivy")]
    assert all(("close",) in p.calls for p in stage.performers.values())
    assert state(server) == "loaded" and "robots" not in server.server.status()
    assert not [t for t in threading.enumerate() if t.name in ("xgo-show show",
                                                                "xgo-show director")]
    assert server.ask("start")["ok"]  # and another can start
    server.ask("stop")


def test_a_fault_is_in_the_status_and_in_the_last_result(server: Serve, stage: Stage) -> None:
    held_at_b(server)
    stage.p("rex").fault = "port lost"
    status = server.server.status()
    assert status["faults"] == {"rex": "port lost"}
    assert status["robots"]["rex"]["fault"] == "port lost" and not status["robots"]["ivy"].get(
        "fault")
    stage.p("rex").fail("port lost")
    last = ended(server)
    assert last["completed"] is False and last["faults"] == {"rex": "port lost"}
    assert last["reason"] == "fault on rex: port lost"


def test_a_show_that_raises_is_ended_as_an_exception_and_closed(
    server: Serve, stage: Stage, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("no show today")

    monkeypatch.setattr(server_module.Launch, "run", broken)
    assert server.ask("start")["ok"]
    last = ended(server)
    assert (last["completed"], last["reason"]) == (
        False, "exception: RuntimeError('no show today')")
    assert stage.closed == [("rex", "ivy")]
    assert server.said[-1] == (
        "show 'Triggered test' ended: exception: RuntimeError('no show today')")


def test_a_show_plays_with_zenohs_receiving_threads_raised_and_lowers_them_after(
    server: Serve, stage: Stage, monkeypatch: pytest.MonkeyPatch
) -> None:
    asked: list[str] = []
    raised: list[tuple[int, int]] = []
    lowered: list[int] = []

    def named(prefix: str) -> list[int]:
        asked.append(prefix)
        return [11, 12]

    def raise_thread(tid: int, priority: int) -> bool:
        raised.append((tid, priority))
        return tid != 12  # not permitted for this one

    monkeypatch.setattr(server_module, "threads_named", named)
    monkeypatch.setattr(server_module, "raise_thread", raise_thread)
    monkeypatch.setattr(server_module, "lower_thread", lowered.append)

    class Osc:
        native_id = 13

        def close(self) -> None:
            pass

    server.server.osc = Osc()  # type: ignore[assignment]
    held_at_b(server)
    assert asked == ["rx-"] and raised == [(11, HELPER_PRIORITY), (12, HELPER_PRIORITY),
                                           (13, HELPER_PRIORITY)]
    assert lowered == []
    server.ask("stop")
    ended(server)
    assert lowered == [11, 13]


def test_an_osc_server_without_its_thread_yet_raises_only_zenohs(
    server: Serve, monkeypatch: pytest.MonkeyPatch
) -> None:
    raised: list[int] = []
    monkeypatch.setattr(server_module, "threads_named", lambda prefix: [11])
    monkeypatch.setattr(server_module, "raise_thread",
                        lambda tid, priority: raised.append(tid) or True)
    monkeypatch.setattr(server_module, "lower_thread", lambda tid: None)

    class Osc:
        native_id = None

        def close(self) -> None:
            pass

    server.server.osc = Osc()  # type: ignore[assignment]
    held_at_b(server)
    assert raised == [11]
    server.ask("stop")


# --- what a start arms ---------------------------------------------------------------------

def test_a_start_arms_the_show_with_the_servers_clock_bus_and_options(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = serving(triggered_schedule, telemetry=True, arm_margin=0.25,
                maps={**STANDS, "zed": "stand:zed"})  # zed: not in this show
    try:
        got = s.ask("start")
        assert got["ok"], got
        assert stage.opened == [("rex", "ivy")]
        (ctx,) = stage.contexts
        assert ctx.clock is s.server.clock and ctx.telemetry is True
        run = s.server._run
        assert run is not None and run.director.arm_margin == 0.25
        assert run.launch.events is ctx.events and run.runner.events is ctx.events
        assert got["preflight"] == run.launch.report.as_record()  # type: ignore[union-attr]
        assert [r["performer"] for r in got["preflight"]["rows"]] == ["rex", "ivy"]
        assert got["preflight"]["ok"] is True
        wait_until(lambda: [e for e in s.events("state") if e["state"] == "preflight"])
        (preflight,) = [e for e in s.events("state") if e["state"] == "preflight"]
        assert preflight["rows"] == got["preflight"]["rows"] and preflight["ok"] is True
        s.ask("stop")
    finally:
        s.close()


def test_serves_defaults_arm_without_telemetry_off_and_with_a_tenth_of_a_second_margin(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    session_server = server_module.ShowServer(
        RecordingSession(), server_module.ServeOptions(namespace="ns", maps=dict(STANDS)),
        say=lambda line: None)
    try:
        session_server._cmd_load(server_module.LoadRequest(
            schedule=schedule_to_bytes(triggered_schedule).decode()))
        session_server._cmd_start(server_module.StartRequest())
        (ctx,) = stage.contexts
        assert ctx.telemetry is True
        run = session_server._run
        assert run is not None and run.director.arm_margin == 0.1
    finally:
        session_server.close()


def test_sim_gives_a_simulator_to_each_performer_not_mapped_and_closes_it_after(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = serving(triggered_schedule, sim=True, maps={"rex": "stand:rex"})
    try:
        assert s.ask("start")["ok"]
        (bench,) = stage.benches
        assert bench.names == ["ivy"] and bench.models == ["lite"]
        assert stage.contexts[0].telemetry is False  # as the server was told
        assert stage.opened == [("rex", "ivy")]
        assert bench.closed == 0
        s.ask("stop")
        ended(s)
        assert bench.closed == 1
    finally:
        s.close()


def test_sim_with_every_performer_mapped_makes_no_simulator(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = serving(triggered_schedule, sim=True)
    try:
        assert s.ask("start")["ok"]
        assert stage.benches == []
        s.ask("stop")
    finally:
        s.close()


def test_a_performer_with_a_port_in_the_show_needs_no_map(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    ported = dataclasses.replace(triggered_schedule, performers=tuple(
        dataclasses.replace(p, port="stand:" + p.name) if p.name == "ivy" else p
        for p in triggered_schedule.performers))
    s = serving(ported, maps={"rex": "stand:rex"})
    try:
        assert s.ask("start")["ok"]
        assert sorted(stage.performers) == ["ivy", "rex"]
        s.ask("stop")
    finally:
        s.close()


def test_without_sim_an_unmapped_performer_is_refused_before_anything_opens(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = serving(triggered_schedule, maps={})
    try:
        refusal(s.ask("start"), "start", "refused",
                "no robot for performer(s) rex, ivy: start serve with --map NAME=PORT "
                "(or --sim)")
        assert stage.opened == [] and stage.benches == []
    finally:
        s.close()


@pytest.mark.parametrize("sim", [False, True])
def test_a_port_that_does_not_open_refuses_the_start_and_closes_everything(
    stage: Stage, triggered_schedule: Schedule, sim: bool
) -> None:
    s = serving(triggered_schedule, sim=sim, maps={"rex": "stand:rex"} if sim else STANDS)
    stage.open_errors["rex"] = "no such port"
    try:
        refusal(s.ask("start"), "start", "refused",
                "pre-flight failed: a port did not open; nothing was moved")
        assert stage.closed == [("rex", "ivy")]
        assert [b.closed for b in stage.benches] == ([1] if sim else [])
        assert state(s) == "loaded" and s.server._run is None
        assert s.ask("start", force=True)["error"] == "refused"  # force: not for ports
    finally:
        s.close()


def test_failed_robot_checks_refuse_the_start_unless_forced(
    server: Serve, stage: Stage
) -> None:
    stage.problems["ivy"] = ["battery 3 % (floor 20 %)"]
    refusal(server.ask("start"), "start", "refused",
            "pre-flight failed; nothing was moved (--force to start anyway)")
    assert stage.closed == [("rex", "ivy")]
    got = server.ask("start", force=True)
    assert got["ok"] and got["preflight"]["ok"] is False
    server.ask("stop")


@pytest.mark.parametrize(("error", "code", "message"), [
    (XgoShowError("the adapter is gone"), "failed", "the adapter is gone"),
    (RuntimeError("a bug"), "internal", "internal error: RuntimeError('a bug')"),
])
def test_an_open_that_raises_is_answered_by_its_kind_and_closes_the_simulators(
    stage: Stage, triggered_schedule: Schedule, error: Exception, code: str, message: str
) -> None:
    s = serving(triggered_schedule, sim=True, maps={"rex": "stand:rex"})
    stage.raise_on_open = error
    try:
        refusal(s.ask("start"), "start", code, message)
        assert [b.closed for b in stage.benches] == [1]
        assert stage.closed == [("rex", "ivy")] and s.server._run is None
        stage.raise_on_open = None
        assert s.ask("start")["ok"]  # the control thread lives on
        s.ask("stop")
    finally:
        s.close()


# --- where and when a show starts ----------------------------------------------------------

def test_a_start_given_in_seconds_is_starting_until_then(server: Serve, stage: Stage) -> None:
    before = time.time()
    got = server.ask("start", **{"in": 1.0})
    after = time.time()
    assert got["ok"] and got["offset"] == 0.0
    assert before + 1.0 - 0.01 <= got["start_time"] <= after + 1.0 + 0.01
    assert state(server) == "starting"
    run = server.server._run
    assert run is not None and run.start_at is not None
    wait_until(lambda: [c for c in stage.p("rex").calls if c[0] == "start"])
    (start,) = [c for c in stage.p("rex").calls if c[0] == "start"]
    assert start[0] == "start" and start[1] >= run.start_at and start[2] == 0.0
    server.ask("stop")


def test_a_start_given_on_the_wall_clock_starts_then(server: Serve, stage: Stage) -> None:
    at = time.time() + 0.3
    got = server.ask("start", at=at, section="c")
    wall, now = time.time(), server.server.clock.now()
    assert got["ok"] and got["offset"] == 1.2
    assert abs(got["start_time"] - at) < 0.01
    run = server.server._run
    assert run is not None and run.start_at is not None
    # The wall time on the show's clock (the two clocks read again here, a moment apart).
    assert abs((run.start_at - now) - (at - wall)) < 0.25
    wait_until(lambda: [c for c in stage.p("ivy").calls if c[0] == "start"])
    (start,) = [c for c in stage.p("ivy").calls if c[0] == "start"]
    # Then, or later if arming took longer (a loaded machine): never earlier.
    assert start[0] == "start" and start[1] >= run.start_at and start[2] == 1.2
    server.ask("stop")


def test_a_start_now_is_said_at_the_servers_clock(server: Serve, stage: Stage) -> None:
    before = time.time()
    got = server.ask("start", time=0.25)
    assert got["ok"] and got["offset"] == 0.25
    assert before - 0.01 <= got["start_time"] <= time.time() + 0.01
    assert server.said[-1] == "starting 'Triggered test' from 0.25 s (<schedule>)"
    run = server.server._run
    assert run is not None and run.start_at is None
    wait_until(lambda: state(server) == "playing")
    server.ask("stop")


def test_a_start_in_the_past_is_refused_and_disarmed(
    server: Serve, stage: Stage, monkeypatch: pytest.MonkeyPatch
) -> None:
    wall = time.time()  # the wall clock stands still: how late a start is does not depend
    monkeypatch.setattr(server_module, "time", SimpleNamespace(time=lambda: wall))  # on load
    for late in (2.0, 0.6):
        refusal(server.ask("start", at=wall - late), "start", "bad_request",
                f"start time is {late:.3f} s in the past")
        assert server.server._run is None
    assert stage.closed == [("rex", "ivy")] * 2
    assert all(c[0] != "start" for p in stage.performers.values() for c in p.calls)
    got = server.ask("start", at=wall - 0.4)  # within half a second: played now
    assert got["ok"], got
    server.ask("stop")


def test_the_last_instant_of_a_show_may_start_but_its_end_may_not(
    server: Serve, triggered_schedule: Schedule
) -> None:
    end = triggered_schedule.duration
    got = server.ask("start", time=end - 0.001)
    assert got["ok"] and got["offset"] == round(end - 0.001, 6)
    server.ask("stop")
    wait_until(lambda: state(server) == "loaded")
    refusal(server.ask("start", time=end), "start", "bad_request",
            f"start at {end:g} s: outside the show (0 to {end:g} s)")


# --- commands while a show plays -----------------------------------------------------------

def test_pause_resume_and_seek_reach_every_robot(server: Serve, stage: Stage) -> None:
    assert server.ask("start", section="d")["ok"]  # no wait ahead
    wait_until(lambda: state(server) == "playing")
    got = server.ask("pause")
    assert got["ok"] and got["state"] in ("playing", "paused")
    wait_until(lambda: state(server) == "paused")
    assert all(any(c[0] == "pause" for c in p.calls) for p in stage.performers.values())
    got = server.ask("seek", time=2.0)
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "seek", "show_time": 2.0,
                   "section": "d"}
    assert all(any(c[0] == "seek" and c[1] == 2.0 for c in p.calls)
               for p in stage.performers.values())
    got = server.ask("resume")
    assert got["ok"] and got["state"] in ("paused", "playing")
    wait_until(lambda: state(server) == "playing")
    assert all(any(c[0] == "resume" for c in p.calls) for p in stage.performers.values())
    server.ask("stop")


def stuck_run(
    monkeypatch: pytest.MonkeyPatch, hold: float
) -> tuple[threading.Event, threading.Event]:
    """Every show's run is stuck (for at most ``hold`` s) until the second event is set; the
    first is set once a run began. The run then ends not completed ("stuck")."""
    playing, go_on = threading.Event(), threading.Event()

    def stuck(*args: object, **kwargs: object) -> ShowResult:
        playing.set()
        go_on.wait(hold)
        return ShowResult(False, "stuck")

    monkeypatch.setattr(server_module.Launch, "run", stuck)
    return playing, go_on


def test_a_stop_that_does_not_end_in_time_says_stopping(
    server: Serve, stage: Stage, monkeypatch: pytest.MonkeyPatch
) -> None:
    playing, go_on = stuck_run(monkeypatch, 10.0)
    assert server.ask("start")["ok"] and playing.wait(10.0)
    run = server.server._run
    assert run is not None and run.thread is not None
    joins: list[float | None] = []
    monkeypatch.setattr(run.thread, "join", joins.append)  # its bound, without the wait
    got = server.ask("stop")
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "stop", "state": "stopping"}
    assert joins == [2.0]
    got = server.ask("panic")
    assert got["state"] == "stopping" and joins == [2.0, 1.0]
    go_on.set()
    assert ended(server)["reason"] == "stuck"


def test_a_failed_safe_stop_is_in_the_stop_reply(server: Serve, stage: Stage) -> None:
    held_at_b(server)
    stage.stop_error["ivy"] = "stop frames not written: port gone"
    got = server.ask("stop", reason="curtain")
    assert got["stops"] == {"rex": {"ok": True, "error": ""},
                            "ivy": {"ok": False, "error": "stop frames not written: port gone"}}


def test_a_panic_stops_the_show_at_once_and_says_so(server: Serve, stage: Stage) -> None:
    held_at_b(server)
    got = server.ask("panic")
    assert got["ok"] and got["state"] == "ended" and got["reason"] == "panic"
    assert set(got["stops"]) == {"rex", "ivy"}
    assert ("safe_stop", "panic", 0.1) in stage.p("rex").calls
    wait_until(lambda: [e for e in server.events("state") if e["state"] == "panic"])
    assert ended(server)["reason"] == "panic"


def test_a_panic_during_a_starts_pre_flight_cancels_it_and_closes_everything(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = serving(triggered_schedule, sim=True, maps={"rex": "stand:rex"})
    try:
        assert s.ask("panic")["state"] == "idle"  # an earlier panic counts for nothing later
        stage.hold_open = threading.Event()
        start = s.query("start")
        assert stage.opening.wait(10.0)
        got = s.ask("panic")
        assert got["state"] == "idle"
        stage.hold_open.set()
        refusal(start.answer(), "start", "cancelled",
                "start cancelled by a panic during its pre-flight")
        assert s.server.counters["cancelled"] == 1 and state(s) == "loaded"
        assert stage.closed == [("rex", "ivy")] and [b.closed for b in stage.benches] == [1]
        assert all(c[0] != "start" for p in stage.performers.values() for c in p.calls)
        stage.hold_open = None
        assert s.ask("start")["ok"]  # a panic before a start cancels nothing
        s.ask("stop")
    finally:
        s.close()


def test_closing_stops_a_running_show_first(stage: Stage, triggered_schedule: Schedule) -> None:
    s = serving(triggered_schedule)
    held_at_b(s)
    s.server.close()
    assert ("safe_stop", "serve is closing", 0.1) in stage.p("rex").calls
    assert s.server.status()["last_result"]["reason"] == "serve is closing"
    assert stage.closed == [("rex", "ivy")]
    assert all(d.undeclared for d in s.session.declared)


def test_a_running_show_cannot_be_replaced(server: Serve) -> None:
    held_at_b(server)
    refusal(server.ask("start"), "start", "refused", "a show is running already (stop it first)")
    refusal(server.ask("load", path="/nonexistent.yaml"), "load", "refused",
            "a show is running: stop it before loading another")
    server.ask("stop")


# --- the run log's trigger times -----------------------------------------------------------

def records(path: Path, kind: str) -> list[dict[str, Any]]:
    lines = path.read_text(encoding="utf-8").splitlines()
    return [r for r in map(json.loads, lines) if r["kind"] == kind]


def frame(t: float, kind: str) -> FrameSent:
    return FrameSent(t, "rex", kind, None, None, b"\x00", "", None, 0.0)


def test_the_log_keeps_a_released_waits_times_from_the_trigger_to_its_first_frame(
    stage: Stage, triggered_schedule: Schedule, tmp_path: Path
) -> None:
    log = tmp_path / "run.jsonl"
    s = serving(triggered_schedule, log=log)
    try:
        held_at_b(s)
        bus = stage.contexts[0].events
        bus.publish(frame(1.0, "frame"))  # before any trigger: nothing timed
        assert s.server._trace is None
        got = s.trigger("go").answer()
        assert got["held"] is True
        trace = s.server._trace
        assert trace is not None and (trace.trigger, trace.section) == ("go", "b")
        assert trace.received <= trace.parsed <= trace.decided
        bus.publish(StateChanged(5.0, "rex", S.PAUSED, 0.6))  # neither reaching nor running
        bus.publish(frame(5.5, "read"))  # a telemetry read is no write of the show
        bus.publish(StateChanged(6.0000004, "rex", S.REACHING, 0.6))
        bus.publish(StateChanged(6.5, "ivy", S.REACHING, 0.6))  # the first writer's only
        bus.publish(StateChanged(7.0, "rex", S.RUNNING, 0.6))
        bus.publish(StateChanged(7.5, "ivy", S.RUNNING, 0.6))
        bus.publish(frame(8.0, "reach"))
        bus.publish(frame(8.5, "reach"))
        assert s.server._trace is trace
        bus.publish(frame(9.0, "frame"))
        assert s.server._trace is None
        bus.publish(frame(9.5, "frame"))  # timed once
        s.ask("stop")
    finally:
        s.close()
    (record,) = records(log, "trigger")
    assert {k: record[k] for k in ("trigger", "section", "woke", "released", "first_write",
                                   "first_frame")} == {
        "trigger": "go", "section": "b", "woke": 6.0, "released": 7.0, "first_write": 8.0,
        "first_frame": 9.0}
    assert record["received"] == round(trace.received, 6)
    assert record["decided"] == round(trace.decided, 6)


def test_a_release_straight_to_running_woke_when_it_ran_and_a_frame_is_its_first_write(
    stage: Stage, triggered_schedule: Schedule, tmp_path: Path
) -> None:
    log = tmp_path / "run.jsonl"
    s = serving(triggered_schedule, log=log)
    try:
        held_at_b(s)
        bus = stage.contexts[0].events
        s.trigger("go").answer()
        bus.publish(StateChanged(7.0, "rex", S.RUNNING, 0.6))
        bus.publish(StateChanged(7.5, "rex", S.REACHING, 0.6))
        bus.publish(frame(9.0, "frame"))
        s.ask("stop")
    finally:
        s.close()
    (record,) = records(log, "trigger")
    assert (record["woke"], record["released"], record["first_write"], record["first_frame"]) \
        == (7.0, 7.0, 9.0, 9.0)


def test_without_a_log_nothing_is_timed(server: Serve, stage: Stage) -> None:
    held_at_b(server)
    server.trigger("go").answer()
    assert server.server._trace is None and server.server.log is None
    server.ask("stop")


def test_a_trigger_kept_for_the_wait_ahead_is_not_timed(
    stage: Stage, triggered_schedule: Schedule, tmp_path: Path
) -> None:
    s = serving(triggered_schedule, log=tmp_path / "run.jsonl")
    try:
        assert s.ask("start")["ok"]
        wait_until(lambda: state(s) == "playing")
        got = s.trigger("go").answer()
        assert got["held"] is False and s.server._trace is None
        s.ask("stop")
    finally:
        s.close()


# --- loads, and the events' wire form ------------------------------------------------------

def test_a_routine_is_compiled_and_its_problems_are_placed_in_routine(serve: Serve) -> None:
    got = serve.ask("load", routine=ROUTINE.replace("Triggered test", "Überraschung"))
    assert got["ok"] and got["show"]["name"] == "Überraschung"
    assert got["show"]["source"] == "<routine>" and got["show"]["triggers"] == ["go", "encore"]
    assert serve.said[-1] == "loaded 'Überraschung' (<routine>); triggers: go, encore"
    refusal(serve.ask("load", routine="show: x\n"), "load", "failed",
            "<routine>: 2 error(s): <routine>:1:1: error: performers: missing required field "
            "'performers' (and 1 more)")
    assert serve.server.status()["show"]["name"] == "Überraschung"  # the last good one stays


def test_a_schedule_sent_as_text_is_named_schedule_in_its_problems(serve: Serve) -> None:
    refusal(serve.ask("load", schedule="{"), "load", "failed",
            "<schedule>: not a schedule file (invalid JSON at line 1 column 2: Expecting "
            "property name enclosed in double quotes)")
    refusal(serve.ask("load", path="/nonexistent.yaml"), "load", "failed",
            "/nonexistent.yaml: no such file")


def test_events_go_out_as_compact_json_that_may_be_dropped_under_congestion(
    serve: Serve
) -> None:
    import zenoh

    serve.server._put("ns/event/x", {"a": [1, 2], "b": "c"})
    assert serve.session.puts[-1] == ("ns/event/x", b'{"a":[1,2],"b":"c"}',
                                      zenoh.CongestionControl.DROP)
    with pytest.raises(ValueError):  # strict JSON: a NaN is refused, not sent
        serve.server._put("ns/event/x", {"a": float("nan")})


def test_an_osc_bar_without_a_number_seeks_to_the_first_bar(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    timed = dataclasses.replace(triggered_schedule, tempo_map=((1, 120.0, 4),))
    s = serving(timed)
    try:
        assert s.ask("start", section="d")["ok"]  # no wait ahead
        wait_until(lambda: state(s) == "playing")
        s.server._on_osc(Command("bar"))
        wait_until(lambda: any(line.startswith("osc: seek") for line in s.said))
        assert "osc: seek: done" in s.said
        assert all(any(c[0] == "seek" and c[1] == 0.0 for c in p.calls)
                   for p in stage.performers.values())
        s.server._on_osc(Command("bar", 2.0))
        wait_until(lambda: all(any(c[0] == "seek" and c[1] == 2.0 for c in p.calls)
                               for p in stage.performers.values()))
        s.ask("stop")
    finally:
        s.close()


def test_an_osc_trigger_is_timed_in_the_log_like_any_other(
    stage: Stage, triggered_schedule: Schedule, tmp_path: Path
) -> None:
    s = serving(triggered_schedule, log=tmp_path / "run.jsonl")
    try:
        held_at_b(s)
        before = s.server.clock.now()
        s.server._on_osc(Command("trigger", name="go"))
        trace = s.server._trace
        assert trace is not None and before <= trace.received <= trace.parsed
        wait_until(lambda: [e for e in s.events("trigger") if e["accepted"]])
        (event,) = [e for e in s.events("trigger") if e["accepted"]]
        assert event["source"] == "osc" and event["data"] is None
        s.ask("stop")
    finally:
        s.close()


def test_a_put_that_releases_a_held_wait_is_timed_from_its_arrival(
    stage: Stage, triggered_schedule: Schedule, tmp_path: Path
) -> None:
    s = serving(triggered_schedule, log=tmp_path / "run.jsonl")
    try:
        held_at_b(s)
        before = s.server.clock.now()
        s.session.publish("ns/trigger/go")
        trace = s.server._trace
        assert trace is not None and (trace.trigger, trace.section) == ("go", "b")
        assert before <= trace.received <= trace.parsed <= trace.decided
        s.ask("stop")
    finally:
        s.close()


def test_the_shows_robot_states_and_progress_are_published(server: Serve) -> None:
    held_at_b(server)
    wait_until(lambda: {(e.get("robot"), e["state"]) for e in server.events("state")} >= {
        ("rex", "paused"), ("ivy", "paused")})
    paused = [e for e in server.events("state") if e.get("robot") == "rex"
              and e["state"] == "paused"]
    assert paused[0]["show_time"] == 0.6
    wait_until(lambda: server.events("progress"), timeout=10)  # a few a second
    progress = server.events("progress")[0]
    assert progress["section"] == "b" and progress["duration"] == 2.3
    server.ask("stop")


def test_unsafe_writes_are_refused_unless_serve_allows_them(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    from xgo_show.compiler.schedule import ScheduledFrame
    from xgo_show.profiles import get_profile
    from xgo_show.wire.xgo import write_frame

    zero = write_frame(get_profile("mini").register("servo_zero").address, b"\x01")
    unsafe = dataclasses.replace(triggered_schedule, performers=tuple(
        dataclasses.replace(p, frames=tuple(sorted((*p.frames, ScheduledFrame(0.5, zero)),
                                                   key=lambda f: f.t)))
        if p.name == "rex" else p for p in triggered_schedule.performers))
    s = serving(unsafe, sim=True, maps={"rex": "stand:rex"})
    try:
        got = s.ask("start")
        assert (got["error"], got["message"][:18]) == ("failed", "refusing to run: r")
        assert "servo_zero" in got["message"] and stage.opened == []
        assert [b.closed for b in stage.benches] == [1]
    finally:
        s.close()
    s = serving(unsafe, allow_unsafe=True)
    try:
        assert s.ask("start")["ok"]
        run = s.server._run
        assert run is not None and run.launch.unsafe != []
        s.ask("stop")
    finally:
        s.close()


def close_in_time(s: Serve) -> None:
    """Close the server from another thread; it must return (after its bounded waits)."""
    closer = threading.Thread(target=s.server.close, name="test closer")
    closer.start()
    closer.join(20.0)  # the bounds are 2 and 3 s; a held open waits up to a minute
    assert not closer.is_alive(), "close waited for ever"
    assert all(d.undeclared for d in s.session.declared)


def test_closing_gives_a_stuck_show_a_bounded_wait(
    stage: Stage, triggered_schedule: Schedule, monkeypatch: pytest.MonkeyPatch
) -> None:
    playing, go_on = stuck_run(monkeypatch, 30.0)
    s = serving(triggered_schedule)
    try:
        assert s.ask("start")["ok"] and playing.wait(10.0)
        close_in_time(s)
    finally:
        go_on.set()
        s.server.close()


def test_closing_gives_a_command_stuck_in_its_pre_flight_a_bounded_wait(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = serving(triggered_schedule)
    stage.hold_open = threading.Event()
    try:
        start = s.query("start")
        assert stage.opening.wait(10.0)  # the control thread waits in the start's open
        close_in_time(s)
    finally:
        stage.hold_open.set()
    # The start's pre-flight ends after the close: nothing may start then (the process is
    # about to exit, and a show it started would be left without a safe stop).
    refusal(start.answer(), "start", "closing", "start cancelled: the server is closing")
    assert stage.closed == [("rex", "ivy")] and s.server._run is None
    assert all(c[0] != "start" for p in stage.performers.values() for c in p.calls)
    assert s.server.counters["cancelled"] == 1
