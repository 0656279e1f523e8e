"""The one recording stand-in for a Zenoh session in the in-process tests: the calls the
conductor's relay code makes (``session.get``, ``session.liveliness().get``, the clock
tracker's ``declare_querier``), and a server's side (queryables, subscribers, liveliness
tokens, ``put``) for the relay (relay/server.py), the time server (net/timesync.py) and
``serve`` (control/server.py). The relay client, the relayed performers, the conductor's
endpoint, the relay and the servers run in the test process without Zenoh: mutmut forks each
mutant's tests from a process whose Zenoh runtime does not survive the fork
(docs/contributing.md).

Every query is recorded. A responder given by the test answers it, as a relay would, with
:func:`answer` (a relay's reply to the query), :func:`time_server` (its clock) or
:class:`Answer` (anything else); a query sent with a callback is answered at once, unless the
session ``holds`` them: the test then answers each held query itself (:meth:`Query.deliver`),
at the moment it chooses. A ``loopback`` session answers its queries with its own
queryables, so both sides of a protocol (a clock tracker and a time server) share one session.
A query to a server (:meth:`RecordingSession.query`, or :class:`Incoming` handed to a callback)
records its replies, which thread sent each and whether express. Only this lowest layer is
stood in for: the client, its heartbeat thread and watchdog, the clock tracker, the relay and
the servers are the real ones.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import zenoh

from xgo_show.net import messages as msg
from xgo_show.net.timesync import SYNC_VERSION


class Payload:
    """A sample's payload (``to_bytes`` only)."""

    def __init__(self, data: bytes) -> None:
        self.data = data

    def to_bytes(self) -> bytes:
        return self.data


class Sample:
    """A reply's sample: its payload and key."""

    def __init__(self, data: bytes, key_expr: str) -> None:
        self.payload = Payload(data)
        self.key_expr = key_expr


class Answer:
    """What a ``zenoh.Reply`` offers: a sample (``ok``) or an error (``err``)."""

    def __init__(self, ok: bytes | None = None, err: bytes | None = None, key: str = "") -> None:
        self.ok = None if ok is None else Sample(ok, key)
        self.err = None if err is None else Sample(err, key)


class Query:
    """One ``session.get``: its key, payload and options, and its callback if it had one."""

    def __init__(self, key: str, payload: bytes, timeout: float, congestion_control: Any,
                 handler: Any) -> None:
        self.key = key
        self.payload = payload
        self.timeout = timeout
        self.congestion_control = congestion_control
        self.at = time.monotonic()
        if isinstance(handler, zenoh.handlers.Callback):
            self._call, self._drop = handler.callback, handler.drop
        else:
            self._call, self._drop = handler, None
        self.delivered = False
        self.via_querier = False  # sent by a declared querier, not a plain get

    @property
    def request(self) -> dict[str, Any]:
        """The request as sent (decoded JSON)."""
        decoded: dict[str, Any] = json.loads(self.payload)
        return decoded

    @property
    def op(self) -> str:
        return str(self.request["op"])

    @property
    def seq(self) -> int:
        return int(self.request["seq"])

    def deliver(self, answers: Sequence[Answer]) -> None:
        """Hand ``answers`` to the query's callback, then end the query (its drop)."""
        assert self._call is not None, "a query without a callback returns its answers"
        self.delivered = True
        for a in answers:
            self._call(a)
        if self._drop is not None:
            self._drop()


Responder = Callable[[Query], Sequence[Answer]]


def answer(query: Query, *, relay: str = "hall", relay_time: float | None = None,
           seq: int | None = None, error: str | None = None, **fields: Any) -> Answer:
    """The relay's reply to ``query`` (a refusal if ``error``), with the reply's ``fields``;
    ``relay_time`` defaults to the test process's monotonic clock (the relay's clock here)."""
    body = {
        "v": msg.PROTOCOL_VERSION,
        "seq": query.seq if seq is None else seq,
        "ok": error is None,
        "error": error,
        "relay": relay,
        "relay_time": time.monotonic() if relay_time is None else relay_time,
        **fields,
    }
    return Answer(msg.encode(body), key=query.key)


