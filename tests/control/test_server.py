"""``xgo-show serve`` in its own process, driven by Zenoh clients on loopback (no mocks).

The server runs simulated robots on real ptys; this process talks to it through a real Zenoh
session (multicast scouting off, explicit endpoints), and some tests use the ``ctl`` and
``trigger`` commands as separate processes, as an operator on another host would.
"""

from __future__ import annotations

import functools
import itertools
import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import zenoh

from tests.children import first_answer
from tests.control.conftest import ROUTINE, control_session, status_or_none
from tests.control.conftest import serve_process as serve_process_of
from tests.loopback import peer_config
from xgo_show.control.client import ControlClient, ControlFailed
from xgo_show.control.keys import control_key, event_key, status_key, trigger_key
from xgo_show.control.protocol import MAX_PAYLOAD
from xgo_show.control.schemas import definition

ROOT = Path(__file__).resolve().parents[2]
NS = f"test-serve-{os.getpid()}"


@pytest.fixture(scope="module")
def serve_process(triggered_path: Path) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """A serve process with simulated robots and the short triggered show loaded, and its
    endpoint."""
    with serve_process_of(triggered_path, NS) as (proc, endpoint, output):
        yield proc, endpoint
    assert "serve stopped" in output[0]


@pytest.fixture(scope="module")
def server(serve_process: tuple[subprocess.Popen[str], str]) -> str:
    """The serve process's endpoint."""
    return serve_process[1]


@pytest.fixture(scope="module")
def session(serve_process: tuple[subprocess.Popen[str], str]) -> Iterator[zenoh.Session]:
    with control_session(*serve_process, NS) as s:
        yield s


