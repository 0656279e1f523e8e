"""Roles through Zenoh's own access control, with real credentials (examples/zenoh-acl/).

``xgo-show serve`` runs as its own process with the documented ``serve.json5`` (user/password
authentication, access control by user name, default deny). An operator may start, trigger and
read; a viewer may only read status and events (its start and its trigger reach nobody); a user
in no role, a client without credentials and one with a wrong password see nothing at all.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from tests.children import exited, first_answer
from tests.conftest import wait_until
from tests.loopback import free_port

ROOT = Path(__file__).resolve().parents[2]
ACL = ROOT / "examples" / "zenoh-acl"
NS = "xgo-show"  # the namespace the example's rules name
# Seconds an ask that must go unanswered waits: an answer on loopback takes milliseconds.
REFUSED = 0.3


@pytest.fixture(scope="module")
def configs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example's files on a free loopback port, plus a user in no role."""
    folder = tmp_path_factory.mktemp("acl")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    for src in ACL.iterdir():
        text = src.read_text(encoding="utf-8")
        text = text.replace("tcp/0.0.0.0:7447", endpoint).replace("tcp/127.0.0.1:7447", endpoint)
        (folder / src.name).write_text(text, encoding="utf-8")
    with (folder / "users.txt").open("a", encoding="utf-8") as users:
        users.write("guest:guest-secret\n")
    guest = (folder / "viewer.json5").read_text(encoding="utf-8").replace("viewer", "guest")
    (folder / "guest.json5").write_text(guest, encoding="utf-8")
    operator = (folder / "operator.json5").read_text(encoding="utf-8")
    (folder / "wrong.json5").write_text(operator.replace("operator-secret", "guess"), "utf-8")
    stranger = "".join(line for line in operator.splitlines(keepends=True)
                       if "transport:" not in line)
    assert "usrpwd" not in stranger
    (folder / "stranger.json5").write_text(stranger, encoding="utf-8")
    return folder


@pytest.fixture(scope="module")
def server(configs: Path, triggered_path: Path) -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "serve", "--sim", "--no-telemetry", "--load",
         str(triggered_path), "--zenoh-config", "serve.json5"],
        cwd=configs, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    try:
        yield proc
    finally:
        proc.terminate()
        out = exited(proc, 10)
        assert proc.returncode == 0 and "Traceback" not in out, out


class Client:
    """One Zenoh session as ``who`` (its config file), with every event it receives."""

    def __init__(self, configs: Path, who: str) -> None:
        self.session = zenoh.open(zenoh.Config.from_file(str(configs / f"{who}.json5")))
        self.events: list[dict[str, Any]] = []
        self.sub = self.session.declare_subscriber(
            f"{NS}/event/**", lambda s: self.events.append(json.loads(s.payload.to_bytes()))
        )

    def ask(self, key: str, timeout: float = 1.0) -> dict[str, Any] | None:
        """The reply's JSON (an error reply too), or None when nobody answers."""
        for reply in self.session.get(f"{NS}/{key}", payload=b"{}", timeout=timeout):
            sample = reply.ok if reply.ok is not None else reply.err
            assert sample is not None
            return dict(json.loads(sample.payload.to_bytes()))
        return None

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()


def _seen(client: Client) -> set[tuple[str, str | None]]:
    """(event, state) of every event ``client`` received."""
    return {(e["event"], e.get("state")) for e in list(client.events)}


def _xgo(configs: Path, who: str, *args: str, timeout: float = 10.0
         ) -> subprocess.CompletedProcess[str]:
    """``xgo-show ARGS`` as another process, connecting as ``who``."""
    return subprocess.run(
        [sys.executable, "-m", "xgo_show", *args, "--zenoh-config",
         str(configs / f"{who}.json5"), "--timeout", str(timeout)],
        capture_output=True, text=True, timeout=60,
    )


def test_roles_operator_viewer_and_strangers(configs: Path, server: subprocess.Popen[str]) -> None:
    clients = {who: Client(configs, who) for who in ("operator", "viewer", "guest", "stranger",
                                                      "wrong")}
    try:
        operator, viewer = clients["operator"], clients["viewer"]
        first_answer(lambda: operator.ask("status", timeout=0.5), server)  # serve is up
        # Each session connects on its own: the operator's answer does not say the viewer's
        # session is up yet (on a busy machine it may take a while longer).
        status = first_answer(lambda: viewer.ask("status", timeout=0.5), server)
        assert status["state"] == "loaded"
        for who in ("guest", "stranger", "wrong"):
            assert clients[who].ask("status", timeout=REFUSED) is None, who
        refused = _xgo(configs, "viewer", "ctl", "start", timeout=1.0)
        assert refused.returncode == 2
        assert "no xgo-show serve answered" in refused.stderr, refused.stderr
        assert viewer.ask("control/start", timeout=REFUSED) is None
        started = _xgo(configs, "operator", "ctl", "start")
        assert started.returncode == 0, started.stderr
        wait_until(lambda: (operator.ask("status") or {}).get("state") == "waiting", 10.0)
        for who in ("viewer", "guest", "stranger", "wrong"):  # puts that must reach nobody
            clients[who].session.put(f"{NS}/trigger/go", b"{}",
                                     congestion_control=zenoh.CongestionControl.BLOCK)
        assert viewer.ask("trigger/go", timeout=REFUSED) is None
        time.sleep(0.3)
        assert (viewer.ask("status") or {}).get("state") == "waiting"
        fired = _xgo(configs, "operator", "trigger", "go")
        assert fired.returncode == 0, fired.stderr
        assert fired.stdout.strip() == "trigger 'go': released section 'b'"
        wait_until(lambda: (viewer.ask("status") or {}).get("state") == "loaded", 10.0)
        wait_until(lambda: all(("state", "ended") in _seen(clients[who])  # the last events
                               for who in ("operator", "viewer")), 5.0)
    finally:
        for client in clients.values():
            client.close()
    seen = {who: _seen(c) for who, c in clients.items()}
    for who in ("operator", "viewer"):
        assert {("state", "playing"), ("wait", "waiting"), ("state", "ended")} <= seen[who], who
    triggers = [(e["trigger"], e["accepted"]) for e in viewer.events if e["event"] == "trigger"]
    assert triggers == [("go", True)]  # the operator's; nobody else's reached the show
    assert seen["guest"] == seen["stranger"] == seen["wrong"] == set()
