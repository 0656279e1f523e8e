"""``serve --follow osc:...``: a sound desk's OSC cues over real UDP (python-osc's client) start
the loaded show and fire its triggers, which release the waits as a Zenoh trigger does (the same
``trigger`` and ``wait`` events, source ``osc``); a bad cue is one line, not a crash."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pythonosc.udp_client import SimpleUDPClient

from tests.children import exited, read_until
from tests.control.conftest import control_session
from tests.loopback import free_port
from xgo_show.control.client import ControlClient
from xgo_show.control.keys import event_key

NS = "osc-serve-test"


def _until(check: Callable[[], bool], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_the_desk_starts_the_show_and_its_triggers_release_the_waits(
    triggered_path: Path,
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "serve", "--sim", "--load", str(triggered_path),
         "--listen", endpoint, "--namespace", NS, "--no-telemetry",
         "--follow", "osc:127.0.0.1:0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    seen: list[str] = []
    events: list[dict[str, Any]] = []
    try:
        line = read_until(proc, r"listening for OSC cues on 127\.0\.0\.1:\d+ ", seen)
        port = int(re.search(r":(\d+) ", line).group(1))  # type: ignore[union-attr]
        desk = SimpleUDPClient("127.0.0.1", port)
        with control_session(proc, endpoint, NS) as session:
            client = ControlClient(session, NS, timeout=5.0)
            sub = session.declare_subscriber(
                event_key(NS), lambda s: events.append(json.loads(s.payload.to_bytes())))
            client.status()  # the subscriber is in place before anything is published
            desk.send_message("/trigger", "go")  # nothing runs yet: refused, said
            read_until(proc, r"osc: trigger 'go' refused: no show is running", seen)
            desk.send_message("/trigger", "lights")  # nobody waits for it: counted
            read_until(proc, r"osc: trigger 'lights' refused: no section of this show waits "
                       r"for 'lights' \(its triggers: encore, go\)", seen)
            desk.send_message("/trigger", 5)
            read_until(proc, r"osc: /trigger takes one trigger name", seen)
            assert client.status()["counters"]["unknown"] == 1
            desk.send_message("/go", [])
            read_until(proc, r"starting 'Triggered test' from 0 s", seen)
            _until(lambda: client.status()["state"] == "waiting")
            assert client.status()["waiting_for"]["trigger"] == "go"
            desk.send_message("/trigger", "go")
            _until(lambda: client.status()["state"] == "waiting"
                   and client.status()["waiting_for"]["trigger"] == "encore")
            desk.send_message("/trigger", "encore")
            _until(lambda: client.status()["state"] in ("loaded", "idle"))
            last = client.status()["last_result"]
            assert last["completed"] is True and last["reason"] == "completed"
            sub.undeclare()
    finally:
        proc.terminate()
        out = exited(proc, 10)
    assert proc.returncode == 0, "".join(seen) + out
    accepted = [(e["trigger"], e["section"], e["held"], e["source"]) for e in events
                if e["event"] == "trigger" and e["accepted"]]
    assert accepted == [("go", "b", True, "osc"), ("encore", "c", True, "osc")]
    released = [(e["section"], e.get("how")) for e in events
                if e["event"] == "wait" and e["state"] == "released"]
    assert released == [("b", "trigger"), ("c", "trigger")]


def test_a_bad_follow_spec_is_a_usage_error() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "xgo_show", "serve", "--sim", "--follow", "osc:nine"],
        capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 2, proc.stderr
    assert "--follow 'osc:nine': write osc:[HOST:]PORT, e.g. osc:9000" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_trigger_cues_parse_to_a_name_or_a_reason() -> None:
    from xgo_show.timecode.osc import Command, parse_command

    assert parse_command("/trigger", ["encore"]) == Command("trigger", name="encore")
    assert parse_command("/xgo/trigger", ["go_2-b"], prefix="/xgo") == \
        Command("trigger", name="go_2-b")
    for bad in ([], ["a", "b"], [3], ["1st"], ["a b"], ["x" * 65]):
        reason = parse_command("/trigger", bad)
        assert isinstance(reason, str) and reason.startswith("/trigger takes one trigger name")
    assert parse_command("/trigger", ["x" * 64]) == Command("trigger", name="x" * 64)
