"""``serve``'s server (control/server.py) in this process with a show running, over the
recording session: OSC cues while a show plays (seek, bar, stop, go, busy), a trigger released
by a put, what the run log keeps of a trigger's release, and the unknown-trigger reply rate
to the reply, on stand-in robots (tests/control/staging.py). The server's refusals, queue and
idle triggers: test_server_logic.py; with shows on simulators: test_server_sims.py."""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Iterator, Sequence

import pytest

from tests.conftest import wait_until as _wait_until
from tests.control.serving import Serve, block_the_control_thread, refusal
from tests.control.staging import Stage
from tests.relay.recording import Answer, Query, ScriptedRelay
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.server import UNKNOWN_REPLIES
from xgo_show.net.session import SessionOptions
from xgo_show.relay import conductor
from xgo_show.relay.options import RELAY_STOP_TIMEOUT, ConductorOptions
from xgo_show.relay.performer import NETWORK_LEAD
from xgo_show.runtime.clock import FakeClock
from xgo_show.timecode.osc import Command


def wait_until(predicate: Callable[[], object], timeout: float = 10.0) -> None:
    """Wait for what another thread does (generous: a loaded machine is slow)."""
    _wait_until(predicate, timeout)


@pytest.fixture
def playing(stage: Stage, triggered_schedule: Schedule) -> Iterator[Serve]:
    """A show without waits, playing (on stand-in robots)."""
    s = Serve()
    plain = dataclasses.replace(triggered_schedule, sections=())
    s.ask("load", schedule=schedule_to_bytes(plain).decode())
    assert s.ask("start")["ok"]
    wait_until(lambda: s.server.status()["state"] == "playing", timeout=10)
    yield s
    s.close()


def said_after(s: Serve, n: int, prefix: str) -> str:
    wait_until(lambda: any(line.startswith(prefix) for line in s.said[n:]), timeout=10)
    return next(line for line in s.said[n:] if line.startswith(prefix))


def test_osc_seek_and_bar_while_a_show_plays(playing: Serve) -> None:
    n = len(playing.said)
    playing.server._on_osc(Command("seek", 0.5))
    assert said_after(playing, n, "osc: seek") == "osc: seek: done"
    n = len(playing.said)
    playing.server._on_osc(Command("bar", 2.0))
    assert said_after(playing, n, "osc: seek") == (
        "osc: seek refused (bad_request): this show has no tempo: give time, not bar")
    n = len(playing.said)
    playing.server._on_osc(Command("bar"))
    assert said_after(playing, n, "osc: seek").endswith("give time, not bar")
    refusal(playing.ask("seek", bar=2), "seek", "bad_request",
            "this show has no tempo: give time, not bar")


def test_an_osc_stop_stops_the_show_saying_so(playing: Serve) -> None:
    n = len(playing.said)
    playing.server._on_osc(Command("stop"))
    assert said_after(playing, n, "osc: stop") == "osc: stop: ended"
    last = playing.server.status()["last_result"]
    assert last is not None and last["reason"] == "OSC /stop"


def test_an_osc_go_without_a_time_starts_at_the_beginning(loaded: Serve) -> None:
    loaded.server._on_osc(Command("go"))
    said_after(loaded, 0, "osc: start")
    assert "starting 'Triggered test' from 0 s (<schedule>)" in loaded.said
    loaded.ask("stop")


def test_osc_cues_are_refused_when_the_queue_is_full(serve: Serve,
                                                   triggered_schedule: Schedule) -> None:
    first = block_the_control_thread(serve, triggered_schedule)
    waiting = [serve.query("pause") for _ in range(63)]
    serve.server._on_osc(Command("pause"))  # the 64th: still queued
    serve.server._on_osc(Command("resume"))
    assert serve.said[-1] == "osc: /resume refused: 64 commands are already waiting"
    assert serve.server.counters["busy"] == 1
    serve.block.set()
    assert first.answer()["ok"] and all(q.answer()["ok"] is False for q in waiting)


def test_an_osc_trigger_releases_a_held_wait(loaded: Serve) -> None:
    loaded.ask("start", section="b")  # holds at once
    wait_until(lambda: loaded.server.status()["state"] == "waiting", timeout=10)
    loaded.server._on_osc(Command("trigger", name="go"))
    wait_until(lambda: any(e.get("accepted") for e in loaded.events("trigger")))
    event = next(e for e in loaded.events("trigger") if e.get("accepted"))
    assert (event["trigger"], event["section"], event["held"], event["source"]) == (
        "go", "b", True, "osc")
    loaded.ask("stop")


