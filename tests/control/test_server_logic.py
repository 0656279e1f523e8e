"""``xgo-show serve``'s server (control/server.py) in this process, over a recording session
(tests/relay/recording.py) in place of Zenoh: queries and puts are handed to the server's own
queryables and subscribers, its replies and event puts recorded. Shows play on simulated
robots (real ptys). What it declares, command dispatch and every refusal, the busy queue,
panic always wins (queued commands cancelled), closing, triggers by query and by put (known,
unknown, malformed, rate-limited), the counters, OSC cues, and a show played, held, released,
paused, sought and stopped. test_server.py runs ``serve`` in its own process over Zenoh."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.conftest import wait_until as _wait_until
from tests.control.serving import NS, Serve, block_the_control_thread, refusal
from tests.control.staging import Stage
from tests.relay.recording import RecordingSession
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.protocol import PROTOCOL_VERSION, LoadRequest
from xgo_show.control.server import UNKNOWN_REPLIES, UNKNOWN_RING, ServeOptions, ShowServer
from xgo_show.runtime.clock import FakeClock
from xgo_show.timecode.osc import Command


def wait_until(predicate: Callable[[], object], timeout: float = 10.0) -> None:
    """Wait for what another thread does (generous: a loaded machine is slow)."""
    _wait_until(predicate, timeout)


ZERO = {"triggers": 0, "accepted": 0, "refused": 0, "unknown": 0, "malformed": 0, "busy": 0,
        "cancelled": 0, "events_dropped": 0, "events_suppressed": 0}


# --- what it serves ------------------------------------------------------------------------------

def test_the_server_answers_control_status_and_triggers_and_takes_every_trigger_put(
    serve: Serve
) -> None:
    live = {(d.kind, d.key) for d in serve.session.declared}
    assert live == {("queryable", "ns/control/*"), ("queryable", "ns/status"),
                    ("queryable", "ns/trigger/*"), ("subscriber", "ns/trigger/*")}
    threads = {t.name for t in threading.enumerate()}
    assert {"xgo-show control", "xgo-show unknown triggers"} <= threads


def test_status_before_anything_is_loaded(serve: Serve) -> None:
    got = serve.session.query("ns/status").answer()
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "status", "state": "idle",
                   "show": None, "last_result": None, "namespace": NS,
                   "version": PROTOCOL_VERSION, "counters": ZERO}


def test_a_load_declares_one_subscriber_per_awaited_trigger_and_says_what_is_loaded(
    serve: Serve, triggered_schedule: Schedule
) -> None:
    got = serve.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
    assert got["ok"] and got["command"] == "load" and got["warnings"] == []
    assert got["show"]["name"] == "Triggered test" and got["show"]["source"] == "<schedule>"
    assert got["show"]["triggers"] == ["go", "encore"]
    subs = [d.key for d in serve.session.live("subscriber")]
    assert subs == ["ns/trigger/*", "ns/trigger/encore", "ns/trigger/go"]
    assert serve.said == ["loaded 'Triggered test' (<schedule>); triggers: go, encore"]
    wait_until(lambda: serve.events("state"))
    state = serve.events("state")[0]
    assert (state["state"], state["show"]) == ("loaded", "Triggered test")
    status = serve.server.status()
    assert status["state"] == "loaded" and status["show"] == got["show"]
    # Loaded again: the previous show's subscribers go, the new show's come.
    old = serve.session.live("subscriber")[1:]
    serve.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
    assert all(d.undeclared for d in old) and len(serve.session.live("subscriber")) == 3


def test_a_show_without_triggers_says_none(serve: Serve, triggered_schedule: Schedule) -> None:
    import dataclasses
    plain = dataclasses.replace(triggered_schedule, sections=())
    serve.ask("load", schedule=schedule_to_bytes(plain).decode())
    assert serve.said[-1].endswith("; triggers: none")
    assert [d.key for d in serve.session.live("subscriber")] == ["ns/trigger/*"]


def test_a_show_loaded_at_start_is_loaded_before_anything_is_served(
    triggered_path: Path
) -> None:
    session = RecordingSession()
    server = ShowServer(session, ServeOptions(namespace=NS, sim=True),
                        load=LoadRequest(path=str(triggered_path)), say=lambda line: None)
    try:
        assert server.status()["show"]["source"] == str(triggered_path)
        assert len(session.live("subscriber")) == 3
    finally:
        server.close()


# --- refusals ------------------------------------------------------------------------------------

def test_malformed_and_unknown_commands_are_refused_with_their_code(serve: Serve) -> None:
    got = serve.ask("dance")
    assert got["error"] == "unknown_command" and got["command"] == "dance"
    assert got["message"].startswith("unknown command 'dance'; commands: load, start")
    got = serve.ask("start", raw=b"[1]")
    refusal(got, "start", "bad_request", "payload must be a JSON object, not an array")


def test_commands_need_a_show(serve: Serve) -> None:
    refusal(serve.ask("start"), "start", "refused", "no show is loaded: send load first")
    for command in ("pause", "resume", "stop"):
        refusal(serve.ask(command), command, "refused",
                f"cannot {command}: no show is running")
    refusal(serve.ask("seek", time=1.0), "seek", "refused", "cannot seek: no show is running")


def test_a_start_outside_the_show_or_at_an_unknown_place_is_refused(
    loaded: Serve, triggered_schedule: Schedule
) -> None:
    end = triggered_schedule.duration
    for t in (end, 99.0):  # the end itself is outside: nothing would play
        refusal(loaded.ask("start", time=t), "start", "bad_request",
                f"start at {t:g} s: outside the show (0 to {end:g} s)")
    refusal(loaded.ask("start", section="zz"), "start", "not_found",
            "no section named 'zz'; sections: a, b, c, d")
    refusal(loaded.ask("start", bar=2), "start", "bad_request",
            "this show has no tempo: give time, not bar")


def test_a_start_without_robots_names_the_performers(triggered_schedule: Schedule) -> None:
    s = Serve(sim=False, maps={"rex": "/dev/null-rex"})
    try:
        s.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
        refusal(s.ask("start"), "start", "refused",
                "no robot for performer(s) ivy: start serve with --map NAME=PORT (or --sim)")
    finally:
        s.close()


def test_a_start_in_the_past_is_refused_and_nothing_is_left_armed(
    loaded: Serve, monkeypatch: pytest.MonkeyPatch
) -> None:
    from types import SimpleNamespace

    from xgo_show.control import server as server_module

    wall = time.time()  # the wall clock stands still: the lateness does not depend on load
    monkeypatch.setattr(server_module, "time", SimpleNamespace(time=lambda: wall))
    got = loaded.ask("start", at=wall - 10.0)
    assert got["error"] == "bad_request"
    assert got["message"] == "start time is 10.000 s in the past"
    assert loaded.server.status()["state"] == "loaded"
    got = loaded.ask("start", at=wall - 0.3)  # late, but within half a second: played
    assert got["ok"], got
    loaded.ask("stop")


# --- the control thread: busy, panic, closing ----------------------------------------------------

def test_a_full_queue_answers_busy(serve: Serve, triggered_schedule: Schedule) -> None:
    first = block_the_control_thread(serve, triggered_schedule)
    waiting = [serve.query("pause") for _ in range(64)]
    got = serve.ask("resume")
    refusal(got, "resume", "busy", "64 commands are already waiting; try again")
    assert serve.server.counters["busy"] == 1
    serve.block.set()
    assert first.answer()["ok"]
    assert all(q.answer()["message"] == "cannot pause: no show is running" for q in waiting)


def test_a_panic_is_answered_at_once_and_cancels_the_queued_commands(
    serve: Serve, triggered_schedule: Schedule
) -> None:
    first = block_the_control_thread(serve, triggered_schedule)
    queued = [serve.query("start"), serve.query("seek", time=1.0)]
    got = serve.ask("panic")
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "panic", "state": "idle",
                   "note": "no show is running: nothing is moving"}
    refusal(queued[0].answer(), "start", "cancelled", "start cancelled by a panic")
    refusal(queued[1].answer(), "seek", "cancelled", "seek cancelled by a panic")
    assert serve.server.counters["cancelled"] == 2
    serve.block.set()
    assert first.answer()["ok"]


def test_a_malformed_panic_is_still_refused(serve: Serve) -> None:
    assert serve.ask("panic", raw=b"{")["error"] == "bad_request"


def test_closing_answers_the_queued_commands_and_undeclares_everything(
    stage: Stage, triggered_schedule: Schedule
) -> None:
    s = Serve()
    first = block_the_control_thread(s, triggered_schedule)
    queued = s.query("pause")
    closer = threading.Thread(target=s.server.close)
    closer.start()
    s.block.set()
    closer.join(10.0)
    assert not closer.is_alive()
    assert first.answer()["ok"]
    refusal(queued.answer(), "control", "closing", "the server is closing")
    assert all(d.undeclared for d in s.session.declared)
    assert not any(t.name in ("xgo-show control", "xgo-show unknown triggers")
                   for t in threading.enumerate())


# --- triggers ------------------------------------------------------------------------------------

def test_a_trigger_query_nobody_waits_for_is_refused_and_counted(serve: Serve) -> None:
    refusal(serve.trigger("zz").answer(), "trigger", "refused",
            "trigger 'zz' refused: no show with triggers is loaded")
    counters = serve.server.counters
    assert (counters["triggers"], counters["refused"], counters["unknown"]) == (1, 1, 1)
    wait_until(lambda: serve.events("warning"))
    warning = serve.events("warning")[0]
    assert (warning["unknown"], warning["trigger"]) == (1, "zz")
    assert warning["message"] == ("1 trigger(s) no section waits for refused since the last "
                                  "such warning (the last: 'zz')")


def test_a_trigger_the_loaded_show_lacks_names_its_triggers(loaded: Serve) -> None:
    refusal(loaded.trigger("zz").answer(), "trigger", "refused",
            "trigger 'zz' refused: no section of this show waits for 'zz' (its triggers: "
            "encore, go)")


def test_unknown_trigger_queries_get_at_most_their_rate_of_replies(serve: Serve) -> None:
    clock = FakeClock(1000.0)
    serve.server.clock = clock  # the queries come in one instant, however loaded the machine
    queries = [serve.trigger(f"t{i}") for i in range(UNKNOWN_REPLIES + 5)]
    assert [q for q in queries if q.errors] == queries[:UNKNOWN_REPLIES]
    assert all(q.dropped.is_set() for q in queries[UNKNOWN_REPLIES:])  # dropped unanswered
    assert serve.server.counters["unknown"] == UNKNOWN_REPLIES + 5
    # A second later (to the float): a new window of replies, and a warning telling how many
    # since the first one (the warnings: once a second at most).
    clock.advance(1.0)
    assert serve.trigger("last").errors
    wait_until(lambda: len(serve.events("warning")) == 2, timeout=10)
    assert serve.events("warning")[1]["unknown"] == UNKNOWN_REPLIES + 5


def test_a_trigger_with_no_show_running_is_refused(loaded: Serve) -> None:
    for payload in (None, b"{}", b'{"v":1}', b'{"v": 1}', b'{"source": "desk"}'):
        refusal(loaded.trigger("go", payload).answer(), "trigger", "refused",
                "trigger 'go' refused: no show is running")
    counters = loaded.server.counters
    assert (counters["triggers"], counters["refused"], counters["unknown"]) == (5, 5, 0)
    wait_until(lambda: loaded.events("trigger"))
    event = loaded.events("trigger")[0]
    assert (event["trigger"], event["accepted"], event["reason"]) == (
        "go", False, "no show is running")


def test_a_malformed_trigger_query_is_refused_and_counted(loaded: Serve) -> None:
    got = loaded.trigger("go", b'{"source": 5}').answer()
    assert (got["ok"], got["command"], got["error"]) == (False, "trigger", "bad_request")
    refusal(loaded.trigger("go", b"[").answer(), "trigger", "bad_request",
            "payload is not JSON: Expecting value: line 1 column 2 (char 1)")
    assert loaded.server.counters["malformed"] == 2


def test_trigger_puts_go_to_their_own_subscriber_and_unknown_ones_are_counted_in_batches(
    loaded: Serve
) -> None:
    assert loaded.session.publish("ns/trigger/go") == 2  # its own and the wildcard's ring
    counters = loaded.server.counters
    assert (counters["triggers"], counters["refused"]) == (1, 1)  # no show running
    loaded.session.publish("ns/trigger/go", b"{")  # malformed: dropped, said
    assert loaded.server.counters["malformed"] == 1
    wait_until(lambda: loaded.events("warning"))
    assert loaded.events("warning")[0]["message"].startswith(
        "trigger 'go' dropped: payload is not JSON")
    for name in ("x1", "x2", "x3"):
        assert loaded.session.publish(f"ns/trigger/{name}") == 1  # the ring only
    wait_until(lambda: len(loaded.events("warning")) >= 2)
    warning = loaded.events("warning")[1]
    assert (warning["unknown"], warning["trigger"]) == (3, "x3")
    counters = loaded.server.counters
    # The waited one's copy in the ring is not counted again.
    assert (counters["triggers"], counters["unknown"], counters["refused"]) == (4, 3, 4)


# --- OSC cues ------------------------------------------------------------------------------------

def test_osc_cues_queue_like_commands_and_are_answered_in_lines(loaded: Serve) -> None:
    loaded.server._on_osc("listening on 9000")
    loaded.server._on_osc(Command("trigger", name="zz"))
    loaded.server._on_osc(Command("trigger", name="go"))
    for cue in (Command("pause"), Command("seek", 1.0), Command("bar", 2.0), Command("stop")):
        loaded.server._on_osc(cue)
    wait_until(lambda: len(loaded.said) >= 8)
    assert loaded.said[1:] == [
        "osc: listening on 9000",
        "osc: trigger 'zz' refused: no section of this show waits for 'zz' (its triggers: "
        "encore, go)",
        "osc: trigger 'go' refused: no show is running",
        "osc: pause refused (refused): cannot pause: no show is running",
        "osc: seek refused (refused): cannot seek: no show is running",
        "osc: seek refused (refused): cannot seek: no show is running",
        "osc: stop refused (refused): cannot stop: no show is running",
    ]


def test_an_osc_go_starts_the_show_and_then_goes_on(loaded: Serve) -> None:
    loaded.server._on_osc(Command("go", 0.7))
    wait_until(lambda: any(line.startswith("osc: start") for line in loaded.said), timeout=10)
    assert "starting 'Triggered test' from 0.7 s (<schedule>)" in loaded.said
    assert "osc: start: done" in loaded.said
    loaded.server._on_osc(Command("go"))  # running: go on
    wait_until(lambda: any(line.startswith("osc: resume") for line in loaded.said), timeout=10)
    loaded.ask("stop")


# --- a show played -------------------------------------------------------------------------------

def test_a_show_starts_holds_at_its_wait_is_released_by_a_trigger_and_stops(
    loaded: Serve
) -> None:
    before = time.time()
    got = loaded.ask("start", section="b", **{"in": 0.2})  # holds as it starts
    assert got["ok"] and got["show"] == "Triggered test" and got["offset"] == 0.6
    assert before + 0.15 < got["start_time"] < time.time() + 0.25
    assert got["preflight"] is not None
    refusal(loaded.ask("start"), "start", "refused", "a show is running already (stop it first)")
    refusal(loaded.ask("load", path="/nonexistent.yaml"), "load", "refused",
            "a show is running: stop it before loading another")
    wait_until(lambda: loaded.server.status()["state"] == "waiting", timeout=10)
    status = loaded.server.status()
    assert status["waiting_for"] == {"section": "b", "trigger": "go", "timeout": None}
    assert status["next_wait"] == {"section": "b", "trigger": "go"}
    assert status["duration"] == status["show"]["duration"]
    assert set(status["robots"]) == {"rex", "ivy"} and status["faults"] == {}
    got = loaded.trigger("go", b'{"source": "desk", "data": [1]}').answer()
    assert got == {"v": PROTOCOL_VERSION, "ok": True, "command": "trigger", "trigger": "go",
                   "section": "b", "held": True}
    wait_until(lambda: [e for e in loaded.events("trigger") if e.get("accepted")])
    event = next(e for e in loaded.events("trigger") if e.get("accepted"))
    assert (event["section"], event["held"], event["source"], event["data"]) == (
        "b", True, "desk", [1])
    assert loaded.server.counters["accepted"] == 1
    wait_until(lambda: loaded.server.status().get("next_wait") is not None or
               loaded.server.status()["state"] != "playing", timeout=10)
    got = loaded.ask("stop", reason="enough")
    assert got["state"] == "ended" and got["reason"]
    assert set(got["stops"]) == {"rex", "ivy"} and all(s["ok"] for s in got["stops"].values())
    status = loaded.server.status()
    assert status["state"] == "loaded" and status["last_result"]["show"] == "Triggered test"
    assert status["last_result"]["completed"] is False
    assert any(line.startswith("show 'Triggered test' ended: ") for line in loaded.said)


def test_a_running_show_is_paused_resumed_and_sought(serve: Serve,
                                                     triggered_schedule: Schedule) -> None:
    import dataclasses
    plain = dataclasses.replace(triggered_schedule, sections=())  # no waits to hold it
    serve.ask("load", schedule=schedule_to_bytes(plain).decode())
    serve.ask("start")
    wait_until(lambda: serve.server.status()["state"] == "playing", timeout=10)
    got = serve.ask("pause")
    assert got["ok"] and got["state"] in ("playing", "paused")  # it acts a moment later
    wait_until(lambda: serve.server.status()["state"] == "paused", timeout=10)
    got = serve.ask("seek", time=0.5)
    assert got["ok"] and got["show_time"] == 0.5
    got = serve.ask("resume")
    assert got["ok"] and got["state"] in ("paused", "playing")
    wait_until(lambda: serve.server.status()["state"] == "playing", timeout=10)
    got = serve.ask("panic")
    assert got["ok"] and got["state"] == "ended" and set(got["stops"]) == {"rex", "ivy"}
    wait_until(lambda: any(e["state"] == "panic" for e in serve.events("state")))
    wait_until(lambda: serve.server.status()["state"] == "loaded", timeout=10)
    assert serve.server.status()["last_result"]["completed"] is False


# --- how it is wired -----------------------------------------------------------------------------

def test_the_servers_threads_are_daemons(serve: Serve) -> None:
    """A command or a drain that never ends must not keep ``serve`` from exiting."""
    mine = {t.name: t.daemon for t in threading.enumerate()
            if t.name in ("xgo-show control", "xgo-show unknown triggers")}
    assert mine == {"xgo-show control": True, "xgo-show unknown triggers": True}


def test_triggers_are_taken_on_zenohs_receiving_thread(loaded: Serve) -> None:
    """The trigger queryable and the awaited triggers' subscribers run on the thread that
    received the message (``indirect=False``): no hand-over before the release."""
    direct = [d for d in loaded.session.declared if d.key.startswith("ns/trigger/")
              and not (d.kind == "subscriber" and d.key == "ns/trigger/*")]
    assert sorted((d.kind, d.key) for d in direct) == [
        ("queryable", "ns/trigger/*"), ("subscriber", "ns/trigger/encore"),
        ("subscriber", "ns/trigger/go")]
    assert all(d.handler.indirect is False for d in direct)


def test_puts_for_unknown_triggers_wait_in_a_ring_of_its_size(
    stage: Stage, monkeypatch: pytest.MonkeyPatch
) -> None:
    import zenoh

    rings: list[int] = []
    ring = zenoh.handlers.RingChannel

    def sized(capacity: int) -> object:
        rings.append(capacity)
        return ring(capacity)

    monkeypatch.setattr(zenoh.handlers, "RingChannel", sized)
    s = Serve()
    try:
        assert rings == [UNKNOWN_RING]
    finally:
        s.close()


def test_osc_cues_arrive_over_udp_with_follow(stage: Stage) -> None:
    from pythonosc.udp_client import SimpleUDPClient

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:  # a free UDP port
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    s = Serve(follow=f"osc:{port}")
    try:
        osc = s.server.osc
        assert osc is not None and (osc.host, osc.port) == ("127.0.0.1", port)
        SimpleUDPClient(osc.host, osc.port).send_message("/pause", [])
        wait_until(lambda: "osc: pause refused (refused): cannot pause: no show is running"
                   in s.said, timeout=10)
    finally:
        s.close()
    assert not [t for t in threading.enumerate() if t.name == "osc-server"]
