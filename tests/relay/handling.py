"""What the in-process relay tests share (test_relay_handling.py, test_relay_plumbing.py):
requests as the relay decodes them, and recording doubles of the lowest Zenoh layer a relay
uses (the session it declares on, the query it answers), so a :class:`Relay` is started,
queried and closed in this process. Everything above that layer is the relay's own code."""

from __future__ import annotations

import threading
from collections.abc import Callable
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


class Query:
    """What a queryable callback gets: a payload, and where the replies go (recorded, with
    the thread that sent each, so a test sees who answered)."""

    class _Payload:
        def __init__(self, data: bytes) -> None:
            self.data = data

        def to_bytes(self) -> bytes:
            return self.data

    def __init__(self, data: bytes | None, key: str = "ns/relay/hall/cmd") -> None:
        self.payload = None if data is None else self._Payload(data)
        self.key_expr = key
        self.replies: list[tuple[str, bytes]] = []
        self.errors: list[bytes] = []
        self.threads: list[str] = []
        self.express: list[bool] = []
        self.done = threading.Event()  # a reply or an error reply was sent
        self._dropped = threading.Event()

    def reply(self, key: str, data: bytes, *, express: bool = False) -> None:
        self.replies.append((key, data))
        self.express.append(express)
        self.threads.append(threading.current_thread().name)
        self.done.set()

    def reply_err(self, data: bytes) -> None:
        self.errors.append(data)
        self.threads.append(threading.current_thread().name)
        self.done.set()

    def drop(self) -> None:
        self._dropped.set()

    @property
    def dropped(self) -> bool:
        return self._dropped.is_set()

    def answer(self) -> dict[str, Any]:
        """The one relay reply (``msg.decode_reply``'s fields) on the query's own key."""
        assert self._dropped.wait(5.0) and len(self.replies) == 1  # a worker drops it last
        key, data = self.replies[0]
        assert key == self.key_expr
        return msg.decode_reply(data).__dict__ | {}


class Declared:
    """A queryable or liveliness token: its key, and whether it was withdrawn (in order)."""

    def __init__(self, session: Session, kind: str, key: str) -> None:
        self.session, self.kind, self.key = session, kind, key

    def undeclare(self) -> None:
        self.session.undeclared.append((self.kind, self.key))


class Session:
    """The part of a Zenoh session a relay uses: queryables (their callbacks recorded by key,
    for a test to call with a :class:`Query`) and liveliness tokens."""

    def __init__(self) -> None:
        self.queryables: dict[str, Callable[[Query], None]] = {}
        self.declared: list[tuple[str, str]] = []
        self.undeclared: list[tuple[str, str]] = []

    def declare_queryable(self, key: str, callback: Callable[[Query], None]) -> Declared:
        self.queryables[key] = callback
        self.declared.append(("queryable", key))
        return Declared(self, "queryable", key)

    def liveliness(self) -> Session:
        return self

    def declare_token(self, key: str) -> Declared:
        self.declared.append(("token", key))
        return Declared(self, "token", key)

    def query(self, key: str, data: bytes | None, timeout: float = 5.0) -> Query:
        """Send ``data`` to the queryable on ``key`` as Zenoh would; wait for its answer."""
        q = Query(data, key)
        self.queryables[key](q)
        assert q.done.wait(timeout), f"no answer on {key} within {timeout} s"
        return q


def upload(relay: Relay, seconds: float = 0.3, **extra: Any) -> dict[str, Any]:
    text, sha = upload_text(walk_schedule(seconds, rex="mini"))
    fields = {"schedule": text, "sha256": sha, "link_loss": "stop", "watchdog_ms": 500,
              **extra}
    return relay.handle(request("upload", **fields))


def start(relay: Relay, sha: str, **fields: Any) -> dict[str, Any]:
    return relay.handle(request("start", sha256=sha, **fields))
