"""A relay's Zenoh side (relay/server.py's ``start``, its queryables, the command worker, the
time-sync hook, ``finish`` and ``close``) and a remote behaviour's stage commands, in this
process: the relay runs its own code over the recording double of the session and the queries
(tests/relay/recording.py), the lowest layer only. What keys it serves and withdraws, who
answers a command (the worker, in order; a heartbeat at once), that a wildcard listing gets
each relay's own key, that only the holder's timebase is followed (and counts as hearing it),
and what ``finish`` waits for. test_relay_server.py covers the same over real Zenoh sessions
with relays in their own processes; mutmut's forked tests cannot use those (contributing.md).
"""

from __future__ import annotations

import itertools
import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from tests.conftest import wait_until
from xgo_show.errors import RelayRefused
from xgo_show.net import messages as msg
from xgo_show.net.slew import SlewingClock
from xgo_show.net.testhooks import DelayInjector, SkewedClock
from xgo_show.relay import server
from xgo_show.relay.robots import OwnedRobot, close_robots, open_robots
from xgo_show.relay.server import Relay, RelayState
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.runlog import RunLog

from .conftest import upload_text, walk_schedule
from .handling import ALICE, BOB, encoded, request, start
from .recording import Incoming, RecordingSession, record_threads

#: A started relay, its session and its log.
Served = tuple[Relay, RecordingSession, RunLog]

KEY = {part: f"ns/relay/hall/{part}" for part in ("cmd", "info", "time", "alive")}
WORKER = "xgo-show relay commands"


@pytest.fixture
def robots() -> Iterator[dict[str, OwnedRobot]]:
    owned = open_robots({"rex": "sim:mini", "lola": "sim:lite"}, {})
    yield owned
    close_robots(owned)


def served(robots: dict[str, OwnedRobot], **options: Any) -> Served:
    """A relay named hall in namespace ns, started over a recording session."""
    session, log = RecordingSession(), RunLog(None, keep=True)
    relay = Relay(session, "hall", robots, namespace="ns", log=log, **options)  # type: ignore[arg-type]
    return relay.start(), session, log


@pytest.fixture
def relay(robots: dict[str, OwnedRobot]) -> Iterator[Served]:
    got = served(robots)
    yield got
    got[0].close()


def events(log: RunLog, name: str) -> list[dict[str, Any]]:
    """The log's ``name`` events without their kind, name and clock time."""
    return [{k: v for k, v in r.items() if k not in ("kind", "mono", "event")}
            for r in log.events(name)]


@pytest.fixture(autouse=True)
def patient_watchdog(monkeypatch: pytest.MonkeyPatch) -> None:
    """A holder's watchdog of 60 s from its hello on: these tests send no heartbeats, and on a
    loaded machine (a mutation run at idle priority) 500 ms can pass between two lines of a
    test. test_relay_handling.py checks the 500 ms default and what a silence does."""
    monkeypatch.setattr(server, "DEFAULT_WATCHDOG_MS", 60_000)


def hold(r: Relay, who: msg.Conductor = ALICE) -> None:
    """``who`` holds ``r``."""
    r.handle(request("hello", who))
    assert r._holder is not None and r._holder.watchdog.timeout == 60.0


def worker() -> threading.Thread:
    (th,) = [t for t in threading.enumerate() if t.name == WORKER]
    return th


# --- what it declares, and withdraws ---------------------------------------------------------

def test_start_serves_the_relays_keys_and_close_withdraws_them(
    robots: dict[str, OwnedRobot],
) -> None:
    relay, session, log = served(robots)
    assert session.declarations() == [("queryable", KEY["time"]), ("queryable", KEY["cmd"]),
                                ("queryable", KEY["info"]), ("token", KEY["alive"])]
    assert events(log, "relay_start") == [{"relay": "hall", "robots": ["rex", "lola"],
                                           "instance": relay.instance}]
    th = worker()
    assert th.daemon and th.is_alive()
    relay.close("bye")
    # The token first: a conductor stops seeing the relay before its queries go unanswered.
    assert session.undeclared == [("token", KEY["alive"]), ("queryable", KEY["info"]),
                                  ("queryable", KEY["cmd"]), ("queryable", KEY["time"])]
    assert not th.is_alive()  # the worker was told to end, and was waited for
    assert events(log, "safe_stop") == [{"relay": "hall", "reason": "bye",
                                         "ok": {"rex": True, "lola": True}}]
    assert events(log, "relay_stop") == [{"relay": "hall", "reason": "bye"}]
    relay.close("again")  # once closed, closing does nothing
    assert len(session.undeclared) == 4 and len(events(log, "relay_stop")) == 1


