"""``xgo-show serve`` driving robots behind an ``xgo-show relay``: three OS processes.

The relay owns the simulated robots (real ptys); serve reaches it through its own Zenoh session
(``--map NAME=zenoh:RELAY/ROBOT``); this test process is the operator. A triggered show plays
to its end on the relay's robots, held at its wait until the operator's trigger.

Two waits: ``go`` released by the operator, ``encore`` taken by its timeout (a seek to ``d``),
so the director's second and third commands to the relay's robots reach them too.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from tests.children import exited, first_answer
from tests.control.conftest import status_or_none
from tests.loopback import free_port
from tests.relay.processes import Relays
from xgo_show.control.client import ControlClient
from xgo_show.net.session import SessionOptions, open_session

NS = f"test-serve-relayed-{os.getpid()}"


def _until_status(client: ControlClient, states: tuple[str, ...], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while client.status()["state"] not in states:
        assert time.monotonic() < deadline, f"never {states}: {client.status()}"
        time.sleep(0.02)


def test_serve_plays_a_triggered_show_on_relayed_robots(
    relays: Relays, triggered_path: Path
) -> None:
    show = triggered_path
    relay = relays.start("stage", {"rex": "mini", "ivy": "lite"}, "--namespace", NS)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    serve = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "serve", "--map", "rex=zenoh:stage/rex",
         "--map", "ivy=zenoh:stage", "--no-telemetry", "--load", str(show),
         "--listen", endpoint, "--connect", relay.endpoint, "--namespace", NS,
         "--watchdog-ms", "3000"],  # the shared machine can be loaded (14 seen)
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    session = open_session(SessionOptions(connect=(endpoint,), namespace=NS))
    try:
        client = ControlClient(session, NS, timeout=1.0)
        first_answer(lambda: status_or_none(client), serve)  # the handshake: serve is up
        client.timeout = 10.0
        reply = client.command("start")
        assert [r["performer"] for r in reply["preflight"]["rows"]] == ["rex", "ivy"]
        _until_status(client, ("waiting",), 10.0)
        held = len(relay.received("rex"))
        time.sleep(0.3)  # held at the wait: nothing new reaches the relay's robot
        assert len(relay.received("rex")) == held
        assert client.trigger("go")["held"] is True
        try:
            _until_status(client, ("loaded",), 10.0)
        except AssertionError:
            serve.terminate()
            raise AssertionError(exited(serve, 10)) from None
        last = client.status()["last_result"]
        assert last["completed"] is True, last
        assert len(relay.received("rex")) > held and len(relay.received("ivy")) > held / 2
    finally:
        session.close()
        serve.terminate()
        out = exited(serve, 10)
    assert serve.returncode == 0, out
    assert "Traceback" not in out
