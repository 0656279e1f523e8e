"""What a relay (relay/server.py) gives back and writes down, in this process over the recording
session of tests/relay/handling.py: the numbers in its refusals (on a clock that moves only
when the test moves it), the state a conductor is told, what the show's runner is given and
what its result becomes in the reply, the run log and the robots' safe state, the defaults a
relay process gets, and the threads it starts. The first mutation runs left these unchecked
(docs/mutation-results.md); test_relay_handling.py and test_relay_plumbing.py cover the rest.
"""

from __future__ import annotations

import dataclasses
import json
import re
import threading
import time
from collections.abc import Callable, Iterator
from types import SimpleNamespace
from typing import Any

import pytest

from tests.conftest import wait_until
from xgo_show.errors import RelayRefused
from xgo_show.net import messages as msg
from xgo_show.relay import server
from xgo_show.relay.performer import executor_lead
from xgo_show.relay.robots import OwnedRobot, close_robots, open_robots
from xgo_show.relay.server import Relay, RelayState
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.show_runner import ShowResult, ShowRunner

from .conftest import upload_text, walk_schedule
from .handling import ALICE, BOB, CMD, encoded, request
from .recording import Incoming, RecordingSession, record_threads


@pytest.fixture
def robots() -> Iterator[dict[str, OwnedRobot]]:
    owned = open_robots({"rex": "sim:mini", "lola": "sim:lite"}, {})
    yield owned
    close_robots(owned)


class ManualClock:
    """A clock that moves only when the test moves it (``t``); a wait on it ends when the test
    has moved it past the deadline, or at once when interrupted. Unlike ``FakeClock`` it never
    jumps ahead by itself, so a holder's watchdog on it stays quiet until the test says."""

    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def now(self) -> float:
        return self.t

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        while self.t < deadline:
            if interrupt is not None and interrupt.wait(0.005):
                return False
            if interrupt is None:
                time.sleep(0.005)
        return True


Made = tuple[Relay, RecordingSession, RunLog]


@pytest.fixture
def make(robots: dict[str, OwnedRobot]) -> Iterator[Callable[..., Made]]:
    """``make(**options)``: a relay named hall in namespace ns, started over a recording
    session, logging to memory; closed after the test."""
    made: list[Relay] = []

    def build(**options: Any) -> Made:
        session, log = RecordingSession(), RunLog(None, keep=True)
        r = Relay(session, "hall", robots, namespace="ns", log=log, **options)  # type: ignore[arg-type]
        made.append(r.start())
        return r, session, log

    yield build
    for r in made:
        r.close()


@pytest.fixture(autouse=True)
def patient_watchdog(monkeypatch: pytest.MonkeyPatch) -> None:
    """A holder's watchdog of 60 s from its hello (no heartbeats here; see test_relay_plumbing)."""
    monkeypatch.setattr(server, "DEFAULT_WATCHDOG_MS", 60_000)


def events(log: RunLog, name: str) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in ("kind", "mono", "event")}
            for r in log.events(name)]


def upload(r: Relay, seconds: float = 2.0, *, who: msg.Conductor = ALICE,
           **extra: Any) -> dict[str, Any]:
    text, sha = upload_text(walk_schedule(seconds, rex="mini"))
    fields = {"schedule": text, "sha256": sha, "link_loss": "stop", "watchdog_ms": 60_000,
              **extra}
    return r.handle(request("upload", who, **fields))


def start(r: Relay, sha: str, **fields: Any) -> dict[str, Any]:
    return r.handle(request("start", sha256=sha, **{"offset": 0.0, **fields}))


@dataclasses.dataclass
class Scripted:
    """``ShowRunner.run`` and ``stop`` replaced: ``run`` records its arguments and waits until
    ``release`` is set (a stop sets it unless ``stuck``), then returns ``result(arguments)``
    (kept as the runner's result, as the real run does)."""

    calls: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    stops: list[str] = dataclasses.field(default_factory=list)
    release: threading.Event = dataclasses.field(default_factory=threading.Event)
    stuck: bool = False
    result: Callable[[dict[str, Any]], ShowResult] = (
        lambda kw: ShowResult(True, "completed", start_at=kw["start_at"]))