def test_a_put_releases_a_held_wait(loaded: Serve) -> None:
    loaded.ask("start", section="b")  # holds at once
    wait_until(lambda: loaded.server.status()["state"] == "waiting", timeout=10)
    loaded.session.publish("ns/trigger/go", b'{"source": "desk", "data": 7}')
    wait_until(lambda: any(e.get("accepted") for e in loaded.events("trigger")))
    event = next(e for e in loaded.events("trigger") if e.get("accepted"))
    assert (event["trigger"], event["section"], event["held"], event["source"],
            event["data"]) == ("go", "b", True, "desk", 7)
    assert loaded.server.counters["accepted"] == 1
    wait_until(lambda: loaded.server.status()["state"] == "playing")
    loaded.ask("stop")


def test_unknown_trigger_queries_in_one_second_get_exactly_their_rate(serve: Serve) -> None:
    clock = FakeClock(1000.0)
    serve.server.clock = clock  # all in one second, however loaded the machine
    queries = [serve.trigger(f"t{i}") for i in range(UNKNOWN_REPLIES + 3)]
    clock.advance(0.999)
    queries.append(serve.trigger("late"))  # the same second still
    assert sum(1 for q in queries if q.errors) == UNKNOWN_REPLIES
    assert all(q.errors for q in queries[:UNKNOWN_REPLIES])


# --- a start armed across a panic ----------------------------------------------------------------

@pytest.fixture
def relayed(monkeypatch: pytest.MonkeyPatch,
            stage: Stage) -> Iterator[tuple[Serve, ScriptedRelay]]:
    """A server whose performer rex plays on robot dog1 of relay hall (a scripted relay that
    answers through the server's own recording session), ivy on a stand-in robot."""
    for name in ("_options", "_session", "_conductor"):  # the conductor's, restored after
        monkeypatch.setattr(conductor, name, getattr(conductor, name))
    relay = ScriptedRelay()
    options = ConductorOptions(session=SessionOptions(namespace="ns"), watchdog=2.0,
                               timeout=2.0)
    s = Serve(maps={"rex": "zenoh:hall/dog1"}, conductor=options)
    s.session.respond = relay
    yield s, relay
    s.close()


def test_a_panic_during_a_starts_pre_flight_cancels_the_start(
    relayed: tuple[Serve, ScriptedRelay], triggered_schedule: Schedule
) -> None:
    s, relay = relayed
    s.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
    assert s.ask("panic")["state"] == "idle"  # an earlier panic counts for nothing later
    uploading, go_on = threading.Event(), threading.Event()
    script = relay.__call__

    def slow_upload(q: Query) -> Sequence[Answer]:
        if q.op == "upload":
            uploading.set()
            go_on.wait(10.0)
        return script(q)

    s.session.respond = slow_upload
    start = s.query("start")
    assert uploading.wait(10.0)  # the start is in its pre-flight
    got = s.ask("panic")
    assert got["ok"] and got["state"] == "idle"  # nothing was moving yet
    go_on.set()
    refusal(start.answer(), "start", "cancelled",
            "start cancelled by a panic during its pre-flight")
    assert s.server.counters["cancelled"] == 1 and s.server.status()["state"] == "loaded"
    assert s.session.of("release")  # the relay given up: nothing left armed


def test_a_relayed_performer_plays_with_the_relays_stop_timeout_and_command_lead(
    relayed: tuple[Serve, ScriptedRelay], triggered_schedule: Schedule
) -> None:
    s, _ = relayed
    s.ask("load", schedule=schedule_to_bytes(triggered_schedule).decode())
    got = s.ask("start", section="b")
    assert got["ok"], got
    run = s.server._run
    assert run is not None
    assert (run.launch.stop_timeout, run.launch.command_lead) == (RELAY_STOP_TIMEOUT,
                                                                 NETWORK_LEAD)
    assert s.session.of("upload")  # through the server's own session
    s.ask("stop")


@pytest.mark.parametrize("sim", [False, True])
def test_a_relay_named_in_the_show_file_is_used_unless_sim_plays_that_performer(
    relayed: tuple[Serve, ScriptedRelay], triggered_schedule: Schedule, sim: bool
) -> None:
    s, relay = relayed
    ported = dataclasses.replace(triggered_schedule, performers=tuple(
        dataclasses.replace(p, port="zenoh:hall/dog1") if p.name == "rex" else p
        for p in triggered_schedule.performers))
    options = s.server.opts.conductor
    t = Serve(sim=sim, maps={} if sim else {"ivy": "stand:ivy"}, conductor=options)
    t.session.respond = relay
    try:
        t.ask("load", schedule=schedule_to_bytes(ported).decode())
        got = t.ask("start", section="b")
        assert got["ok"], got
        run = t.server._run
        assert run is not None
        assert run.launch.command_lead == (0.0 if sim else NETWORK_LEAD)
        assert bool(t.session.of("upload")) is not sim
        t.ask("stop")
    finally:
        t.close()