def test_a_relay_that_cannot_be_undeclared_still_closes(robots: dict[str, OwnedRobot]) -> None:
    relay, _, log = served(robots)

    def closed_session() -> None:
        raise RuntimeError("session closed")

    for entity in relay._declared:
        entity.undeclare = closed_session  # type: ignore[method-assign]
    relay.close("bye")
    assert events(log, "relay_stop") == [{"relay": "hall", "reason": "bye"}]


# --- info and commands -----------------------------------------------------------------------

def test_info_answers_a_wildcard_listing_on_the_relays_own_key(
    relay: Served,
) -> None:
    r, session, _ = relay
    q = Incoming("ns/relay/*/info", None)  # a listing: every relay answers the same query
    session.queryables[KEY["info"]](q)
    ((key, data),) = q.replies
    assert key == KEY["info"]
    got = json.loads(data)
    want = r.describe()
    assert abs(got.pop("relay_time") - want.pop("relay_time")) < 1.0
    assert got == want and got["relay"] == "hall" and got["state"] == RelayState.IDLE


def test_commands_are_answered_by_the_worker_one_at_a_time_in_order(
    relay: Served, monkeypatch: pytest.MonkeyPatch,
) -> None:
    r, session, _ = relay
    hold(r)  # the hello below is the holder's again
    order = itertools.count()
    answered: list[tuple[int, int]] = []  # (seq, order of the answer)
    ran: list[str] = []
    real_reply = Incoming.reply

    def reply(self: Incoming, key: str, data: bytes, *, express: bool = False) -> None:
        answered.append((msg.decode_reply(data).seq, next(order)))
        ran.append(threading.current_thread().name)
        real_reply(self, key, data, express=express)

    monkeypatch.setattr(Incoming, "reply", reply)
    cmd = session.queryables[KEY["cmd"]]
    queries = [Incoming(KEY["cmd"], encoded("hello", seq=1)),
               Incoming(KEY["cmd"], encoded("probe", seq=2, performer="rex")),
               Incoming(KEY["cmd"], encoded("stop", seq=3, reason="x")),
               Incoming(KEY["cmd"], None)]
    for q in queries:
        cmd(q)
    for q in queries:
        assert q.done.wait(10.0)
    assert [seq for seq, _ in answered] == [1, 2, 3, -1]
    assert ran == [WORKER] * 4
    assert [q.answer()["ok"] for q in queries] == [True, True, True, False]
    stopped = msg.decode_reply(queries[2].replies[0][1])
    assert stopped.fields == {"stops": {"rex": True, "lola": True}}


def test_a_heartbeat_is_answered_at_once_in_the_callers_thread(
    relay: Served,
) -> None:
    r, session, _ = relay
    hold(r)
    beat = Incoming(KEY["cmd"], encoded("heartbeat", seq=5))
    session.queryables[KEY["cmd"]](beat)
    assert beat.replies and beat.threads == [threading.current_thread().name]
    assert beat.answer()["seq"] == 5 and beat.answer()["show"]["state"] == "idle"


def test_heartbeats_pings_and_listings_hold_off_while_a_writer_is_due_other_commands_do_not(
    robots: dict[str, OwnedRobot], monkeypatch: pytest.MonkeyPatch,
) -> None:
    held: list[str] = []  # the thread of each hold-off (Zenoh's callback thread, here ours)
    monkeypatch.setattr(SlewingClock, "hold_off",
                        lambda self: held.append(threading.current_thread().name))
    r, session, _ = served(robots)
    try:
        hold(r)
        assert held == []
        beat = Incoming(KEY["cmd"], encoded("heartbeat", seq=5))
        session.queryables[KEY["cmd"]](beat)
        assert held == [threading.current_thread().name] and beat.answer()["ok"]
        ping = json.dumps({"v": 1, "op": "ping", "seq": 3}).encode()
        assert session.query(KEY["time"], ping, wait=5.0).replies
        assert len(held) == 2
        listing = Incoming("ns/relay/*/info", None)
        session.queryables[KEY["info"]](listing)
        assert len(held) == 3 and listing.replies
        probe = Incoming(KEY["cmd"], encoded("probe", seq=6, performer="rex"))
        session.queryables[KEY["cmd"]](probe)  # the worker's: a stop must not wait
        assert probe.done.wait(10.0) and probe.answer()["ok"]
        assert len(held) == 3
    finally:
        r.close()