@pytest.fixture
def scripted(monkeypatch: pytest.MonkeyPatch) -> Iterator[Scripted]:
    script = Scripted()

    def run(runner: ShowRunner, **kwargs: Any) -> ShowResult:
        script.calls.append(kwargs)
        assert script.release.wait(30.0)
        runner.result = script.result(kwargs)
        return runner.result

    def stop(runner: ShowRunner, reason: str = "stop requested") -> None:
        script.stops.append(reason)
        if not script.stuck:
            script.release.set()

    monkeypatch.setattr(ShowRunner, "run", run)
    monkeypatch.setattr(ShowRunner, "stop", stop)
    yield script
    script.release.set()


def ended(r: Relay) -> None:
    wait_until(lambda: r.describe()["state"] == RelayState.ENDED, timeout=10.0)


# --- a relay process's defaults --------------------------------------------------------------

def test_a_relays_defaults_namespace_telemetry_no_trace_and_a_log_that_keeps_nothing(
    robots: dict[str, OwnedRobot],
) -> None:
    session = RecordingSession()
    r = Relay(session, "hall", robots).start()  # type: ignore[arg-type]
    try:
        assert [key for _, key in session.declarations()] == [
            "xgo-show/relay/hall/time", "xgo-show/relay/hall/cmd", "xgo-show/relay/hall/info",
            "xgo-show/relay/hall/alive"]
        assert r.telemetry is True and r.allow_unsafe is False and r.sync_delay is None
        assert r._tracer is None
        assert r.log.path is None and r.log.records == []  # a relay runs for days: no growth
        other = Relay(RecordingSession(), "hall", robots)  # type: ignore[arg-type]
        assert re.fullmatch(r"[0-9a-f]{12}", r.instance) and other.instance != r.instance
        other.close()
    finally:
        r.close()


def test_close_without_a_reason_says_the_relay_closed(make: Callable[..., Made]) -> None:
    r, _, log = make()
    r.close()
    assert events(log, "safe_stop") == [{"relay": "hall", "reason": "relay closed",
                                         "ok": {"rex": True, "lola": True}}]
    assert events(log, "relay_stop") == [{"relay": "hall", "reason": "relay closed"}]


# --- the holder ------------------------------------------------------------------------------

def test_a_holders_watchdog_runs_on_the_relays_own_clock_in_a_thread_named_for_it(
    make: Callable[..., Made],
) -> None:
    clock = ManualClock()
    r, _, log = make(clock=clock)
    r.handle(request("hello"))
    assert "xgo-show watchdog conductor alice" in {t.name for t in threading.enumerate()}
    time.sleep(0.05)
    assert r.describe()["holder"] is not None  # the host's clock has not moved
    clock.t += 60.0  # to the deadline exactly (a later wake-up would get a grace first)
    wait_until(lambda: r.describe()["holder"] is None, timeout=10.0)
    assert events(log, "link_lost") == [{"conductor": "alice", "silent_ms": 60000.0,
                                         "policy": None}]


def test_a_new_holder_starts_from_this_hosts_clock_not_the_last_ones_timebase(
    make: Callable[..., Made],
) -> None:
    r, session, _ = make()
    r.handle(request("hello"))
    tb = {"v": 1, "op": "timebase", "conductor": ALICE.id, "offset": -50.0, "rate": 0.0,
          "ref": 0.0, "bound": 1e-4, "rate_bound": 1e-6}
    session.query("ns/relay/hall/time", json.dumps(tb).encode(), wait=5.0)
    assert r.clock.timebase is not None
    r.handle(request("release"))
    r.handle(request("hello", BOB))
    # Bob's first timebase is set at once, not slewed to from Alice's (30 s away).
    q = session.query("ns/relay/hall/time", json.dumps(
        tb | {"conductor": BOB.id, "offset": -80.0}).encode(), wait=5.0)
    assert [json.loads(d) for _, d in q.replies] == [{"v": 1, "ok": True, "correction": 0.0}]
    assert abs(r.clock.now() - (r.base.now() + 80.0)) < 0.5


def test_a_release_closes_the_stage_in_a_daemon_thread_of_its_own(
    make: Callable[..., Made], monkeypatch: pytest.MonkeyPatch,
) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    r.handle(request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=60_000))
    made = record_threads(monkeypatch, server)
    r.handle(request("release"))
    assert made == [("xgo-show watchdog stop", True), ("xgo-show stage close", True)]


# --- what the worker answers at once ---------------------------------------------------------

