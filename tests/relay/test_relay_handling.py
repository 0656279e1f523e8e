"""A relay's command handling (relay/server.py), in this process without Zenoh: the relay is
built over robots on in-process simulators and given decoded requests (``handle``) or raw
query payloads (``_reply``, as its queryable does). Who may command it, what each op answers
or refuses and in which words, the show states, and the link-loss policy when the holder goes
silent. test_relay_server.py covers the same over Zenoh with relays in their own processes."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Iterator
from typing import Any

import pytest

from xgo_show.errors import RelayRefused
from xgo_show.net import messages as msg
from xgo_show.relay.robots import OwnedRobot, close_robots, open_robots
from xgo_show.relay.server import DEFAULT_WATCHDOG_MS, Relay, RelayState
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.show_runner import ShowRunner

from .conftest import upload_text, walk_schedule
from .handling import ALICE, BOB, CMD, request, start, upload
from .recording import Incoming


@pytest.fixture
def robots() -> Iterator[dict[str, OwnedRobot]]:
    owned = open_robots({"rex": "sim:mini", "lola": "sim:lite"}, {})
    yield owned
    close_robots(owned)


@pytest.fixture
def relay(robots: dict[str, OwnedRobot]) -> Iterator[Relay]:
    r = Relay(None, "hall", robots)  # type: ignore[arg-type]  # no Zenoh: never started
    yield r
    r.close()


# --- who may command it ----------------------------------------------------------------------

def test_the_first_hello_holds_the_relay_and_gets_its_description(relay: Relay) -> None:
    got = relay.handle(request("hello"))
    d = got["description"]
    assert d["relay"] == "hall" and d["holder"] == {"id": "a1", "name": "alice"}
    assert d["state"] == RelayState.IDLE and d["last"] is None and d["v"] == msg.PROTOCOL_VERSION
    assert d["allow_unsafe"] is False and d["instance"] == relay.instance
    assert [r["name"] for r in d["robots"]] == ["rex", "lola"]
    assert all(r["state"] == "idle" for r in d["robots"])
    assert relay.handle(request("hello"))["description"]["holder"]["id"] == "a1"  # again


def test_another_conductor_is_refused_while_one_holds_it(relay: Relay) -> None:
    relay.handle(request("hello"))
    for op, fields in (("hello", {}), ("heartbeat", {}), ("stop", {"reason": "x"})):
        with pytest.raises(RelayRefused) as info:
            relay.handle(request(op, BOB, **fields))
        held = ("relay hall is held by conductor 'alice' (id a1); it serves one conductor at "
                "a time")
        assert str(info.value) == (held if op == "hello" else f"{op}: {held}")


def test_a_command_before_hello_is_refused(relay: Relay) -> None:
    with pytest.raises(RelayRefused) as info:
        relay.handle(request("stop", reason="x"))
    assert str(info.value) == "stop: this conductor does not hold relay hall; send hello first"
    assert relay.describe()["holder"] is None


def test_release_lets_another_conductor_hold_it(relay: Relay) -> None:
    relay.handle(request("hello"))
    assert relay.handle(request("release")) == {}
    assert relay.describe()["holder"] is None
    assert relay.handle(request("hello", BOB))["description"]["holder"]["name"] == "bob"


def test_a_heartbeat_answers_with_the_show_status(relay: Relay) -> None:
    relay.handle(request("hello"))
    show = relay.handle(request("heartbeat"))["show"]
    assert show["state"] == RelayState.IDLE and show["last"] is None
    assert show["events"] == [] and show["dropped"] == 0
    assert abs(show["t"] - relay.clock.now()) < 1.0
    assert "performers" not in show and "stage" not in show


def test_an_op_the_relay_does_not_serve_is_refused(relay: Relay) -> None:
    relay.handle(request("hello"))
    bare = msg.Request("dance", 1, ALICE, 1.0)  # decode_request would refuse it already
    with pytest.raises(RelayRefused, match=r"^dance: not supported by this relay$"):
        relay.handle(bare)


def test_a_silent_holder_is_let_go_after_the_default_watchdog(relay: Relay) -> None:
    assert DEFAULT_WATCHDOG_MS == 500
    relay.handle(request("hello"))
    deadline = time.monotonic() + 3.0
    while relay.describe()["holder"] is not None:
        assert time.monotonic() < deadline, "the silent holder was kept"
        time.sleep(0.01)
    relay.handle(request("hello", BOB))  # free again


# --- replies as the queryable sends them -----------------------------------------------------

def test_a_reply_echoes_the_sequence_number_with_the_ops_fields(relay: Relay) -> None:
    q = Incoming(CMD, msg.encode(request("hello", seq=7).to_json()))
    relay._reply(q, q.payload.to_bytes())  # type: ignore[union-attr]
    answer = q.answer()
    msg.decode_reply(q.replies[0][1])  # as the conductor reads it
    assert (answer["seq"], answer["ok"], answer["error"], answer["relay"]) == (7, True, None,
                                                                              "hall")
    assert answer["description"]["holder"]["name"] == "alice"
    assert abs(answer["relay_time"] - relay.clock.now()) < 1.0


def test_a_refusal_is_an_error_reply_with_the_sequence_number(relay: Relay) -> None:
    q = Incoming(CMD, msg.encode(request("stop", seq=9, reason="x").to_json()))
    relay._reply(q, q.payload.to_bytes())  # type: ignore[union-attr]
    answer = q.answer()
    assert (answer["seq"], answer["ok"]) == (9, False)
    assert answer["relay"] == "hall" and abs(answer["relay_time"] - relay.clock.now()) < 1.0
    assert answer["error"] == "stop: this conductor does not hold relay hall; send hello first"


def test_an_unreadable_request_gets_an_error_reply_without_a_sequence_number(relay: Relay
                                                                             ) -> None:
    q = Incoming(CMD, b"{not json")
    relay._reply(q, b"{not json")
    answer = q.answer()
    assert (answer["seq"], answer["ok"]) == (-1, False)
    assert answer["relay"] == "hall" and abs(answer["relay_time"] - relay.clock.now()) < 1.0
    assert answer["error"].startswith("not a JSON message")


def test_a_bug_is_an_internal_error_reply_and_the_relay_keeps_serving(
    relay: Relay, monkeypatch: pytest.MonkeyPatch
) -> None:
    logged: list[tuple[str, dict[str, Any]]] = []
    relay.log = RunLog(None, keep=False)
    monkeypatch.setattr(relay.log, "event", lambda kind, **f: logged.append((kind, f)))

    def broken(request: msg.Request) -> dict[str, Any]:
        raise KeyError("oops")

    monkeypatch.setattr(relay, "handle", broken)
    q = Incoming(CMD, msg.encode(request("hello", seq=3).to_json()))
    relay._reply(q, q.payload.to_bytes())  # type: ignore[union-attr]
    answer = q.answer()
    assert (answer["seq"], answer["ok"]) == (3, False)
    assert answer["relay"] == "hall" and abs(answer["relay_time"] - relay.clock.now()) < 1.0
    assert answer["error"] == "internal error: KeyError('oops')"
    assert logged == [("internal_error", {"error": "KeyError('oops')"})]


def test_a_reading_that_is_not_a_number_is_an_error_reply_not_a_crash(
    relay: Relay, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(relay, "handle", lambda request: {"battery": math.nan})
    q = Incoming(CMD, msg.encode(request("hello", seq=4).to_json()))
    relay._reply(q, q.payload.to_bytes())  # type: ignore[union-attr]
    answer = q.answer()
    assert (answer["seq"], answer["ok"]) == (4, False)
    assert answer["relay"] == "hall" and abs(answer["relay_time"] - relay.clock.now()) < 1.0
    assert "JSON compliant" in answer["error"]


def test_heartbeats_are_answered_at_once_and_the_rest_in_order(relay: Relay) -> None:
    relay.handle(request("hello"))
    beat = Incoming(CMD, msg.encode(request("heartbeat", seq=2).to_json()))
    relay._on_command(beat)  # type: ignore[arg-type]
    assert beat.answer()["show"]["state"] == RelayState.IDLE
    hello = Incoming(CMD, msg.encode(request("hello", seq=3).to_json()))
    relay._on_command(hello)  # type: ignore[arg-type]
    assert hello.replies == []  # queued for the worker
    assert relay._work.get_nowait() is hello
    empty = Incoming(CMD, None)
    relay._reply(empty, b"")
    assert empty.answer()["ok"] is False


# --- shows -----------------------------------------------------------------------------------

def test_an_upload_is_checked_and_loaded(relay: Relay) -> None:
    relay.handle(request("hello"))
    got = upload(relay, battery_floor=15.0)
    assert got["preflight_ok"] is True
    assert [row["performer"] for row in got["preflight"]] == ["rex"]
    row = got["preflight"][0]
    assert (row["model"], row["port"], row["opened"]) == ("mini", "sim:mini", True)
    assert set(row) == {"performer", "model", "port", "opened", "firmware", "detected",
                        "battery", "voltage", "low_latency", "problems", "notes"}
    assert relay.describe()["state"] == RelayState.LOADED
    assert relay._show is not None and relay._show.battery_floor == 15.0
    assert relay._show.link_loss == "stop"


def test_a_start_is_refused_unless_its_time_leaves_the_robots_their_lead(relay: Relay
                                                                         ) -> None:
    relay.handle(request("hello"))
    sha = upload(relay)["sha256"]
    now = relay.clock.now()
    cases = [
        ({"offset": 0.0}, "start: give start_at or start_in (not both)"),
        ({"offset": 0.0, "start_at": now + 5, "start_in": 1.0},
         "start: give start_at or start_in (not both)"),
        ({"offset": 0.3, "start_in": 5.0}, "start: offset 0.3 s is outside the show"),
        ({"offset": -0.1, "start_in": 5.0}, "start: offset -0.1 s is outside the show"),
    ]
    for fields, error in cases:
        with pytest.raises(RelayRefused) as info:
            start(relay, sha, **fields)
        assert str(info.value) == error
    with pytest.raises(RelayRefused, match=r"^start: no uploaded show with SHA-256 0{12}\.\.\.$"):
        start(relay, "0" * 64, offset=0.0, start_in=5.0)
    with pytest.raises(RelayRefused) as info:
        start(relay, sha, offset=0.0, start_at=now - 0.5)
    late = re.fullmatch(r"start: the start time passed (\d+\.\d) ms ago \(give a longer lead "
                        r"time\)", str(info.value))
    assert late is not None and 500 <= float(late.group(1)) < 1500
    with pytest.raises(RelayRefused) as info:
        start(relay, sha, offset=0.0, start_in=0.001)
    need = re.fullmatch(r"start: the robots need (\d+) ms to be ready and the start time is "
                        r"(\d+) ms away \(give a longer lead time\)", str(info.value))
    assert need is not None and int(need.group(1)) > 1 and int(need.group(2)) <= 1
    assert relay.describe()["state"] == RelayState.LOADED  # nothing started


def test_a_show_starts_at_its_time_plays_and_ends(relay: Relay) -> None:
    relay.handle(request("hello"))
    sha = upload(relay, seconds=0.3)["sha256"]
    now = relay.clock.now()
    got = start(relay, sha, offset=0.0, start_at=now + 0.3)
    assert got["start_at"] == now + 0.3 and 0 < got["margin"] < 0.3
    assert relay.describe()["state"] in (RelayState.ARMED, RelayState.RUNNING)
    with pytest.raises(RelayRefused, match=r"^start: this show has already started$"):
        start(relay, sha, offset=0.0, start_in=1.0)
    with pytest.raises(RelayRefused, match=r"^a show is running on this relay; stop it"):
        upload(relay)
    show = relay.handle(request("heartbeat"))["show"]
    assert set(show["performers"]) == {"rex"}
    assert show["performers"]["rex"]["total"] > 0
    events = show["events"]
    show = beat_until(relay, lambda show: show["state"] == RelayState.ENDED)
    events += show["events"]
    last = show["last"]
    assert last["sha256"] == sha and last["completed"] is True and last["link_lost"] is False
    assert last["faults"] == {} and last["late_start_ms"] >= 0
    assert any(row[0] == "f" for row in events)  # what it sent, sent back


def beat_until(relay: Relay, done: Any, timeout: float = 5.0) -> dict[str, Any]:
    """Heartbeats every 20 ms (the holder stays alive) until ``done(show status)``; the
    status returned holds the events of every heartbeat."""
    deadline = time.monotonic() + timeout
    events: list[Any] = []
    while True:
        show: dict[str, Any] = relay.handle(request("heartbeat"))["show"]
        events += show["events"]
        if done(show):
            return show | {"events": events}
        assert time.monotonic() < deadline, show
        time.sleep(0.02)


def test_timed_commands_need_a_show_and_a_time_still_to_come(relay: Relay) -> None:
    relay.handle(request("hello"))
    with pytest.raises(RelayRefused, match=r"^pause: no show is running$"):
        relay.handle(request("pause", at=None))
    sha = upload(relay, seconds=2.0)["sha256"]
    with pytest.raises(RelayRefused, match=r"^seek: no show is running$"):
        relay.handle(request("seek", show_time=1.0, at=None))  # loaded, not started
    start(relay, sha, offset=0.0, start_in=0.2)
    now = relay.clock.now()
    with pytest.raises(RelayRefused) as info:
        relay.handle(request("pause", at=now - 0.25))
    late = re.fullmatch(r"pause: its time passed (\d+\.\d) ms before it arrived \(give a "
                        r"longer command lead\)", str(info.value))
    assert late is not None and 250 <= float(late.group(1)) < 1250
    at = relay.clock.now() + 0.3
    assert relay.handle(request("pause", at=at)) == {"at": at}
    assert relay.handle(request("resume", at=at + 0.1)) == {"at": at + 0.1}
    assert relay.handle(request("seek", show_time=1.5, at=at + 0.2)) == {"at": at + 0.2}
    got = relay.handle(request("pause", at=None))  # now
    assert abs(got["at"] - relay.clock.now()) < 0.5
    stops = relay.handle(request("stop", reason="operator"))["stops"]
    assert stops == {"rex": True}
    assert relay.describe()["last"]["completed"] is False


def test_a_stop_with_no_show_stops_every_robot(relay: Relay) -> None:
    relay.handle(request("hello"))
    assert relay.handle(request("stop", reason="x")) == {"stops": {"rex": True, "lola": True}}


def test_a_probe_reads_a_robot_between_shows(relay: Relay) -> None:
    relay.handle(request("hello"))
    rows = relay.handle(request("probe", performer="rex"))["rows"]
    assert rows and all(isinstance(k, str) and isinstance(v, str) for k, v in rows)
    with pytest.raises(RelayRefused, match=r"^probe: no robot 'rita' on relay hall$"):
        relay.handle(request("probe", performer="rita"))


def test_a_silent_holder_during_a_stop_show_stops_it(relay: Relay) -> None:
    relay.handle(request("hello"))
    sha = upload(relay, seconds=2.0, watchdog_ms=100)["sha256"]
    start(relay, sha, offset=0.0, start_in=0.2)
    show = relay._show
    assert show is not None and show.thread is not None
    show.thread.join(5.0)  # the holder is silent: the show ends early, stopped
    last = relay.describe()["last"]
    assert last["link_lost"] is True and last["completed"] is False
    assert relay.describe()["holder"] is None


def test_a_silent_holder_during_a_continue_show_lets_it_finish(relay: Relay) -> None:
    relay.handle(request("hello"))
    text, sha = upload_text(walk_schedule(0.5, rex="mini"))
    relay.handle(request("upload", schedule=text, sha256=sha, link_loss="continue",
                         watchdog_ms=100))
    start(relay, sha, offset=0.0, start_in=0.2)
    show = relay._show
    assert show is not None and show.thread is not None
    show.thread.join(5.0)
    last = relay.describe()["last"]
    assert last["link_lost"] is True and last["completed"] is True


def test_a_loaded_show_is_forgotten_when_its_conductor_lets_go(relay: Relay) -> None:
    relay.handle(request("hello"))
    upload(relay)
    relay.handle(request("release"))
    assert relay.describe()["state"] == RelayState.IDLE


# --- what the relay's run log says -----------------------------------------------------------

def events(log: RunLog, *names: str) -> list[dict[str, Any]]:
    """The relay's own log events (not the runtime's frames), without their clock time."""
    return [{k: v for k, v in r.items() if k not in ("kind", "mono")}
            for r in log.records if r["kind"] == "event" and (not names or r["event"] in names)]


@pytest.fixture
def logged(robots: dict[str, OwnedRobot]) -> Iterator[tuple[Relay, RunLog]]:
    log = RunLog(None, keep=True)
    r = Relay(None, "hall", robots, log=log)  # type: ignore[arg-type]
    yield r, log
    r.close()


def test_the_log_says_who_held_the_relay_what_was_loaded_and_why_it_was_let_go(
    logged: tuple[Relay, RunLog],
) -> None:
    relay, log = logged
    relay.handle(request("hello"))
    got = upload(relay)
    relay.handle(request("release"))
    relay.handle(request("hello", BOB))
    relay.handle(request("stop", BOB, reason="done"))
    assert events(log, "hello", "upload", "release", "safe_stop") == [
        {"event": "hello", "conductor": "alice"},
        {"event": "upload", "show": "relay test", "sha256": got["sha256"],
         "performers": ["rex"], "preflight_ok": True, "unsafe_allowed": []},
        {"event": "release", "conductor": "alice", "reason": "released by the conductor"},
        {"event": "hello", "conductor": "bob"},
        {"event": "safe_stop", "relay": "hall", "reason": "done", "ok": {"rex": True,
                                                                        "lola": True}},
    ]


def test_the_log_of_a_show_that_plays_to_its_end(logged: tuple[Relay, RunLog]) -> None:
    relay, log = logged
    relay.handle(request("hello"))
    sha = upload(relay, seconds=0.3)["sha256"]
    got = start(relay, sha, offset=0.0, start_in=0.2)
    beat_until(relay, lambda show: show["state"] == RelayState.ENDED)
    (armed,) = events(log, "armed")
    assert armed == {"event": "armed", "sha256": sha, "start_at": got["start_at"],
                     "margin_ms": round(got["margin"] * 1e3, 3)}
    (realtime,) = events(log, "realtime")
    assert isinstance(realtime["granted"], str) and realtime["granted"]
    last = relay.describe()["last"]
    assert last == {"sha256": sha, "completed": True, "reason": "completed", "faults": {},
                    "link_lost": False, "late_start_ms": last["late_start_ms"],
                    "stops": {}, "stop_latency_ms": None}
    assert 0 <= last["late_start_ms"] < 1000
    late = events(log, "late_start")
    assert late == [] or late[0]["late_ms"] == last["late_start_ms"] > 0


def test_the_log_of_a_lost_link(logged: tuple[Relay, RunLog]) -> None:
    relay, log = logged
    relay.handle(request("hello"))
    sha = upload(relay, seconds=2.0, watchdog_ms=100)["sha256"]
    start(relay, sha, offset=0.0, start_in=0.2)
    show = relay._show
    assert show is not None and show.thread is not None
    show.thread.join(5.0)
    (lost,) = events(log, "link_lost")
    assert lost["conductor"] == "alice" and lost["policy"] == "stop"
    assert 100 <= lost["silent_ms"] < 2000
    (release,) = events(log, "release")
    assert release == {"event": "release", "conductor": "alice",
                       "reason": "link lost during the show; policy stop"}
    last = relay.describe()["last"]
    assert last["completed"] is False and last["stops"] == {"rex": True}
    assert last["reason"].startswith("link lost: conductor alice silent for ")
    assert last["stop_latency_ms"] is not None and last["stop_latency_ms"] >= 0


def test_a_silent_holder_between_shows_is_let_go_with_the_reason_logged(
    logged: tuple[Relay, RunLog],
) -> None:
    relay, log = logged
    relay.handle(request("hello"))
    deadline = time.monotonic() + 3.0
    while relay.describe()["holder"] is not None:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    (lost,) = events(log, "link_lost")
    assert lost["policy"] is None and lost["conductor"] == "alice"
    (release,) = events(log, "release")
    assert re.fullmatch(r"conductor silent for \d+ ms", release["reason"])
    assert events(log, "safe_stop") == []  # nothing was playing: nothing stopped


def test_a_silence_from_a_conductor_that_no_longer_holds_changes_nothing(
    logged: tuple[Relay, RunLog],
) -> None:
    relay, log = logged
    relay.handle(request("hello"))
    relay._on_silence(BOB, 1.0)  # not the holder
    assert relay.describe()["holder"]["name"] == "alice"
    assert events(log, "link_lost") == []


def test_a_failing_show_ends_with_the_exception_said(
    logged: tuple[Relay, RunLog], monkeypatch: pytest.MonkeyPatch
) -> None:
    relay, log = logged

    def broken(self: ShowRunner, **kwargs: Any) -> None:
        raise RuntimeError("boom")  # the runner safe-stops its robots before it raises

    monkeypatch.setattr(ShowRunner, "run", broken)
    relay.handle(request("hello"))
    sha = upload(relay, seconds=0.3)["sha256"]
    start(relay, sha, offset=0.0, start_in=0.2)
    show = beat_until(relay, lambda s: s["state"] == RelayState.ENDED)
    assert show["last"] == {"sha256": sha, "completed": False,
                            "reason": "exception: RuntimeError('boom')", "faults": {},
                            "link_lost": False, "late_start_ms": 0.0, "stops": {},
                            "stop_latency_ms": None}
    assert events(log, "late_start") == []
