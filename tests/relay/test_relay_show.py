"""Robots behind a relay as the show runner sees them (relay/performer.py), in this process:
a real :class:`RelayClient` over a recording session (tests/relay/recording.py) that holds the
heartbeats and timed commands until the test answers them, a fake clock and an event bus.
What the heartbeat answers become (states, show times, readings, faults, the end of a show),
when a command for "now" acts and how often it is sent, refusals and silence as faults, the
lead of a start, the safe stop, and giving the relay up. test_conductor.py and
test_relayed_timeline.py run the same over Zenoh with relays in their own processes."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator, Sequence
from typing import Any

import pytest

from tests.conftest import wait_until
from tests.relay.conftest import walk_schedule
from tests.relay.recording import Answer, Query, RecordingSession, answer
from xgo_show.compiler.schedule import PerformerSchedule
from xgo_show.errors import NetworkError
from xgo_show.net import messages as msg
from xgo_show.profiles import get_profile
from xgo_show.relay.client import RelayClient
from xgo_show.relay.performer import (
    MIN_NETWORK_LEAD,
    NETWORK_LEAD,
    RELAY_SETUP,
    RTT_FACTOR,
    RelayedPerformer,
    RelayShow,
    executor_lead,
)
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import (
    Event,
    EventBus,
    EventRecorder,
    FaultRaised,
    SafeStopped,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, Progress
from xgo_show.runtime.show_runner import default_reach

SHA = "abc123"
NAMES = {"rex": "dog1", "lola": "dog2"}  # show performer -> robot on the relay


class Rig:
    """A relay show over a holding recording session; the relay's answers are the test's."""

    def __init__(self, *, synced: bool = True, watchdog: float = 5.0,
                 stop: Any = None) -> None:
        self.stop_reply = stop if stop is not None else {"stops": {"dog1": True, "dog2": True}}
        self.session = RecordingSession(self._respond, hold=True)
        self.client = RelayClient(self.session, "hall", namespace="ns",  # type: ignore[arg-type]
                                  conductor=msg.Conductor("c1", "alice"), timeout=1.0)
        self.clock = FakeClock(100.0)
        self.bus = EventBus()
        self.events = EventRecorder(self.bus)
        self.schedule = walk_schedule(1.0, rex="mini", lola="lite")
        self.show = RelayShow(self.client, NAMES, SHA, clock=self.clock, events=self.bus,
                              watchdog=watchdog, synced=synced)
        self.performers = {p.name: RelayedPerformer(p, self.show)
                           for p in self.schedule.performers}

    def _respond(self, q: Query) -> Sequence[Answer]:
        # What the test does not hold: synchronous requests (stop, release).
        if q.op == "stop":
            if isinstance(self.stop_reply, str):
                return [answer(q, error=self.stop_reply)]
            return [answer(q, **self.stop_reply)]
        return [answer(q)]

    def beat(self, status: dict[str, Any]) -> None:
        """Answer the latest heartbeat with ``status`` (one heartbeat may have several
        answers: the relay's answer comes at once, not a heartbeat period later)."""
        wait_until(lambda: self.session.of("heartbeat"), timeout=5.0)
        q = self.session.of("heartbeat")[-1]
        q.deliver([answer(q, show=status)])

    def sent(self, op: str) -> list[dict[str, Any]]:
        return [q.request for q in self.session.of(op)]

    def of(self, kind: type[Event]) -> list[Any]:
        return [e for e in self.events.events if isinstance(e, kind)]

    def close(self) -> None:
        self.client.stop_heartbeat()


@pytest.fixture
def rig() -> Iterator[Rig]:
    r = Rig()
    r.show.begin()
    yield r
    r.close()


def row(state: str = "running", show_time: float = 1.0, sent: int = 3, total: int = 20,
        cue: str = "walk", fault: str | None = None) -> dict[str, Any]:
    return {"state": state, "show_time": show_time, "sent": sent, "total": total, "cue": cue,
            "fault": fault}


# --- the lead ------------------------------------------------------------------------------------

def test_the_leads_are_the_documented_constants() -> None:
    assert (NETWORK_LEAD, RTT_FACTOR, MIN_NETWORK_LEAD, RELAY_SETUP) == (0.2, 3.0, 0.05, 0.05)


def test_a_start_needs_the_worst_recent_round_trip_three_times_and_the_relay_set_up() -> None:
    r = Rig()
    assert r.show.network_lead() == MIN_NETWORK_LEAD  # no round trip measured yet
    assert r.show.lead() == pytest.approx(MIN_NETWORK_LEAD + RELAY_SETUP)
    r.client.link.recent.extend([0.001, 0.01])  # 3 x 0.01 < 0.05: the floor
    assert r.show.network_lead() == MIN_NETWORK_LEAD
    r.client.link.recent.extend([0.1, 0.02])  # the worst, not the last
    assert r.show.network_lead() == pytest.approx(0.3)
    assert r.show.lead() == pytest.approx(0.35)
    rex = r.performers["rex"]
    assert rex.lead_time(0.0) == pytest.approx(0.35 + executor_lead(rex.schedule, 0.0))


def test_an_executor_needs_its_own_lead_and_the_catch_up_frames_of_a_mid_show_start() -> None:
    (p,) = walk_schedule(1.0, rex="mini").performers
    assert executor_lead(p, 0.0) == executor_lead(p, -1.0) == 0.05
    frames = default_reach(p, get_profile("mini"))(0.5)
    assert frames  # the walk's speed and its sway
    wire = sum(p.link.wire_time(len(d)) + p.link.gap for d, _ in frames)
    assert executor_lead(p, 0.5) == pytest.approx(0.05 + wire)
    assert executor_lead(p, 0.5) > 0.05 + p.link.gap * len(frames)


# --- times on the two clocks ---------------------------------------------------------------------

def test_once_synced_the_relay_reads_the_conductor_clock() -> None:
    r = Rig()
    r.client.link.offset = 2.5
    assert (r.show.to_relay(10.0), r.show.to_conductor(10.0)) == (10.0, 10.0)


def test_before_the_timebase_the_heartbeat_offset_converts_times() -> None:
    r = Rig(synced=False)
    r.client.link.offset = 2.5
    assert (r.show.to_relay(10.0), r.show.to_conductor(12.5)) == (12.5, 10.0)
    r.show.once("pause", 20.0)
    assert r.sent("pause")[0]["at"] == 22.5


# --- heartbeat answers ---------------------------------------------------------------------------

def test_begin_restarts_the_heartbeats_with_the_show_watchdog() -> None:
    r = Rig(watchdog=0.25)
    r.client.start_heartbeat(period=10.0, watchdog=10.0)
    first = r.client._beat
    r.show.begin()
    try:
        assert r.client._beat is not first
        wait_until(lambda: len(r.session.of("heartbeat")) >= 3, timeout=5.0)
        # Every watchdog / 5 (50 ms), each waiting the watchdog for its answer.
        assert all(q["op"] == "heartbeat" for q in r.sent("heartbeat"))
        assert {q.timeout for q in r.session.of("heartbeat")[1:]} == {0.25}
    finally:
        r.close()


def test_the_relay_rows_become_each_performer_state_and_progress(rig: Rig) -> None:
    rex, lola = rig.performers["rex"], rig.performers["lola"]
    assert rex.state is ExecutorState.IDLE and not rex.done and rex.fault is None
    assert rex.progress == Progress("rex", ExecutorState.IDLE, 0.0, 0, len(rex.schedule.frames),
                                    "", "")
    rig.beat({"t": 100.0, "performers": {
        "dog1": row("running", 1.0, 3, 20, "walk"),
        "dog2": row("paused", 2.0, 5, 20, "sway"),
        "other": row("running"),  # not this show's: ignored
        "bad": "x",
    }})
    assert rex.state is ExecutorState.RUNNING and lola.state is ExecutorState.PAUSED
    rig.clock.advance(0.5)  # the relay's show time runs on for a running performer only
    p = rex.progress
    assert (p.performer, p.state, p.sent, p.total, p.cue) == ("rex", ExecutorState.RUNNING, 3,
                                                             len(rex.schedule.frames), "walk")
    assert p.show_time == pytest.approx(1.5) and p.label == rex.schedule.frames[2].label
    assert lola.progress.show_time == 2.0 and lola.progress.label == lola.schedule.frames[4].label
    assert rig.show.remote("rex") is not None and rig.show.remote("nobody") is None


def test_a_heartbeat_without_a_stamp_is_of_now(rig: Rig) -> None:
    rig.beat({"performers": {"dog1": {"state": "running", "show_time": 1.0}}})
    remote = rig.show.remote("rex")
    assert remote is not None and remote.at == 100.0
    assert (remote.sent, remote.total, remote.cue, remote.fault) == (0, 0, "", None)
    rig.clock.advance(0.25)
    assert rig.performers["rex"].progress.show_time == pytest.approx(1.25)
    rig.beat({"performers": {"dog1": {}}})
    assert rig.performers["rex"].state is ExecutorState.IDLE
    assert rig.performers["rex"].progress.show_time == 0.0


def test_show_times_are_of_the_relay_stamp_on_the_conductor_clock() -> None:
    r = Rig(synced=False)
    r.client.link.offset, r.client.link.best_rtt = 2.0, 0.0  # kept: no faster round trip
    r.show.begin()
    try:
        r.beat({"t": 101.5, "performers": {"dog1": row("running", 1.0)}})
        remote = r.show.remote("rex")
        assert remote is not None and remote.at == pytest.approx(99.5)  # 0.5 s ago here
        assert remote.show_time_at(100.0) == pytest.approx(1.5)
        assert remote.show_time_at(99.0) == 1.0  # never backwards
    finally:
        r.close()


def test_a_label_only_for_frames_the_schedule_has(rig: Rig) -> None:
    rex = rig.performers["rex"]
    n = len(rex.schedule.frames)
    for sent, label in ((0, ""), (1, rex.schedule.frames[0].label),
                        (n, rex.schedule.frames[n - 1].label), (n + 1, "")):
        rig.beat({"performers": {"dog1": row("running", 1.0, sent)}})
        assert rex.progress.label == label, sent


def test_the_relay_events_are_published_renamed_and_on_the_conductor_clock() -> None:
    r = Rig(synced=False)
    r.client.link.offset, r.client.link.best_rtt = 10.0, 0.0  # kept: no faster round trip
    r.show.begin()
    try:
        r.beat({"events": [
            ["t", "dog1", "battery", 80.0, 111.0],
            ["s", "dog2", "running", 0.5, 112.0],
            ["t", "other", "battery", 10.0, 111.0],
            ["t", "dog1", "battery", 79.0, 113.0],
            ["t", "dog1", "roll", 1.5, 113.0],
        ]})
        assert r.of(TelemetryRead) == [TelemetryRead(101.0, "rex", "battery", 80.0),
                                       TelemetryRead(103.0, "rex", "battery", 79.0),
                                       TelemetryRead(103.0, "rex", "roll", 1.5)]
        assert r.of(StateChanged) == [StateChanged(102.0, "lola", ExecutorState.RUNNING, 0.5)]
        assert r.performers["rex"].readings == {"battery": 79.0, "roll": 1.5}
        assert r.show.readings("lola") == {}
        got = r.show.readings("rex")
        got["battery"] = 0.0  # a copy
        assert r.show.readings("rex")["battery"] == 79.0
    finally:
        r.close()


def test_a_relay_fault_event_faults_its_performer_once_naming_the_relay(rig: Rig) -> None:
    rig.beat({"events": [["x", "dog1", "port closed", 100.5], ["x", "dog1", "again", 100.6]]})
    assert rig.of(FaultRaised) == [FaultRaised(100.5, "rex", "on relay hall: port closed")]
    # The same fault in the rows that follow is not published again.
    rig.beat({"performers": {"dog1": row("failed", fault="port closed")}})
    assert len(rig.of(FaultRaised)) == 1
    rex = rig.performers["rex"]
    assert rex.state is ExecutorState.FAILED and rex.done
    assert rex.fault == "on relay hall: port closed"


def test_a_fault_only_in_the_rows_is_published_once_at_now(rig: Rig) -> None:
    rig.beat({"performers": {"dog2": row("failed", fault="battery 5 %")}})
    rig.beat({"performers": {"dog2": row("failed", fault="battery 5 %")}})
    assert rig.of(FaultRaised) == [FaultRaised(100.0, "lola", "on relay hall: battery 5 %")]
    assert rig.performers["rex"].fault is None


def test_events_come_before_the_state_they_lead_to() -> None:
    r = Rig()
    order: list[str] = []
    r.bus.subscribe(lambda e: order.append(
        f"{type(e).__name__} {r.performers['rex'].state.value}"))
    r.show.begin()
    try:
        r.beat({"events": [["s", "dog1", "finished", 1.0, 100.0]],
                "performers": {"dog1": row("finished")}})
        assert order == ["StateChanged idle"]
        assert r.performers["rex"].state is ExecutorState.FINISHED
    finally:
        r.close()


@pytest.mark.parametrize(("last", "states"), [
    ({"completed": True}, ("finished", "finished")),
    ({"completed": False, "faults": {"dog2": "fell"}}, ("stopped", "failed")),
    ({"completed": False, "faults": None}, ("stopped", "stopped")),
])
def test_an_ended_show_ends_every_performer(rig: Rig, last: dict[str, Any],
                                            states: tuple[str, str]) -> None:
    rig.beat({"t": 100.0, "performers": {"dog1": row("running", 4.0, 7, 20, "walk")}})
    rig.clock.advance(1.0)
    rig.beat({"state": "ended", "t": 101.0, "last": {"sha256": SHA, **last}})
    rex, lola = rig.performers["rex"], rig.performers["lola"]
    assert (rex.state.value, lola.state.value) == states
    assert rex.done and lola.done and rex.join(0.0) is True
    rex_remote, lola_remote = rig.show.remote("rex"), rig.show.remote("lola")
    assert rex_remote is not None and lola_remote is not None
    # What was known of the performer stays (its show time frozen where it ended).
    assert (rex_remote.show_time, rex_remote.sent, rex_remote.total, rex_remote.cue) == (
        4.0, 7, 20, "walk")
    assert rex_remote.at == 101.0
    assert (lola_remote.show_time, lola_remote.sent, lola_remote.total, lola_remote.cue) == (
        0.0, 0, 0, "")
    faults = [e for e in rig.of(FaultRaised)]
    if states[1] == "failed":
        assert faults == [FaultRaised(101.0, "lola", "on relay hall: fell")]
        assert lola.fault == "on relay hall: fell"
    else:
        assert faults == []


@pytest.mark.parametrize("status", [
    {"state": "ended", "last": {"sha256": "other", "completed": True}},
    {"state": "ended", "last": None},
    {"state": "idle", "last": {"sha256": SHA, "completed": True}},
])
def test_another_show_ending_ends_nothing(rig: Rig, status: dict[str, Any]) -> None:
    rig.beat(status)
    assert rig.show.remote("rex") is None
    assert rig.performers["rex"].state is ExecutorState.IDLE


def test_a_started_performer_waits_for_the_end(rig: Rig) -> None:
    rex = rig.performers["rex"]
    assert rex.join(0.0) is True  # never started: nothing to wait for
    rex.start(101.0)
    start = time.monotonic()
    assert rex.join(0.1) is False
    assert 0.08 <= time.monotonic() - start < 2.0
    rig.beat({"state": "ended", "last": {"sha256": SHA, "completed": True}})
    assert rex.join(None) is True and rex.join(0.0) is True


# --- losing the relay ----------------------------------------------------------------------------

def test_a_silent_relay_faults_every_performer_once_and_ends_the_show() -> None:
    r = Rig(watchdog=0.15)
    r.show.begin()
    try:
        wait_until(lambda: r.show.lost() is not None, timeout=5.0)
        why = r.show.lost()
        assert why is not None
        ms = int(why.split("no answer for ")[1].split(" ms")[0])
        assert ms >= 150
        assert why == (f"relay hall lost: no answer for {ms} ms (watchdog 150 ms); it applies "
                       "the show's link-loss policy")
        assert r.of(FaultRaised) == [FaultRaised(100.0, "rex", why),
                                     FaultRaised(100.0, "lola", why)]
        rex = r.performers["rex"]
        assert rex.state is ExecutorState.FAILED and rex.fault == why and rex.done
        rex.start(101.0)
        assert rex.join(1.0) is True
        n = len(r.session.queries)
        rex.pause()  # nothing more goes to a lost relay
        assert len(r.session.queries) == n
        stopped = rex.safe_stop("lost")  # nor a stop: its watchdog has stopped the robots
        assert not stopped.ok and stopped.error == why and len(r.session.queries) == n
        r.show.close()  # no release either: its heartbeats stop
        assert len(r.session.queries) == n and r.client._beat is None
    finally:
        r.close()


def test_a_performer_faulted_before_the_relay_was_lost_is_not_faulted_again() -> None:
    r = Rig(watchdog=0.3)
    r.show.begin()
    try:
        r.beat({"events": [["x", "dog1", "fell", 100.0]]})
        wait_until(lambda: r.show.lost() is not None, timeout=5.0)
        assert [e.performer for e in r.of(FaultRaised)] == ["rex", "lola"]
        assert r.performers["rex"].fault == r.show.lost()  # lost says more than the fault
    finally:
        r.close()


# --- commands ------------------------------------------------------------------------------------

def test_a_start_is_sent_once_for_every_performer_of_the_relay(rig: Rig) -> None:
    for p in rig.performers.values():
        p.start(105.0, offset=2.0)
    (start,) = rig.sent("start")
    assert (start["sha256"], start["start_at"], start["offset"]) == (SHA, 105.0, 2.0)
    rig.performers["rex"].start(106.0)
    assert [s["offset"] for s in rig.sent("start")] == [2.0, 0.0]


def test_timed_commands_go_once_per_time_and_value(rig: Rig) -> None:
    rex, lola = rig.performers["rex"], rig.performers["lola"]
    rex.pause(at=101.0)
    lola.pause(at=101.0)
    rex.resume(at=102.0)
    lola.resume(at=102.0)
    rex.seek(3.0, at=103.0)
    lola.seek(3.0, at=103.0)
    rex.seek(4.0, at=103.0)
    assert [(q["op"], q["at"], q.get("show_time")) for q in
            rig.sent("pause") + rig.sent("resume") + rig.sent("seek")] == [
        ("pause", 101.0, None), ("resume", 102.0, None), ("seek", 103.0, 3.0),
        ("seek", 103.0, 4.0)]
    rex.abort()  # nothing to hold back: the relay sends the frames
    rex.close()
    assert len(rig.session.queries) - len(rig.session.of("heartbeat")) == 4


def test_a_command_for_now_acts_one_network_lead_ahead_for_everyone(rig: Rig) -> None:
    rig.client.link.recent.append(0.125)  # network lead 0.375 s (binary fractions: exact)
    rig.performers["rex"].pause()
    rig.clock.advance(0.125)
    rig.performers["lola"].pause()  # before that time: the same command
    (pause,) = rig.sent("pause")
    assert pause["at"] == 100.375
    rig.performers["rex"].resume()  # another op: its own time
    assert rig.sent("resume")[0]["at"] == 100.5
    rig.clock.advance(0.25)  # now exactly that time: a new pause is a new command
    rig.performers["rex"].pause()
    assert [p["at"] for p in rig.sent("pause")] == [100.375, 100.75]
    rig.performers["rex"].seek(1.0)
    rig.performers["lola"].seek(2.0)  # another value: another command, at its own lead
    assert [(s["show_time"], s["at"]) for s in rig.sent("seek")] == [(1.0, 100.75),
                                                                     (2.0, 100.75)]


def test_the_start_reply_says_the_margin(rig: Rig) -> None:
    rig.performers["rex"].start(105.0)
    assert rig.show.start_margin is None
    (q,) = rig.session.held("start")
    q.deliver([answer(q, margin=0.25)])
    assert rig.show.start_margin == 0.25 and rig.show.failed() is None
    rig.performers["rex"].start(106.0)
    q = rig.session.held("start")[0]
    q.deliver([answer(q, margin="soon")])
    assert rig.show.start_margin is None
    rig.performers["rex"].pause(at=107.0)
    q = rig.session.held("pause")[0]
    q.deliver([answer(q, margin=1.0)])  # only a start's margin is kept
    assert rig.show.start_margin is None and rig.of(FaultRaised) == []


def test_a_refused_command_faults_every_performer_once(rig: Rig) -> None:
    rig.performers["rex"].start(105.0)
    (q,) = rig.session.held("start")
    q.deliver([answer(q, error="start too late by 0.2 s")])
    why = "start on relay hall: relay hall: start too late by 0.2 s"
    assert rig.show.failed() == why
    assert rig.of(FaultRaised) == [FaultRaised(100.0, "rex", why),
                                   FaultRaised(100.0, "lola", why)]
    assert rig.performers["lola"].fault == why
    rig.performers["rex"].pause(at=106.0)
    q = rig.session.held("pause")[0]
    q.deliver([])  # unanswered: a second failure, no second fault
    assert rig.show.failed() == why and len(rig.of(FaultRaised)) == 2


def test_a_failure_after_one_performer_faulted_faults_the_others() -> None:
    r = Rig()
    r.show.fail("boom")
    assert r.show.failed() == "boom"
    r2 = Rig()
    r2.show.begin()
    try:
        r2.beat({"events": [["x", "dog1", "fell", 100.0]]})
        r2.clock.advance(1.0)
        r2.show.fail("late")
        assert r2.of(FaultRaised)[1:] == [FaultRaised(101.0, "lola", "late")]
    finally:
        r2.close()


# --- the safe stop -------------------------------------------------------------------------------

def test_a_safe_stop_is_one_stop_command_for_the_relay(rig: Rig) -> None:
    rex, lola = rig.performers["rex"], rig.performers["lola"]
    rig.clock.advance(2.0)
    got = rex.safe_stop("operator", timeout=0.1)
    assert (got.performer, got.reason, got.ok, got.frames, got.error) == (
        "rex", "operator", True, ("relay stop",), "")
    assert 0.0 <= got.elapsed < 2.0
    (stop,) = rig.sent("stop")
    assert stop["reason"] == "operator"
    assert 0.4 < rig.session.of("stop")[0].timeout <= 0.5  # at least half a second
    assert lola.safe_stop("operator").ok and len(rig.sent("stop")) == 1
    assert rex.safe_stop("again") is got and rex.stop_result is got
    assert rex.state is ExecutorState.STOPPED and rex.done
    assert rig.of(SafeStopped) == [SafeStopped(102.0, "rex", got),
                                   SafeStopped(102.0, "lola", lola.stop_result)]


def test_a_safe_stop_waits_as_long_as_asked_beyond_half_a_second() -> None:
    r = Rig()
    r.show.stop("x", 2.0)
    assert 1.9 < r.session.of("stop")[0].timeout <= 2.0


def test_a_robot_the_relay_could_not_stop_fails() -> None:
    r = Rig(stop={"stops": {"dog1": False}})
    got = r.performers["rex"].safe_stop("fault")
    assert not got.ok and got.error == "the relay's safe stop of dog1 failed"
    assert got.frames == ("relay stop",)
    assert r.performers["lola"].safe_stop("fault").ok  # not named: stopped
    assert r.performers["rex"].state is ExecutorState.STOPPED  # it has no fault of its own
    r.show.fail("start on relay hall: refused")
    assert r.performers["rex"].state is ExecutorState.FAILED


def test_a_stop_the_relay_refuses_says_its_watchdog_stops_the_robots() -> None:
    r = Rig(stop="not held")
    got = r.performers["rex"].safe_stop("fault")
    assert not got.ok and got.frames == ()
    assert got.error == ("relay hall: not held (the relay's watchdog stops its robots on its "
                         "own)")
    assert r.show.stop("again", 0.1) == {"error": got.error}
    assert len(r.sent("stop")) == 1


# --- giving the relay up -------------------------------------------------------------------------

def test_closing_releases_the_relay() -> None:
    r = Rig()
    r.show.begin()
    wait_until(lambda: r.session.of("heartbeat"))
    r.show.close()
    assert r.client._beat is None and [q["op"] for q in r.sent("release")] == ["release"]


def test_a_performer_has_the_name_and_model_of_its_schedule(rig: Rig) -> None:
    rex = rig.performers["rex"]
    assert (rex.name, rex.model) == ("rex", "mini")
    assert isinstance(rex.schedule, PerformerSchedule) and rex.stop_result is None


def test_an_unanswered_send_is_a_network_error_fault(rig: Rig) -> None:
    rig.performers["rex"].resume(at=101.0)
    (q,) = rig.session.held("resume")
    q.deliver([])
    failed = rig.show.failed()
    assert failed is not None and failed.startswith(
        "resume on relay hall: relay hall did not answer resume within 1 s")
    assert isinstance(NetworkError(failed), NetworkError)


# --- what the first mutation run showed unchecked ------------------------------------------------

def test_a_relay_show_is_synced_unless_told_otherwise() -> None:
    r = Rig()
    show = RelayShow(r.client, NAMES, SHA, clock=r.clock, events=r.bus, watchdog=1.0)
    r.client.link.offset = 2.5
    assert show.synced and show.to_relay(10.0) == 10.0


def test_the_show_heartbeats_go_every_fifth_of_the_watchdog() -> None:
    r = Rig(watchdog=0.25)
    r.session.hold = False  # answered at once: the relay is not lost
    start = time.monotonic()
    r.show.begin()
    time.sleep(1.0)
    r.close()
    slots = (time.monotonic() - start) / 0.05
    # A slot missed under load is made up: the count follows the clock, not the waits.
    assert slots * 0.6 <= len(r.session.of("heartbeat")) <= slots + 1


def test_the_loss_message_gives_the_silence_and_the_watchdog_in_ms() -> None:
    r = Rig(watchdog=2.0)
    r.show._on_lost(1.0)  # what the heartbeats' watchdog calls
    assert r.show.lost() == ("relay hall lost: no answer for 1000 ms (watchdog 2000 ms); it "
                             "applies the show's link-loss policy")


def test_a_repeated_relay_fault_does_not_hide_the_events_after_it(rig: Rig) -> None:
    rig.beat({"events": [["x", "dog1", "a", 100.0], ["x", "dog1", "b", 100.1],
                         ["t", "dog1", "battery", 50.0, 100.2]]})
    assert len(rig.of(FaultRaised)) == 1 and rig.performers["rex"].readings == {"battery": 50.0}


def test_a_command_for_now_with_another_value_gets_its_own_time(rig: Rig) -> None:
    rig.client.link.recent.append(0.125)  # network lead 0.375 s
    rig.performers["rex"].seek(1.0)
    rig.clock.advance(0.125)
    rig.performers["rex"].seek(2.0)  # not the same command: at its own now + lead
    assert [s["at"] for s in rig.sent("seek")] == [100.375, 100.5]


def test_a_stop_reply_without_stops_stops_every_robot() -> None:
    r = Rig(stop={})
    got = r.performers["rex"].safe_stop("x")
    assert got.ok and got.error == "" and got.elapsed > 0
    assert r.show.stop("again", 0.1) == {"stops": {}}


def test_a_safe_stop_waits_half_a_second_by_default() -> None:
    r = Rig()
    r.performers["lola"].safe_stop("x")
    assert 0.4 < r.session.of("stop")[0].timeout <= 0.5


def test_a_failed_safe_stop_names_the_performer_and_its_reason() -> None:
    r = Rig(stop="not held")
    got = r.performers["lola"].safe_stop("fault")
    assert (got.performer, got.reason, got.ok) == ("lola", "fault", False)
    assert isinstance(got.elapsed, float) and got.elapsed > 0
    ok = Rig().performers["rex"].safe_stop("operator")
    assert isinstance(ok.elapsed, float) and ok.elapsed > 0


def test_the_lead_of_a_mid_show_start_includes_the_catch_up() -> None:
    r = Rig()
    rex = r.performers["rex"]
    assert rex.lead_time(0.5) == pytest.approx(r.show.lead() + executor_lead(rex.schedule, 0.5))
    assert rex.lead_time(0.5) > rex.lead_time(0.0)


def later(r: Rig, status: dict[str, Any], after: float = 0.1) -> threading.Thread:
    def go() -> None:
        time.sleep(after)
        r.beat(status)

    t = threading.Thread(target=go)
    t.start()
    return t


def test_join_without_a_timeout_waits_for_the_end(rig: Rig) -> None:
    rex = rig.performers["rex"]
    rex.start(101.0)
    t = later(rig, {"state": "ended", "last": {"sha256": SHA, "completed": True}})
    assert rex.join(None) is True and rex.done
    t.join()


@pytest.mark.parametrize("timeout", [None, 5.0])
def test_a_performer_finished_on_the_relay_ends_its_join_at_once(rig: Rig,
                                                                timeout: float | None) -> None:
    rex = rig.performers["rex"]
    rex.start(101.0)
    t = later(rig, {"performers": {"dog1": row("finished")}})  # the show is not over yet
    start = time.monotonic()
    assert rex.join(timeout) is True
    t.join()
    assert time.monotonic() - start < 0.7  # polled every 20 ms, not every second