def test_only_a_heartbeat_shorter_than_1024_bytes_is_answered_in_the_callers_thread(
    make: Callable[..., Made],
) -> None:
    r, session, _ = make()
    r.handle(request("hello"))
    beat = encoded("heartbeat", seq=5)
    at_once = Incoming(CMD, beat + b" " * (1023 - len(beat)))  # JSON allows the trailing blanks
    session.queryables[CMD](at_once)
    assert at_once.threads == [threading.current_thread().name]
    longer = Incoming(CMD, beat + b" " * (1024 - len(beat)))  # by the worker, in its turn
    session.queryables[CMD](longer)
    assert longer.done.wait(10.0) and longer.threads == ["xgo-show relay commands"]
    assert longer.answer()["seq"] == 5


# --- uploads ---------------------------------------------------------------------------------

def test_an_upload_checks_the_robots_against_the_conductors_battery_floor(
    make: Callable[..., Made],
) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    got = upload(r, battery_floor=100.5)  # the simulators report 100 %
    assert got["preflight_ok"] is False
    (problem,) = got["preflight"][0]["problems"]
    assert "battery" in problem and "100.5" in problem
    assert upload(r, battery_floor=50.0)["preflight_ok"] is True


def test_an_upload_sets_the_holders_watchdog_to_the_uploads(make: Callable[..., Made]) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    upload(r, watchdog_ms=250)
    assert r._holder is not None and r._holder.watchdog.timeout == 0.25


def test_what_the_pre_flight_read_is_kept_and_a_reading_it_lacks_keeps_the_last_one(
    make: Callable[..., Made], monkeypatch: pytest.MonkeyPatch,
) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    real = server.preflight
    readings: dict[str, Any] = {"firmware": "M-9.9.9", "battery": 42.5, "voltage": 7.25}

    def read(*args: Any, **kwargs: Any) -> Any:
        report = real(*args, **kwargs)
        rows = [dataclasses.replace(row, **readings) for row in report.rows]
        return dataclasses.replace(report, rows=rows)

    monkeypatch.setattr(server, "preflight", read)
    upload(r)
    rex = r.describe()["robots"][0]
    assert (rex["name"], rex["firmware"], rex["battery"], rex["voltage"]) == (
        "rex", "M-9.9.9", 42.5, 7.25)
    readings.update(firmware="", battery=None, voltage=None)  # a robot that did not say
    upload(r)
    rex = r.describe()["robots"][0]
    assert (rex["firmware"], rex["battery"], rex["voltage"]) == ("M-9.9.9", 42.5, 7.25)