def silent(query: Query) -> Sequence[Answer]:
    """No relay answers."""
    return []


def replying(query: Query) -> Sequence[Answer]:
    """A relay that accepts every command with an empty reply."""
    return [answer(query)]


def time_server(query: Query, ahead: float = 0.0) -> Sequence[Answer]:
    """A relay's time server (net/timesync.py) whose clock is ``ahead`` of this process's:
    answers pings with its time and takes any timebase."""
    request = query.request
    if request.get("op") == "ping":
        now = time.monotonic() + ahead
        body = {"v": SYNC_VERSION, "seq": request.get("seq"), "t1": now, "t2": now}
        return [Answer(json.dumps(body).encode(), key=query.key)]
    return [Answer(json.dumps({"v": SYNC_VERSION, "ok": True}).encode(), key=query.key)]


class Querier:
    """A declared querier: its queries go to the session's responder like any other (its
    ``options`` and every payload it sent recorded)."""

    def __init__(self, session: RecordingSession, key: str, timeout: float,
                 options: dict[str, Any] | None = None) -> None:
        self.session = session
        self.key = key
        self.timeout = timeout
        self.options = {} if options is None else options
        self.payloads: list[bytes] = []
        self.undeclared = False

    def get(self, *, payload: bytes) -> list[Answer]:
        if self.session.broken:
            raise zenoh.ZError("session closed")
        self.payloads.append(bytes(payload))
        answers = self.session.get(self.key, payload=payload, timeout=self.timeout,
                                   _via_querier=True)
        assert answers is not None
        return answers

    def undeclare(self) -> None:
        self.undeclared = True
        self.session.undeclared.append(("querier", self.key))


class Declared:
    """A queryable, subscriber or liveliness token declared on the session (``handler``: its
    callback, or for a ring-channel subscriber the ring its samples wait in; a token has
    none). Undeclaring it is recorded on the session too, in order."""

    def __init__(self, kind: str, key: str, handler: Any,
                 session: RecordingSession | None = None) -> None:
        self.kind = kind
        self.key = key
        self.session = session
        if kind == "token":
            self.callback: Any = None
            self.handler: Any = None
        elif isinstance(handler, zenoh.handlers.Callback):
            self.callback, self.handler = handler.callback, handler
        elif callable(handler):
            self.callback, self.handler = handler, handler
        else:  # a channel: the samples wait in a ring
            self.callback, self.handler = None, Ring()
        self.undeclared = False

    def undeclare(self) -> None:
        self.undeclared = True
        if self.session is not None:
            with self.session.lock:
                self.session.undeclared.append((self.kind, self.key))


class Ring:
    """A ring channel's receiving end (``try_recv``)."""

    def __init__(self) -> None:
        self.items: list[Any] = []
        self.lock = threading.Lock()

    def try_recv(self) -> Any:
        with self.lock:
            return self.items.pop(0) if self.items else None


class Incoming:
    """A query as a queryable's callback gets it: a key, a payload, and where replies go
    (recorded, with the thread that sent each and whether express, so a test sees who
    answered and how)."""

    def __init__(self, key: str, data: bytes | None) -> None:
        self.key_expr = key
        self.payload = None if data is None else Payload(data)
        self.replies: list[tuple[str, bytes]] = []
        self.errors: list[bytes] = []
        self.threads: list[str] = []
        self.express: list[bool] = []
        self.done = threading.Event()  # a reply or an error reply was sent
        self.dropped = threading.Event()

    def reply(self, key: Any, data: bytes, *, express: bool = False) -> None:
        self.replies.append((str(key), bytes(data)))
        self.express.append(express)
        self.threads.append(threading.current_thread().name)
        self.done.set()

    def reply_err(self, data: bytes) -> None:
        self.errors.append(bytes(data))
        self.threads.append(threading.current_thread().name)
        self.done.set()

    def drop(self) -> None:
        self.dropped.set()

    def answer(self, timeout: float = 10.0) -> dict[str, Any]:
        """The one reply or error reply, decoded, once the query is done (dropped)."""
        assert self.dropped.wait(timeout), "the query was never answered"
        assert len(self.replies) + len(self.errors) == 1, (self.replies, self.errors)
        if self.replies:
            key, data = self.replies[0]
            assert key == self.key_expr
        else:
            data = self.errors[0]
        decoded: dict[str, Any] = json.loads(data)
        return decoded


