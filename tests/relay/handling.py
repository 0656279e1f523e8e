"""What the in-process relay tests share (test_relay_handling.py, test_relay_plumbing.py,
test_relay_replies.py): conductors, requests as the relay decodes them, an upload and a start.
The session a relay declares on and the queries it answers are tests/relay/recording.py's
(``RecordingSession``, ``Incoming``), so a :class:`Relay` is started, queried and closed in
this process; everything above that layer is the relay's own code."""

from __future__ import annotations

from typing import Any

from xgo_show.net import messages as msg
from xgo_show.relay.server import Relay

from .conftest import upload_text, walk_schedule

ALICE = msg.Conductor("a1", "alice")
BOB = msg.Conductor("b2", "bob")


def request(op: str, who: msg.Conductor = ALICE, seq: int = 1, **fields: Any) -> msg.Request:
    """A request as the relay receives it: encoded, then decoded and checked."""
    raw = {"v": msg.PROTOCOL_VERSION, "op": op, "seq": seq, "conductor": who.to_json(),
           "sent": 1.0, **fields}
    return msg.decode_request(msg.encode(raw))


def encoded(op: str, who: msg.Conductor = ALICE, seq: int = 1, **fields: Any) -> bytes:
    """A request's payload as a conductor sends it."""
    return msg.encode(request(op, who, seq, **fields).to_json())


#: The key of relay hall's commands in namespace ns.
CMD = "ns/relay/hall/cmd"


def upload(relay: Relay, seconds: float = 0.3, **extra: Any) -> dict[str, Any]:
    text, sha = upload_text(walk_schedule(seconds, rex="mini"))
    fields = {"schedule": text, "sha256": sha, "link_loss": "stop", "watchdog_ms": 500,
              **extra}
    return relay.handle(request("upload", **fields))


def start(relay: Relay, sha: str, **fields: Any) -> dict[str, Any]:
    return relay.handle(request("start", sha256=sha, **fields))