def test_a_relay_that_allows_unsafe_writes_loads_and_starts_a_show_with_them(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    from xgo_show.compiler.schedule import ScheduledFrame
    from xgo_show.wire.xgo import write_frame

    r, _, log = make(allow_unsafe=True)
    r.handle(request("hello"))
    show = walk_schedule(0.5, rex="mini")
    rex = show.performers[0]
    zero = ScheduledFrame(0.2, write_frame(0x21, b"\x01"))  # servo_zero: unsafe
    bad = dataclasses.replace(rex, frames=(*rex.frames[:2], zero))
    text, sha = upload_text(dataclasses.replace(show, performers=(bad,)))
    r.handle(request("upload", schedule=text, sha256=sha, link_loss="stop", watchdog_ms=60_000))
    (loaded,) = events(log, "upload")
    assert loaded["unsafe_allowed"] and "servo_zero" in json.dumps(loaded["unsafe_allowed"])
    start(r, sha, start_in=0.2)  # the runner is made allowing them too
    assert r._show is not None and r._show.runner is not None


# --- starts ----------------------------------------------------------------------------------

def test_start_refusals_say_how_late_and_how_much_lead_to_the_millisecond(
    make: Callable[..., Made], monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = ManualClock(1000.0)
    r, _, _ = make(clock=clock)
    r.handle(request("hello"))
    sha = upload(r)["sha256"]
    with pytest.raises(RelayRefused) as info:
        start(r, sha, start_at=999.5)
    assert str(info.value) == ("start: the start time passed 500.0 ms ago (give a longer lead "
                               "time)")
    with pytest.raises(RelayRefused) as info:
        start(r, sha, start_at=1000.0)  # now is not still to come
    assert str(info.value).startswith("start: the start time passed 0.0 ms ago")
    monkeypatch.setattr(server, "executor_lead", lambda performer, offset: 0.2994)
    with pytest.raises(RelayRefused) as info:
        start(r, sha, start_in=0.04948)
    assert str(info.value) == ("start: the robots need 299 ms to be ready and the start time "
                               "is 49 ms away (give a longer lead time)")
    assert r.describe()["state"] == RelayState.LOADED


def test_a_mid_show_start_needs_the_catch_up_frames_time_too(make: Callable[..., Made]) -> None:
    clock = ManualClock(1000.0)
    r, _, _ = make(clock=clock)
    r.handle(request("hello"))
    sha = upload(r)["sha256"]
    assert r._show is not None
    (rex,) = r._show.schedule.performers
    need = executor_lead(rex, 1.0)
    assert need > executor_lead(rex, 0.0)
    with pytest.raises(RelayRefused) as info:
        start(r, sha, offset=1.0, start_in=0.001)
    assert f"the robots need {need * 1e3:.0f} ms" in str(info.value)


def test_a_start_exactly_the_robots_lead_away_is_accepted_with_no_margin(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    clock = ManualClock(1000.0)
    r, _, log = make(clock=clock)
    r.handle(request("hello"))
    sha = upload(r)["sha256"]
    assert r._show is not None
    lead = executor_lead(r._show.schedule.performers[0], 0.0)
    got = start(r, sha, start_in=lead)
    assert got == {"start_at": 1000.0 + lead, "margin": 0.0}
    assert events(log, "armed")[0]["margin_ms"] == 0.0


def test_a_started_show_is_armed_until_its_start_time_then_running(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    clock = ManualClock(1000.0)
    r, _, _ = make(clock=clock)
    r.handle(request("hello"))
    sha = upload(r)["sha256"]
    assert r.describe()["state"] == RelayState.LOADED
    start(r, sha, start_at=1001.0)
    assert r.describe()["state"] == RelayState.ARMED
    assert r.handle(request("heartbeat"))["show"]["state"] == RelayState.ARMED
    clock.t = 1001.0
    assert r.describe()["state"] == RelayState.RUNNING
    scripted.release.set()
    ended(r)


def test_the_show_runs_on_the_relays_clock_telemetry_and_floor_in_a_daemon_thread(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    for telemetry in (True, False):
        r, _, _ = make(telemetry=telemetry)
        r.handle(request("hello"))
        sha = upload(r, battery_floor=15.0)["sha256"]
        got = start(r, sha, offset=0.5, start_in=0.5)
        show = r._show
        assert show is not None and show.runner is not None and show.thread is not None
        runner = show.runner
        assert runner.clock is r.clock and runner.events is r.events
        assert runner.battery_floor == 15.0
        rex = runner.performers["rex"]
        assert rex.clock is r.clock  # type: ignore[attr-defined]
        poller = rex.telemetry  # type: ignore[attr-defined]
        assert (poller is not None) is telemetry
        if poller is not None:
            assert poller.battery_floor == 15.0
        assert (show.thread.name, show.thread.daemon) == ("relay show", True)
        wait_until(lambda: scripted.calls, timeout=10.0)
        # The runner starts at the armed time from the offset, with no lead of its own (the
        # relay checked the lead), and leaves the relay's signals alone.
        assert scripted.calls[-1] == {"offset": 0.5, "lead": 0.0, "start_at": got["start_at"],
                                      "handle_signals": False}
        scripted.release.set()
        ended(r)
        scripted.release.clear()
        r.close()


# --- the show's end, as the conductor is told and the log keeps it ---------------------------

def test_a_late_start_is_logged_and_reported_to_the_microsecond(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    r, _, log = make()
    scripted.result = lambda kw: ShowResult(
        False, "stopped", start_at=kw["start_at"] + 0.0123456, stop_latency=0.0456789,
        faults={"rex": "port gone"},
        stops={"rex": SimpleNamespace(ok=False)})  # type: ignore[dict-item]
    r.handle(request("hello"))
    sha = upload(r)["sha256"]
    start(r, sha, start_in=0.2)
    scripted.release.set()
    ended(r)
    assert events(log, "late_start") == [{"late_ms": 12.346}]
    assert r.describe()["last"] == {
        "sha256": sha, "completed": False, "reason": "stopped", "faults": {"rex": "port gone"},
        "link_lost": False, "late_start_ms": 12.346, "stops": {"rex": False},
        "stop_latency_ms": 45.679}


def test_a_start_on_time_or_early_logs_no_lateness(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    r, _, log = make()
    scripted.result = lambda kw: ShowResult(True, "completed", start_at=kw["start_at"] - 0.001)
    r.handle(request("hello"))
    start(r, upload(r)["sha256"], start_in=0.2)
    scripted.release.set()
    ended(r)
    assert events(log, "late_start") == []
    last = r.describe()["last"]
    assert last["late_start_ms"] == 0.0 and last["stop_latency_ms"] is None


def test_a_heartbeat_reporting_a_robot_ended_carries_the_events_before_it(
    make: Callable[..., Made], scripted: Scripted, monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xgo_show.runtime.events import StateChanged

    r, _, _ = make()
    r.handle(request("hello"))
    start(r, upload(r)["sha256"], start_in=0.2)
    show = r._show
    assert show is not None and show.runner is not None
    runner = show.runner
    r._bookkeeping.delay = 60.0  # events handed on a minute late unless flushed
    r.events.publish(StateChanged(1.0, "rex", ExecutorState.RUNNING, 0.0))
    assert r.handle(request("heartbeat"))["show"]["events"] == []  # running: not waited for
    r.events.publish(StateChanged(2.0, "rex", ExecutorState.FINISHED, 2.0))
    snap = runner.snapshot()
    done = dataclasses.replace(snap, performers=tuple(
        dataclasses.replace(p, state=ExecutorState.FINISHED) for p in snap.performers))
    monkeypatch.setattr(runner, "snapshot", lambda: done)
    status = r.handle(request("heartbeat"))["show"]
    assert status["performers"]["rex"]["state"] == "finished"
    assert [row[:3] for row in status["events"] if row[0] == "s"] == [
        ["s", "rex", "running"], ["s", "rex", "finished"]]


def test_while_a_show_runs_the_description_gives_each_robots_state(
    make: Callable[..., Made],
) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    start(r, upload(r, seconds=5.0)["sha256"], start_in=0.2)  # played for real

    def states() -> dict[str, str]:
        return {d["name"]: d["state"] for d in r.describe()["robots"]}

    wait_until(lambda: states() == {"rex": "running", "lola": "idle"},  # lola: not in it
               timeout=10.0)
    r.handle(request("stop", reason="x"))


# --- stops -----------------------------------------------------------------------------------

def test_a_stop_answers_within_a_second_even_if_the_runner_is_stuck(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    start(r, upload(r)["sha256"], start_in=0.2)
    wait_until(lambda: scripted.calls, timeout=10.0)
    scripted.stuck = True
    threading.Timer(3.0, scripted.release.set).start()
    began = time.monotonic()
    assert r.handle(request("stop", reason="operator")) == {"stops": {}}  # none known yet
    assert 1.0 <= time.monotonic() - began < 1.9
    assert scripted.stops == ["operator"]
    ended(r)


def test_a_stop_closes_the_stage_with_its_reason(make: Callable[..., Made]) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    r.handle(request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=60_000))
    stage = r._stage
    assert stage is not None
    closed: list[str] = []
    real = stage.close
    stage.close = lambda reason: (closed.append(reason), real(reason))  # type: ignore[method-assign]
    r.handle(request("stop", reason="operator"))
    assert closed == ["operator"]


def test_a_robot_whose_safe_stop_fails_is_reported_and_logged_as_not_stopped(
    make: Callable[..., Made], robots: dict[str, OwnedRobot], monkeypatch: pytest.MonkeyPatch,
) -> None:
    r, _, log = make()
    monkeypatch.setattr(robots["rex"], "safe_stop", lambda: "port gone")
    r.handle(request("hello"))
    assert r.handle(request("stop", reason="x")) == {"stops": {"rex": False, "lola": True}}
    assert events(log, "safe_stop") == [{"relay": "hall", "reason": "x",
                                         "ok": {"rex": False, "lola": True}}]


# --- timed commands and silences -------------------------------------------------------------

def test_a_timed_command_too_late_says_by_how_much_to_the_tenth_of_a_millisecond(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    clock = ManualClock(1000.0)
    r, _, _ = make(clock=clock)
    r.handle(request("hello"))
    start(r, upload(r)["sha256"], start_in=1.0)
    with pytest.raises(RelayRefused) as info:
        r.handle(request("pause", at=999.75))
    assert str(info.value) == ("pause: its time passed 250.0 ms before it arrived (give a "
                               "longer command lead)")


def test_a_lost_link_names_the_silence_in_whole_milliseconds(
    make: Callable[..., Made], scripted: Scripted,
) -> None:
    r, _, _ = make()
    r.handle(request("hello"))
    start(r, upload(r)["sha256"], start_in=0.2)
    r._on_silence(ALICE, 0.4994)
    assert scripted.stops == ["link lost: conductor alice silent for 499 ms"]
    ended(r)
    assert r.describe()["last"]["link_lost"] is True
