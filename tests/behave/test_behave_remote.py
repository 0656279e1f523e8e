"""Triggers over Zenoh: ``xgo-show behave --serve`` in its own process, on a simulated Rider
on a real pty, and this process as any Zenoh client would be (multicast scouting off,
explicit loopback endpoints): a query for a trigger no rule waits for is refused with the
behaviour's triggers listed; a put fires a rule, which plays its routine; every decision comes
back as an ``NS/event/rule`` event."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import zenoh

from tests.children import exited, first_answer
from tests.conftest import wait_until
from tests.loopback import client_config, free_port
from xgo_show.control.keys import event_key, trigger_key

NS = f"test-behave-{os.getpid()}"


def _get(session: zenoh.Session, key: str) -> tuple[bool, dict[str, Any]] | None:
    """(ok, body) of the first reply to a query on ``key``; None: nobody answered (in time)."""
    for reply in session.get(key, payload=b'{"v": 1, "source": "test"}', timeout=1.0):
        if reply.ok is not None:
            return True, json.loads(reply.ok.payload.to_bytes())
        assert reply.err is not None
        error = reply.err.payload.to_bytes()
        if error == b"Timeout":  # Zenoh's own: the queryable was slow (a busy machine), ask again
            return None
        return False, json.loads(error)
    return None


def test_a_zenoh_client_fires_a_behaviours_trigger(tmp_path: Path) -> None:
    (tmp_path / "wave.yaml").write_text(textwrap.dedent("""\
        show: wave
        performers: {rio: {model: rider}}
        tracks:
          rio: [{move: {body_z: 80}, duration: 0.6}]
        """))
    (tmp_path / "b.yaml").write_text(textwrap.dedent("""\
        behaviour: remote
        performers: {rio: {model: rider}}
        routines: {wave: wave.yaml}
        triggers: [visitor]
        rules:
          - {name: greet, when: [{trigger: visitor}], do: [{play: wave}]}
        """))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "behave", str(tmp_path / "b.yaml"), "--sim",
         "--serve", "--listen", endpoint, "--namespace", NS],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    events: list[dict[str, Any]] = []
    try:
        with zenoh.open(client_config(endpoint)) as session:
            sub = session.declare_subscriber(
                event_key(NS), lambda s: events.append(json.loads(s.payload.to_bytes())))
            ok, body = first_answer(lambda: _get(session, trigger_key(NS, "doorbell")), proc)
            assert not ok and body["error"] == "unknown_trigger"
            assert "no rule of the behaviour waits for it (its triggers: visitor)" in (
                body["message"])
            session.put(trigger_key(NS, "visitor"), b'{"v": 1, "source": "door"}')
            wait_until(lambda: any(e.get("event") == "rule" and e["what"] == "action"
                                   for e in list(events)), timeout=5.0)
            sub.undeclare()
        proc.send_signal(signal.SIGINT)  # Ctrl-C: every robot safe-stopped, exit 0
        out = exited(proc)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, out
    rules = [(e["rule"], e["what"], e["text"]) for e in events if e["event"] == "rule"]
    assert ("greet", "fired", "trigger visitor") in rules
    assert ("greet", "action", "rio plays wave") in rules
    triggers = [(e["trigger"], e["accepted"]) for e in events if e["event"] == "trigger"]
    assert ("doorbell", False) in triggers and ("visitor", True) in triggers
    lines = [" ".join(line.split()[1:]) for line in out.splitlines()]
    assert "rule greet: action: rio plays wave" in lines
    assert any(line.startswith("serving triggers on") for line in out.splitlines())
    assert "stopped: every robot was safe-stopped" in out