# --- time sync -------------------------------------------------------------------------------

def timebase(who: msg.Conductor = ALICE, offset: float = -50.0, **fields: float) -> bytes:
    tb = {"offset": offset, "rate": 0.0, "ref": 0.0, "bound": 1e-4, "rate_bound": 1e-6, **fields}
    return json.dumps({"v": 1, "op": "timebase", "conductor": who.id, **tb}).encode()


def test_only_the_holders_timebase_is_followed(relay: Served) -> None:
    r, session, _ = relay
    refused = "relay hall: timebase from a conductor that does not hold it"
    q = session.query(KEY["time"], timebase(), wait=5.0)  # nobody holds the relay yet
    assert [json.loads(e) for e in q.errors] == [{"v": 1, "error": refused}]
    hold(r)
    q = session.query(KEY["time"], timebase(BOB), wait=5.0)
    assert [json.loads(e) for e in q.errors] == [{"v": 1, "error": refused}]
    assert r.clock.timebase is None and q.replies == []
    q = session.query(KEY["time"], timebase(), wait=5.0)
    assert q.errors == [] and [json.loads(d) for _, d in q.replies] == [
        {"v": 1, "ok": True, "correction": 0.0}]  # the first is set at once
    assert r.clock.timebase is not None and r.clock.timebase.offset == -50.0
    assert abs(r.clock.now() - (r.base.now() + 50.0)) < 0.5
    q = session.query(KEY["time"], timebase(offset=-50.002), wait=5.0)
    (correction,) = [json.loads(d)["correction"] for _, d in q.replies]
    assert correction == pytest.approx(0.002, abs=1e-5)  # the next one is slewed to


def test_a_holders_timebase_counts_as_hearing_from_it(
    relay: Served,
) -> None:
    r, session, _ = relay
    hold(r)
    assert r._holder is not None
    heard = r._holder.watchdog.last_heard
    time.sleep(0.02)
    session.query(KEY["time"], timebase(), wait=5.0)
    assert r._holder.watchdog.last_heard >= heard + 0.02


def test_pings_are_stamped_with_this_hosts_clock_not_the_show_clock(
    robots: dict[str, OwnedRobot],
) -> None:
    base = SkewedClock(MonotonicClock(), offset=1000.0)
    r, session, _ = served(robots, clock=base)
    try:
        hold(r)
        # The show clock: base - 400 s.
        session.query(KEY["time"], timebase(offset=-400.0), wait=5.0)
        before = base.now()
        ping = json.dumps({"v": 1, "op": "ping", "seq": 3}).encode()
        q = session.query(KEY["time"], ping, wait=5.0)
        after = base.now()
        ((key, data),) = q.replies
        got = json.loads(data)
        assert key == KEY["time"] and got["seq"] == 3 and q.express == [True]
        assert before <= got["t1"] <= got["t2"] <= after
        assert abs(r.clock.now() - (base.now() + 400.0)) < 0.5
    finally:
        r.close()


def test_a_sync_delay_holds_ping_replies_back(robots: dict[str, OwnedRobot]) -> None:
    r, session, _ = served(robots, sync_delay=DelayInjector(0.05))
    try:
        q = Incoming(KEY["time"], json.dumps({"v": 1, "op": "ping", "seq": 1}).encode())
        sent = time.monotonic()
        session.queryables[KEY["time"]](q)
        assert q.replies == []  # not from the callback
        assert q.done.wait(5.0)
        assert time.monotonic() - sent >= 0.05
        assert q.threads == ["xgo-show time-sync delay"] and q.dropped.is_set()
    finally:
        r.close()


# --- finish: the conductor is gone for good --------------------------------------------------