@functools.cache
def _validator(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(definition(name))


def check(name: str, payload: object) -> None:
    """``payload`` is valid as the schema file's ``name`` (request-X, reply-X, error, event-X)."""
    errors = sorted(_validator(name).iter_errors(payload), key=str)
    assert not errors, f"{name}: {errors[0].message} at {list(errors[0].absolute_path)}"


class CheckedClient(ControlClient):
    """A client that checks every request it sends and every reply against the schemas."""

    def _get(self, key: str, payload: dict[str, Any] | None, what: str) -> dict[str, Any]:
        if payload is not None:
            check(f"request-{what}", payload)
        try:
            reply = super()._get(key, payload, what)
        except ControlFailed as exc:
            if exc.code != "no_reply":
                check("error", exc.reply)
            raise
        check(f"reply-{what}", reply)
        return reply


@pytest.fixture
def client(session: zenoh.Session) -> Iterator[ControlClient]:
    c = CheckedClient(session, NS, timeout=5.0)
    yield c
    # Leave no show running for the next test.
    if c.status()["state"] not in ("idle", "loaded"):
        c.command("stop", reason="test over")


def _until(predicate: Callable[[], bool], timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, "the condition did not hold in time"
        time.sleep(0.02)


def _get_err(session: zenoh.Session, key: str, payload: bytes | None) -> dict[str, Any]:
    """A query that must get an error reply; returns its JSON."""
    replies = list(session.get(key, payload=payload, timeout=5.0,
                               congestion_control=zenoh.CongestionControl.BLOCK))
    assert len(replies) == 1
    assert replies[0].err is not None, replies[0].ok and replies[0].ok.payload.to_string()
    body: dict[str, Any] = json.loads(replies[0].err.payload.to_bytes())
    assert body["v"] == 1 and body["ok"] is False
    return body


def test_status_says_what_is_loaded(client: ControlClient) -> None:
    status = client.status()
    assert status["v"] == 1 and status["ok"] is True and status["state"] == "loaded"
    assert status["show"]["triggers"] == ["go", "encore"]
    assert [s["name"] for s in status["show"]["sections"]] == ["a", "b", "c", "d"]


def test_a_triggered_show_from_start_to_end(
    client: ControlClient, session: zenoh.Session
) -> None:
    events: list[dict[str, Any]] = []
    sub = session.declare_subscriber(
        event_key(NS), lambda s: events.append(json.loads(s.payload.to_bytes()))
    )
    try:
        client.status()  # handshake: the subscriber is declared before anything is published
        with pytest.raises(ControlFailed, match="no show is running") as refused:
            client.trigger("go")
        assert refused.value.code == "refused"
        reply = client.command("start")
        assert reply["ok"] and reply["offset"] == 0.0 and reply["preflight"]["ok"]
        _until(lambda: client.status()["state"] == "waiting")
        status = client.status()  # a late joiner learns everything from one query
        assert status["waiting_for"] == {"section": "b", "trigger": "go", "timeout": None}
        assert status["section"] == "a" or status["show_time"] == pytest.approx(0.6, abs=0.01)
        assert set(status["robots"]) == {"rex", "ivy"}
        with pytest.raises(ControlFailed, match=r"the show waits for 'go' \(section 'b'\)"):
            client.trigger("encore")
        out = client.trigger("go", source="test")
        assert out["section"] == "b" and out["held"] is True
        _until(lambda: client.status()["state"] in ("loaded", "idle"), timeout=10.0)
        last = client.status()["last_result"]
        assert last["completed"] is True and last["reason"] == "completed"
    finally:
        sub.undeclare()
    kinds = {(e["event"], e.get("state")) for e in events}
    assert ("state", "playing") in kinds and ("state", "ended") in kinds
    assert ("wait", "waiting") in kinds and ("wait", "released") in kinds
    assert any(e["event"] == "cue" and e["robot"] == "rex" for e in events)
    accepted = [e for e in events if e["event"] == "trigger" and e["accepted"]]
    assert [(e["trigger"], e["source"]) for e in accepted] == [("go", "test")]
    assert all(e["v"] == 1 and isinstance(e["time"], float) for e in events)


def test_bad_requests_get_clear_error_replies(session: zenoh.Session) -> None:
    cases = [
        (control_key(NS, "dance"), b"{}", "unknown_command", "unknown command 'dance'"),
        (control_key(NS, "start"), b"{not json", "bad_request", "payload is not JSON"),
        (control_key(NS, "start"), b"[1, 2]", "bad_request", "must be a JSON object"),
        (control_key(NS, "start"), b'{"v": 2}', "version", "version 2 is not supported"),
        (control_key(NS, "start"), b'{"bar": 0}', "bad_request", "bar"),
        (control_key(NS, "start"), b'{"section": "nope"}', "not_found", "no section named"),
        (control_key(NS, "seek"), b"{}", "bad_request", "give time, bar or section"),
        (control_key(NS, "load"), b'{"path": "/no/such.yaml"}', "failed", "no such file"),
        (control_key(NS, "stop"), b'{"reason": 5}', "bad_request", "reason"),
        (control_key(NS, "resume"), b"{}", "refused", "no show is running"),
        (control_key(NS, "start"), b" " * (MAX_PAYLOAD + 1), "too_large", "over the limit"),
        (trigger_key(NS, "go"), b'{"data": 1, "x": 2}', "bad_request", "x"),
        (trigger_key(NS, "go"), b" " * (MAX_PAYLOAD + 1), "too_large", "over the limit"),
        (trigger_key(NS, "go"), b'{"v": 1, "data": [1,', "bad_request", "payload is not JSON"),
        (control_key(NS, "start"), b'{"bar": 2}', "bad_request", "this show has no tempo"),
    ]
    for key, payload, code, message in cases:
        body = _get_err(session, key, payload)
        check("error", body)
        assert body["error"] == code, (key, body)
        assert message in body["message"], (key, body)


def test_an_oversized_or_malformed_put_is_dropped_and_counted(
    client: ControlClient, session: zenoh.Session
) -> None:
    warnings: list[dict[str, Any]] = []
    sub = session.declare_subscriber(
        event_key(NS, "warning"), lambda s: warnings.append(json.loads(s.payload.to_bytes())))
    try:
        client.status()  # the subscriber is in place
        before = _counters(client)
        for payload in (b" " * (MAX_PAYLOAD + 1), b"{not json"):
            session.put(trigger_key(NS, "go"), payload,
                        congestion_control=zenoh.CongestionControl.BLOCK)
        _until(lambda: _counters(client)["malformed"] == before["malformed"] + 2)
        _until(lambda: len(warnings) == 2)
    finally:
        sub.undeclare()
    assert _counters(client)["triggers"] == before["triggers"]  # neither reached the director
    assert f"trigger 'go' dropped: payload of {MAX_PAYLOAD + 1} bytes is over the limit" in \
        warnings[0]["message"]
    assert warnings[1]["message"].startswith("trigger 'go' dropped: payload is not JSON: ")
    for warning in warnings:
        check("event-warning", warning)


def test_start_at_a_wall_clock_time_never_in_the_past(client: ControlClient) -> None:
    with pytest.raises(ControlFailed, match=r"start time is 5\.\d+ s in the past") as past:
        client.command("start", at=time.time() - 5.0)
    assert past.value.code == "bad_request"
    assert client.status()["state"] == "loaded"  # nothing moved
    at = time.time() + 1.0
    reply = client.command("start", at=at)
    assert reply["start_time"] == pytest.approx(at, abs=0.005)
    counting = client.status()  # armed, the start still to come
    assert counting["state"] == "starting", counting
    assert -1.0 < counting["show_time"] <= 0.0  # the count-down
    _until(lambda: client.status()["state"] == "waiting")  # at b, 0.6 s into the show
    assert time.time() >= at + 0.6


def test_start_and_seek_by_bar_and_beat(client: ControlClient, triggered_path: Path) -> None:
    # The curtain call: 120 bpm, 4 beats a bar; its sections 'bow' (4 s, bar 3) and
    # 'encore' (8 s, bar 5) wait for triggers.
    client.command("load", path=str(ROOT / "choreographies" / "curtain_call.yaml"))
    try:
        started = client.command("start", bar=2, beat=3)
        assert started["offset"] == 3.0
        _until(lambda: client.status()["state"] == "waiting")  # at bow, bar 3
        status = client.status()
        assert (status["bar"], status["beat"], status["section"]) == (3, 1.0, "bow")
        sought = client.command("seek", bar=5)
        assert sought == {**sought, "show_time": 8.0, "bar": 5, "beat": 1.0, "section": "encore"}
        with pytest.raises(ControlFailed, match=r"seek to 196 s: outside the show \(0 to 16 s\)"
                           ) as beyond:
            client.command("seek", bar=99)
        assert beyond.value.code == "bad_request"
    finally:
        client.command("stop", reason="test over")
        client.command("load", path=str(triggered_path))


def test_a_full_command_queue_answers_busy(
    client: ControlClient, session: zenoh.Session, triggered_path: Path
) -> None:
    before = _counters(client)["busy"]
    patient = CheckedClient(session, NS, timeout=60.0)  # the load's compile takes seconds
    loaded: list[dict[str, Any]] = []
    load = threading.Thread(target=lambda: loaded.append(patient.command("load", routine=SLOW)))
    load.start()
    time.sleep(0.3)  # the control thread compiles it (or is about to): the queue fills behind
    sent = 66  # 64 fit in the queue (63 while the load still waits in it)
    pending = [session.get(control_key(NS, "resume"), payload=b"{}", timeout=60.0,
                           congestion_control=zenoh.CongestionControl.BLOCK)
               for _ in range(sent)]
    answers = []
    for replies in pending:
        reply = next(iter(replies))
        assert reply.err is not None
        answers.append(json.loads(reply.err.payload.to_bytes()))
    load.join(60.0)
    try:
        assert loaded and loaded[0]["ok"]
        codes = [a["error"] for a in answers]
        busy = codes.count("busy")
        assert busy in (2, 3), codes
        assert codes.count("refused") == sent - busy  # each queued one carried out in turn
        assert codes[-busy:] == ["busy"] * busy  # the last ones found the queue full
        assert next(a for a in answers if a["error"] == "busy")["message"] == \
            "64 commands are already waiting; try again"
        assert _counters(client)["busy"] == before + busy
    finally:
        client.command("load", path=str(triggered_path))


def test_two_shows_share_a_network_in_two_namespaces(
    serve_process: tuple[subprocess.Popen[str], str]
) -> None:
    other = f"{NS}-other"
    curtain = ROOT / "choreographies" / "curtain_call.yaml"
    with serve_process_of(curtain, other) as (proc, endpoint, _):
        config = peer_config(listen=["tcp/127.0.0.1:0"], connect=[serve_process[1], endpoint])
        with zenoh.open(config) as both:
            first_answer(lambda: status_or_none(ControlClient(both, other, timeout=1.0)), proc)

            def answers(key: str) -> list[dict[str, Any]]:
                out = []
                for reply in both.get(key, payload=b"{}", timeout=1.0):
                    sample = reply.ok if reply.ok is not None else reply.err
                    assert sample is not None
                    out.append(json.loads(sample.payload.to_bytes()))
                return out

            ours, theirs = answers(status_key(NS)), answers(status_key(other))
            assert [(s["namespace"], s["show"]["name"]) for s in ours] == [
                (NS, "Triggered test")]
            assert [(s["namespace"], s["show"]["name"]) for s in theirs] == [
                (other, "Curtain call")]
            refused = answers(trigger_key(other, "bow"))  # a section's name, not a trigger
            assert [r["message"] for r in refused] == [
                "trigger 'bow' refused: no section of this show waits for 'bow' (its "
                "triggers: encore, go)"]


def test_panic_is_always_accepted_and_stops_every_robot(client: ControlClient) -> None:
    idle = client.command("panic")
    assert idle["ok"] and idle["state"] == "idle"
    client.command("start", section="b")
    _until(lambda: client.status()["state"] == "waiting")
    reply = client.command("panic")
    assert reply["state"] == "ended" and reply["reason"] == "panic"
    assert set(reply["stops"]) == {"rex", "ivy"}
    assert all(s["ok"] for s in reply["stops"].values())
    last = client.status()["last_result"]
    assert last["completed"] is False and last["reason"] == "panic"


def test_the_command_line_clients_from_other_processes(
    server: str, client: ControlClient
) -> None:
    def xgo(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "xgo_show", *args, "--connect", server, "--namespace", NS],
            capture_output=True, text=True, timeout=30,
        )

    started = xgo("ctl", "start")
    assert started.returncode == 0, started.stderr
    assert "starting 'Triggered test' from 0 s" in started.stdout
    _until(lambda: client.status()["state"] == "waiting")
    wrong = xgo("trigger", "encore")
    assert wrong.returncode == 2
    assert "refused: the show waits for 'go' (section 'b')" in wrong.stderr
    assert "Traceback" not in wrong.stderr
    status = xgo("ctl", "status")
    assert status.returncode == 0 and "show 'Triggered test'" in status.stdout
    assert "waiting for trigger 'go' (section b)" in status.stdout
    stopped = xgo("ctl", "stop")  # the show holds at b for ever: stop it
    assert stopped.returncode == 0, stopped.stderr
    client.command("start")
    _until(lambda: client.status()["state"] == "waiting")
    fired = xgo("trigger", "go")
    assert fired.returncode == 0, fired.stderr
    assert fired.stdout.strip() == "trigger 'go': released section 'b'"


class Flood:
    """Puts on ``key`` from a thread, ``rate`` a second (reliable, blocking: none is lost on
    the way, so the server's counters can be checked against ``sent``)."""

    def __init__(self, session: zenoh.Session, key: str, payload: bytes, rate: int) -> None:
        self.sent = 0
        self._stop = threading.Event()

        def run() -> None:
            start = time.monotonic()
            while not self._stop.is_set():
                due = int((time.monotonic() - start) * rate)
                while self.sent < due:
                    session.put(key, payload, congestion_control=zenoh.CongestionControl.BLOCK)
                    self.sent += 1
                time.sleep(0.005)

        self._thread = threading.Thread(target=run, name="xgo-show test flood")
        self._thread.start()

    def stop(self) -> int:
        self._stop.set()
        self._thread.join()
        return self.sent


def _counters(client: ControlClient) -> dict[str, int]:
    return dict(client.status()["counters"])


def test_a_trigger_flood_is_absorbed_and_the_real_one_still_counts(
    client: ControlClient, session: zenoh.Session
) -> None:
    before = _counters(client)
    client.command("start")
    _until(lambda: client.status()["state"] == "waiting")
    warnings: list[dict[str, Any]] = []
    sub = session.declare_subscriber(
        event_key(NS, "*"), lambda s: warnings.append(json.loads(s.payload.to_bytes()))
    )
    client.status()  # the subscriber is in place
    refused = Flood(session, trigger_key(NS, "lights"), b'{"v": 1}', rate=2000)
    malformed = Flood(session, trigger_key(NS, "go"), b"{not json", rate=1000)
    try:
        time.sleep(1.0)
        assert client.status()["state"] == "waiting"  # still answering, still holding
        assert client.trigger("go")["held"] is True
    finally:
        sent = refused.stop(), malformed.stop()
    _until(lambda: client.status()["state"] in ("loaded", "idle"), timeout=10.0)
    assert client.status()["last_result"]["completed"] is True
    after = _counters(client)
    assert after["refused"] - before["refused"] == sent[0]
    assert after["malformed"] - before["malformed"] == sent[1]
    assert after["triggers"] - before["triggers"] == sent[0] + 1
    assert after["accepted"] - before["accepted"] == 1
    _until(lambda: any(w.get("suppressed") for w in warnings), timeout=3.0)
    sub.undeclare()
    assert after["unknown"] - before["unknown"] == sent[0]  # refused unread
    # Triggers no section waits for: one warning a second at most, saying how many.
    unknown = [w for w in warnings if w["event"] == "warning" and "unknown" in w]
    assert unknown and all(w["trigger"] == "lights" for w in unknown)
    assert 0 < sum(w["unknown"] for w in unknown) <= sent[0]
    assert all(b["time"] - a["time"] >= 0.99 for a, b in itertools.pairwise(unknown))
    # Malformed ones (for a trigger the show waits for): each published or counted as left out.
    noisy = [w for w in warnings
             if (w["event"] == "warning" and "suppressed" not in w and "unknown" not in w)
             or (w["event"] == "trigger" and not w["accepted"])]
    seconds = max(w["time"] for w in warnings) - min(w["time"] for w in warnings) + 1
    assert 0 < len(noisy) <= 10 * (seconds + 1)  # the rest counted, not published
    assert len(noisy) + sum(w.get("suppressed", 0) for w in warnings) == sent[1]


def test_panic_wins_over_queued_commands_and_a_flood(
    client: ControlClient, session: zenoh.Session
) -> None:
    flood = Flood(session, trigger_key(NS, "lights"), b"{}", rate=2000)
    replies: list[dict[str, Any]] = []

    def start() -> None:
        try:
            replies.append(client.command("start"))
        except ControlFailed as exc:
            replies.append(exc.reply)

    starts = [threading.Thread(target=start) for _ in range(3)]
    try:
        for th in starts:
            th.start()
        time.sleep(0.05)  # the starts are in: one being armed, the others queued
        began = time.monotonic()
        panic = client.command("panic")
        assert time.monotonic() - began < 1.0
        for th in starts:
            th.join(10.0)
    finally:
        flood.stop()
    assert panic["ok"] and panic["state"] in ("ended", "idle")
    assert len(replies) == 3
    assert all(r["ok"] or r["error"] in ("cancelled", "refused") for r in replies), replies
    # Nothing plays after a panic: not the start being armed, not a queued one.
    _until(lambda: client.status()["state"] in ("loaded", "idle"))
    time.sleep(0.5)
    assert client.status()["state"] in ("loaded", "idle")


_SLOW_TRACK = """
    - repeat: 1700
      cues:
        - {move: {roll: 8, pitch: 5, yaw: 6, body_z: 100}, duration: 1.0}
        - {move: {roll: -8, pitch: -5, yaw: -6, body_z: 90}, duration: 1.0}"""
# 2.1 s of compiling (measured; two performers, 340,000 samples, within the limits): a load
# still under way when the panic comes half a second after it.
SLOW = f"""\
show: Slow to compile
performers:
  rex: {{model: mini}}
  ivy: {{model: mini}}
tracks:
  rex:{_SLOW_TRACK}
  ivy:{_SLOW_TRACK}
"""


def test_panic_cancels_the_commands_still_queued(
    client: ControlClient, session: zenoh.Session, triggered_path: Path
) -> None:
    replies: dict[str, dict[str, Any]] = {}
    patient = CheckedClient(session, NS, timeout=60.0)  # the load's compile may take seconds

    def send(command: str, **fields: Any) -> None:
        try:
            replies[command] = patient.command(command, **fields)
        except ControlFailed as exc:
            replies[command] = exc.reply

    load = threading.Thread(target=send, args=("load",), kwargs={"routine": SLOW})
    load.start()
    time.sleep(0.2)  # being compiled on the control thread
    start = threading.Thread(target=send, args=("start",))
    start.start()
    time.sleep(0.3)  # queued behind the load, which has seconds left
    before = _counters(client)["cancelled"]
    assert client.command("panic")["ok"]
    load.join(60.0)
    start.join(60.0)
    assert replies["start"]["error"] == "cancelled", replies["start"]
    assert replies["start"]["message"] == "start cancelled by a panic"
    assert replies["load"]["ok"]  # what was under way ends (loading moves nothing)
    assert _counters(client)["cancelled"] == before + 1
    assert client.status()["state"] == "loaded"
    client.command("load", path=str(triggered_path))


# The short triggered show with room for the tour's steps on a loaded machine: c waits 30 s
# for 'encore' (not 0.3: the tour must see it hold), and d plays 20 s (the pause after the seek
# must come before the show's end).
TOUR = ROUTINE.replace("timeout: 0.3", "timeout: 30").replace(
    "{at: 1.8, move: {pitch: 0}, duration: 0.5}", "{at: 1.8, move: {pitch: 0}, duration: 20}")
assert TOUR.count("duration: 20}") == 2


def test_every_payload_the_server_sends_matches_its_schema(
    client: ControlClient, session: zenoh.Session, triggered_path: Path
) -> None:
    """A tour of the API: every command's reply (checked by the client), then every event."""
    events: list[tuple[str, dict[str, Any]]] = []
    sub = session.declare_subscriber(
        event_key(NS), lambda s: events.append((str(s.key_expr), json.loads(s.payload.to_bytes())))
    )
    try:
        assert client.command("panic")["state"] == "idle"
        loaded = client.command("load", routine=TOUR)
        assert loaded["show"]["triggers"] == ["go", "encore"]
        client.command("start")
        _until(lambda: client.status()["state"] == "waiting")
        assert client.command("pause")["state"] == "waiting"  # held at a wait already
        session.put(trigger_key(NS, "lights"), b"{}")  # nobody waits: a refusal event
        session.put(trigger_key(NS, "go"), b"{not json")  # dropped: a warning event
        client.trigger("go", source="tour", data={"desk": 1})
        _until(lambda: client.status()["state"] == "waiting")  # at c, for 'encore'
        client.command("seek", section="d")  # (a section that waits would hold again)

        def pause_taken() -> bool:
            try:
                client.command("pause")
            except ControlFailed as exc:  # the seek still reaches a robot: said, not lost
                assert exc.code == "refused" and "cannot pause yet" in str(exc), exc.reply
                return False
            return True

        _until(pause_taken)
        _until(lambda: client.status()["state"] == "paused")
        time.sleep(1.1)  # a progress event (and the robots' telemetry) at least once a second
        client.command("resume")
        assert client.command("stop", reason="tour over")["state"] == "ended"
        _until(lambda: any(e["event"] == "state" and e.get("state") == "ended" for _, e in events))
    finally:
        sub.undeclare()
        client.command("load", path=str(triggered_path))
    kinds = set()
    for key, event in events:
        kind = "telemetry" if "/event/telemetry/" in key else key.rsplit("/", 1)[-1]
        assert event["event"] == kind, (key, event)
        check(f"event-{kind}", event)
        kinds.add(kind)
    # A fault needs a robot that fails: the runtime's tests make those.
    assert kinds == {"state", "cue", "wait", "trigger", "progress", "telemetry", "warning"}


def test_the_zenoh_only_example_imports_nothing_of_ours() -> None:
    import ast

    tree = ast.parse((ROOT / "examples" / "zenoh_control.py").read_text(encoding="utf-8"))
    modules = {alias.name.split(".")[0] for node in ast.walk(tree)
               if isinstance(node, ast.Import) for alias in node.names}
    modules |= {(node.module or "").split(".")[0] for node in ast.walk(tree)
                if isinstance(node, ast.ImportFrom)}
    assert "xgo_show" not in modules
    assert "zenoh" in modules
