"""``serve``'s server over a recording session (tests/relay/recording.py), for the server's
in-process tests (test_server_logic.py, test_server_running.py): queries and puts handed to its
own queryables and subscribers, its replies, event puts and lines recorded."""

from __future__ import annotations

import json
import threading
from typing import Any

from tests.relay.recording import Incoming, RecordingSession
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.protocol import PROTOCOL_VERSION
from xgo_show.control.server import ServeOptions, ShowServer

NS = "ns"


class Serve:
    """A server on a recording session; ``said``: its lines; ``hold_load``: a load blocks in
    its "loaded" line until released (the control thread is then busy)."""

    def __init__(self, **opts: Any) -> None:
        self.session = RecordingSession()
        self.said: list[str] = []
        self.block = threading.Event()
        self.blocked = threading.Event()
        self.hold_load = False
        options = ServeOptions(namespace=NS, **{"sim": True, "telemetry": False, **opts})
        self.server = ShowServer(self.session, options, say=self._say)

    def _say(self, line: str) -> None:
        self.said.append(line)
        if self.hold_load and line.startswith("loaded"):
            self.blocked.set()
            self.block.wait(10.0)

    def query(self, command: str, raw: bytes | None = None, **fields: Any) -> Incoming:
        data = raw if raw is not None else (json.dumps(fields).encode() if fields else None)
        return self.session.query(f"{NS}/control/{command}", data)

    def ask(self, command: str, raw: bytes | None = None, **fields: Any) -> dict[str, Any]:
        return self.query(command, raw, **fields).answer()

    def trigger(self, name: str, raw: bytes | None = None) -> Incoming:
        return self.session.query(f"{NS}/trigger/{name}", raw)

    def events(self, kind: str) -> list[dict[str, Any]]:
        return [p for _, p in self.session.put_payloads(f"{NS}/event/{kind}")]

    def close(self) -> None:
        self.block.set()
        self.server.close()


def refusal(got: dict[str, Any], command: str, code: str, message: str) -> None:
    assert got == {"v": PROTOCOL_VERSION, "ok": False, "command": command, "error": code,
                   "message": message}


def block_the_control_thread(s: Serve, schedule: Schedule) -> Incoming:
    s.hold_load = True
    q = s.query("load", schedule=schedule_to_bytes(schedule).decode())
    assert s.blocked.wait(10.0)
    return q