def upload_for(r: Relay, link_loss: str, seconds: float) -> str:
    text, sha = upload_text(walk_schedule(seconds, rex="mini"))
    r.handle(request("upload", schedule=text, sha256=sha, link_loss=link_loss,
                     watchdog_ms=60000))
    return sha


def test_finish_between_shows_leaves_the_robots_as_they_are(
    relay: Served,
) -> None:
    r, session, log = relay
    r.finish("conductor gone")
    assert events(log, "safe_stop") == [] and events(log, "finishing") == []
    assert events(log, "relay_stop") == [{"relay": "hall", "reason": "conductor gone"}]
    assert len(session.undeclared) == 4


def test_finish_plays_a_continue_show_to_its_end_first(
    relay: Served,
) -> None:
    r, _, log = relay
    hold(r)
    sha = upload_for(r, "continue", 0.6)
    start(r, sha, offset=0.0, start_in=0.2)
    r.finish("conductor gone")
    assert events(log, "finishing") == [{"relay": "hall", "reason": "conductor gone"}]
    last = r.describe()["last"]
    assert last is not None and last["completed"] is True and last["sha256"] == sha
    assert events(log, "safe_stop") == []


def test_finish_stops_a_stop_show_at_once(relay: Served) -> None:
    r, _, log = relay
    hold(r)
    sha = upload_for(r, "stop", 5.0)
    start(r, sha, offset=0.0, start_in=0.2)
    began = time.monotonic()
    r.finish("conductor gone")
    assert time.monotonic() - began < 3.5  # not played to its end (5 s)
    assert events(log, "finishing") == []
    last = r.describe()["last"]
    assert last is not None and last["completed"] is False
    assert last["reason"] == "conductor gone" and last["stops"] == {"rex": True}


def played(r: Relay) -> None:
    """Hold ``r``, play a 0.3 s show on it and wait for its end."""
    hold(r)
    sha = upload_for(r, "stop", 0.3)
    start(r, sha, offset=0.0, start_in=0.2)
    wait_until(lambda: r.describe()["state"] == RelayState.ENDED, timeout=5.0)


def test_a_trace_logs_each_robots_first_frame(robots: dict[str, OwnedRobot]) -> None:
    for trace in (True, False):
        r, _, log = served(robots, trace=trace)
        try:
            played(r)
        finally:
            r.close()
        assert [e["performer"] for e in events(log, "first_frame")] == (["rex"] if trace
                                                                        else [])


# --- a remote behaviour's stage --------------------------------------------------------------

def test_a_stage_opens_for_the_holder_and_keeps_shows_out(
    relay: Served,
) -> None:
    r, _, _ = relay
    hold(r)
    got = r.handle(request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=20000))
    assert got == {"robots": ["rex"]}
    stage = r._stage
    assert stage is not None and stage.open
    assert stage.clock is r.clock and stage.events is r.events and stage.allow_unsafe is False
    assert r._holder is not None and r._holder.watchdog.timeout == 20.0
    status = r.handle(request("heartbeat"))["show"]
    assert status["stage"] == {"open": True, "ended": []}
    for op, fields in (("upload", {"schedule": "x", "sha256": "0" * 64, "link_loss": "stop",
                                   "watchdog_ms": 500}),
                       ("start", {"sha256": "0" * 64, "offset": 0.0, "start_in": 1.0})):
        with pytest.raises(RelayRefused) as info:
            r.handle(request(op, **fields))
        assert str(info.value) == f"{op}: a behaviour's stage is open on this relay"
    r.handle(request("stage_rest", robots=["rex"]))  # the same stage serves the next command
    assert r._stage is stage


def test_a_release_closes_the_stage(relay: Served) -> None:
    r, _, _ = relay
    hold(r)
    r.handle(request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=500))
    stage = r._stage
    assert stage is not None
    r.handle(request("release"))
    assert r._stage is None
    wait_until(lambda: not stage.open, timeout=5.0)


def test_a_stop_closes_the_stage_then_stops_every_robot(
    relay: Served,
) -> None:
    r, _, _ = relay
    hold(r)
    r.handle(request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=500))
    stage = r._stage
    assert stage is not None
    assert r.handle(request("stop", reason="x")) == {"stops": {"rex": True, "lola": True}}
    assert r._stage is None and not stage.open
    assert "stage" not in r.handle(request("heartbeat"))["show"]