def matches(expr: str, key: str) -> bool:
    """Whether ``key`` is in key expression ``expr`` (``*``: one chunk, ``**``: any)."""
    e, k = expr.split("/"), key.split("/")
    if e[-1] == "**":
        head = e[:-1]
        return len(k) >= len(head) and all(a in ("*", b) for a, b in zip(head, k, strict=False))
    return len(e) == len(k) and all(a in ("*", b) for a, b in zip(e, k, strict=True))


class _Liveliness:
    def __init__(self, session: RecordingSession) -> None:
        self.session = session

    def get(self, key: str, *, timeout: float = 10.0) -> list[Answer]:
        self.session.liveliness_gets.append((str(key), timeout))
        return [Answer(b"", key=k) for k in self.session.alive]

    def declare_token(self, key: Any) -> Declared:
        return self.session._declare("token", key, None)


class RecordingSession:
    """Stands in for a ``zenoh.Session``'s queries: records each, answers with ``respond``."""

    def __init__(self, respond: Responder = silent, *, hold: bool = False,
                 alive: Sequence[str] = (), loopback: bool = False) -> None:
        self.respond = self._loopback if loopback else respond
        self.hold = hold
        self.alive = list(alive)  # liveliness token keys
        self.queries: list[Query] = []
        self.liveliness_gets: list[tuple[str, float]] = []
        self.lock = threading.Lock()
        self.closed = False
        self.declared: list[Declared] = []
        self.undeclared: list[tuple[str, str]] = []  # (kind, key), in the order withdrawn
        self.queriers: list[Querier] = []
        self.puts: list[tuple[str, bytes, Any]] = []
        self.broken = False  # a querier's get raises, as on a closed session

    def get(self, key: Any, handler: Any = None, *, payload: bytes | None = None,
            timeout: float = 10.0, congestion_control: Any = None,
            _via_querier: bool = False) -> list[Answer] | None:
        query = Query(str(key), b"" if payload is None else bytes(payload), timeout,
                      congestion_control, handler)
        query.via_querier = _via_querier
        with self.lock:
            self.queries.append(query)
        if handler is None:
            return list(self.respond(query))
        if not self.hold:
            query.deliver(self.respond(query))
        return None

    def liveliness(self) -> _Liveliness:
        return _Liveliness(self)

    def declare_querier(self, key: Any, *, timeout: float = 10.0, **options: Any) -> Querier:
        querier = Querier(self, str(key), timeout, {"timeout": timeout, **options})
        with self.lock:
            self.queriers.append(querier)
        return querier

    def _loopback(self, query: Query) -> Sequence[Answer]:
        """Answer ``query`` with this session's own queryable for its key: what it replies
        (or errs) within the query's timeout."""
        targets = [d for d in self.live("queryable") if matches(d.key, query.key)]
        if not targets:
            return []
        incoming = Incoming(query.key, query.payload)
        targets[0].callback(incoming)
        if not incoming.done.wait(query.timeout):
            return []
        return ([Answer(ok=data, key=key) for key, data in incoming.replies]
                + [Answer(err=data, key=query.key) for data in incoming.errors])

    def close(self) -> None:
        self.closed = True

    # ------------------------------------------------------------------ a server's side

    def declare_queryable(self, key: Any, handler: Any) -> Declared:
        return self._declare("queryable", key, handler)

    def declare_subscriber(self, key: Any, handler: Any) -> Declared:
        return self._declare("subscriber", key, handler)

    def _declare(self, kind: str, key: Any, handler: Any) -> Declared:
        declared = Declared(kind, str(key), handler, self)
        with self.lock:
            self.declared.append(declared)
        return declared

    def put(self, key: Any, payload: bytes, *, congestion_control: Any = None) -> None:
        with self.lock:
            self.puts.append((str(key), bytes(payload), congestion_control))

    def live(self, kind: str) -> list[Declared]:
        """The declarations of ``kind`` not undeclared."""
        with self.lock:
            return [d for d in self.declared if d.kind == kind and not d.undeclared]

    def declarations(self) -> list[tuple[str, str]]:
        """(kind, key) of everything declared, in order (withdrawn or not)."""
        with self.lock:
            return [(d.kind, d.key) for d in self.declared]

    @property
    def queryables(self) -> dict[str, Callable[[Incoming], None]]:
        """The live queryables' callbacks by their key, for a test to call directly."""
        return {d.key: d.callback for d in self.live("queryable")}

    def query(self, key: str, payload: bytes | None = None, *,
              wait: float | None = None) -> Incoming:
        """A query from a client: handed to the queryable whose key matches (returns it; its
        reply may come later, from another thread, unless ``wait`` seconds are given for it)."""
        incoming = Incoming(key, payload)
        (target,) = [d for d in self.live("queryable") if matches(d.key, key)]
        target.callback(incoming)
        if wait is not None:
            assert incoming.done.wait(wait), f"no answer on {key} within {wait} s"
        return incoming

    def publish(self, key: str, payload: bytes = b"") -> int:
        """A put from a client: to every matching subscriber (a ring keeps it); how many."""
        targets = [d for d in self.live("subscriber") if matches(d.key, key)]
        for d in targets:
            sample = Sample(payload, key)
            if d.callback is None:
                with d.handler.lock:
                    d.handler.items.append(sample)
            else:
                d.callback(sample)
        return len(targets)

    def put_payloads(self, prefix: str = "") -> list[tuple[str, dict[str, Any]]]:
        """The puts so far (decoded), of keys starting with ``prefix``."""
        with self.lock:
            return [(k, json.loads(p)) for k, p, _ in self.puts if k.startswith(prefix)]

    def gets(self) -> list[Query]:
        """The plain gets so far (not a declared querier's), in the order sent."""
        with self.lock:
            return [q for q in self.queries if not q.via_querier]

    def of(self, op: str) -> list[Query]:
        """The queries of one op, in the order sent."""
        with self.lock:
            return [q for q in self.queries if q.payload and q.op == op]

    def held(self, op: str) -> list[Query]:
        """The queries of ``op`` not answered yet (a holding session)."""
        return [q for q in self.of(op) if not q.delivered]