def test_stage_commands_are_refused_while_a_show_runs(
    relay: Served,
) -> None:
    r, _, _ = relay
    hold(r)
    sha = upload_for(r, "stop", 2.0)
    start(r, sha, offset=0.0, start_in=0.2)
    with pytest.raises(RelayRefused) as info:
        r.handle(request("stage_open", robots=["rex"], telemetry=0.25, watchdog_ms=500))
    assert str(info.value) == "stage_open: a show is running on this relay"
    assert r._stage is None


# --- what the first mutation run with these tests showed --------------------------------------

def test_a_silence_between_shows_says_how_long_to_the_microsecond(
    relay: Served,
) -> None:
    r, _, log = relay
    hold(r)
    upload_for(r, "stop", 0.3)  # loaded, not playing: nothing to stop, no policy
    r._on_silence(ALICE, 0.1234567)
    assert events(log, "link_lost") == [{"conductor": "alice", "silent_ms": 123.457,
                                         "policy": None}]
    assert events(log, "release")[-1]["reason"] == "conductor silent for 123 ms"
    assert r.describe()["state"] == RelayState.IDLE and events(log, "safe_stop") == []


def test_a_silence_during_a_stop_show_names_the_conductor_and_how_long(
    relay: Served,
) -> None:
    r, _, log = relay
    hold(r)
    sha = upload_for(r, "stop", 5.0)
    start(r, sha, offset=0.0, start_in=0.2)
    r._on_silence(ALICE, 0.4567)
    assert events(log, "link_lost") == [{"conductor": "alice", "silent_ms": 456.7,
                                         "policy": "stop"}]
    last = r.describe()["last"]
    assert last is not None and last["reason"] == "link lost: conductor alice silent for 457 ms"


def test_a_heartbeat_during_a_show_reports_each_robot(
    relay: Served,
) -> None:
    r, _, _ = relay
    hold(r)
    sha = upload_for(r, "stop", 2.0)
    start(r, sha, offset=0.0, start_in=0.2)
    status = r.handle(request("heartbeat"))["show"]
    assert isinstance(status["show_time"], float)
    rex = status["performers"]["rex"]
    assert set(rex) == {"state", "show_time", "sent", "total", "cue", "fault"}
    assert isinstance(rex["state"], str) and isinstance(rex["show_time"], float)
    assert isinstance(rex["sent"], int) and rex["fault"] is None


def test_timed_commands_reach_the_runner_at_their_time(
    relay: Served, monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xgo_show.runtime.show_runner import ShowRunner

    r, _, _ = relay
    calls: list[tuple[str, tuple[Any, ...], dict[str, Any]]] = []
    for name in ("pause", "resume", "seek"):
        monkeypatch.setattr(ShowRunner, name, lambda self, *a, name=name, **k:
                            calls.append((name, a, k)))
    hold(r)
    sha = upload_for(r, "stop", 5.0)
    start(r, sha, offset=0.0, start_in=0.2)
    at = r.clock.now() + 10.0
    r.handle(request("pause", at=at))
    r.handle(request("resume", at=at + 1))
    r.handle(request("seek", show_time=1.5, at=at + 2))
    assert calls == [("pause", (), {"at": at}), ("resume", (), {"at": at + 1}),
                     ("seek", (1.5,), {"at": at + 2})]


def test_a_probe_names_the_model_the_relay_was_given_and_waits_for_the_show(
    relay: Served,
) -> None:
    r, _, _ = relay
    hold(r)
    rows = dict(r.handle(request("probe", performer="rex"))["rows"])
    assert rows["model"] == "mini"  # given, not "(from firmware)"
    sha = upload_for(r, "stop", 2.0)
    start(r, sha, offset=0.0, start_in=0.2)
    with pytest.raises(RelayRefused) as info:
        r.handle(request("probe", performer="rex"))
    assert str(info.value) == "probe: a show is running on relay hall"


def test_a_release_stops_the_old_watchdog_in_a_daemon_thread_of_its_own(
    relay: Served, monkeypatch: pytest.MonkeyPatch,
) -> None:
    r, _, _ = relay
    hold(r)
    made = record_threads(monkeypatch, server)
    r.handle(request("release"))
    assert made == [("xgo-show watchdog stop", True)]