ROBOTS = [{"name": "dog1", "model": "mini", "port": "/dev/pts/7"},
          {"name": "dog2", "model": "lite"}]


class ScriptedRelay:
    """Answers as relay ``hall`` would: its description, its pre-flight rows, its time."""

    def __init__(self) -> None:
        self.robots: list[dict[str, Any]] = list(ROBOTS)
        self.refuse: dict[str, str] = {}  # op -> refusal
        self.time = True
        self.preflight: list[Any] = [
            {"performer": "dog9", "opened": True},  # not in this show: left out
            {"performer": "dog1", "opened": True, "firmware": "R-1.2", "detected": "mini",
             "battery": 81.0, "voltage": None, "low_latency": True,
             "notes": ["port 115200 baud"]},
            {"performer": "dog2", "opened": True, "firmware": None, "detected": 3,
             "battery": None, "voltage": 7.4, "low_latency": 0, "problems": ["battery low"]},
        ]

    def __call__(self, q: Query) -> Sequence[Answer]:
        op = q.op
        if op in ("ping", "timebase"):
            return time_server(q) if self.time else []
        if op in self.refuse:
            return [answer(q, error=self.refuse[op])]
        if op == "hello":
            return [answer(q, description={"relay": "hall", "robots": self.robots})]
        if op == "upload":
            return [answer(q, sha256=q.request["sha256"], preflight=self.preflight)]
        if op == "probe":
            return [answer(q, rows=[["port", "/dev/pts/7"], ["firmware", 12]])]
        return [answer(q)]


def record_threads(monkeypatch: Any, module: Any) -> list[tuple[str, bool | None]]:
    """From now on, every thread ``module`` makes through ``threading.Thread`` is recorded as
    (name, the daemon flag it was given) in the list returned (in order)."""
    made: list[tuple[str, bool | None]] = []

    class Recorded(threading.Thread):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            made.append((self.name, kwargs.get("daemon")))

    monkeypatch.setattr(module.threading, "Thread", Recorded)
    return made
