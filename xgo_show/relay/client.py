"""The conductor's side of the relay protocol: commands, heartbeats, discovery.

:class:`RelayClient` sends one relay the commands of :mod:`xgo_show.net.messages` as Zenoh
queries (reliable, congestion control BLOCK: a command is never dropped to make room) and
checks each reply. :meth:`RelayClient.start_heartbeat` sends a heartbeat query every
``period`` without waiting for the previous answer, so a frozen relay (whose TCP socket stays
open) is noticed after ``watchdog`` seconds of silence, not after Zenoh's lease.

:func:`list_relays` asks every live relay (liveliness tokens) for its description.
"""

from __future__ import annotations

import contextlib
import dataclasses
import getpass
import json
import os
import socket
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from xgo_show.errors import NetworkError
from xgo_show.net import messages as msg
from xgo_show.net.keys import check_relay_name, relay_key, relay_wildcard
from xgo_show.net.watchdog import Watchdog

if TYPE_CHECKING:
    import zenoh

__all__ = [
    "RECENT_RTTS",
    "WORKED_ON",
    "Outcome",
    "RelayClient",
    "RelayLink",
    "list_relays",
    "new_conductor",
]


def new_conductor(name: str | None = None) -> msg.Conductor:
    """This process as a conductor: a fresh id, and ``user@host pid N`` for people."""
    if name is None:
        try:
            user = getpass.getuser()
        except (KeyError, OSError):
            user = "someone"
        name = f"{user}@{socket.gethostname()} pid {os.getpid()}"
    return msg.Conductor(uuid.uuid4().hex, name)


#: How many recent round trips a :class:`RelayLink` keeps (a few seconds of heartbeats).
RECENT_RTTS = 32

#: Commands the relay works on before it answers (a pre-flight, a robot's probe, a safe stop):
#: their round trips say how long that took, not how long the network takes, so they are left
#: out of :attr:`RelayLink.recent` (the lead of a start is made from those).
WORKED_ON = frozenset({"upload", "probe", "stop"})

#: What :meth:`RelayClient.send` hands its ``on_done``: the reply, or why there is none.
Outcome = msg.Reply | NetworkError


@dataclasses.dataclass
class RelayLink:
    """What the heartbeats say about one relay (updated from Zenoh's threads)."""

    last_reply: float = float("-inf")  # conductor's monotonic time of the last answer
    best_rtt: float = float("inf")
    offset: float = 0.0  # relay clock - conductor clock, from the lowest round trip seen
    status: dict[str, Any] | None = None  # the last heartbeat's show status
    lost: bool = False
    #: the round trips of the last exchanges (heartbeats and commands), newest last
    recent: deque[float] = dataclasses.field(default_factory=lambda: deque(maxlen=RECENT_RTTS))

    def worst_recent_rtt(self) -> float | None:
        """The longest of the last :data:`RECENT_RTTS` round trips (None before any)."""
        recent = tuple(self.recent)  # a copy: Zenoh's threads append meanwhile
        return max(recent) if recent else None


class RelayClient:
    """Commands to the relay ``relay`` over ``session``, as ``conductor``."""

    def __init__(
        self,
        session: zenoh.Session,
        relay: str,
        *,
        namespace: str = "xgo-show",
        conductor: msg.Conductor | None = None,
        timeout: float = 3.0,
    ) -> None:
        self.session = session
        self.relay = check_relay_name(relay)
        self.namespace = namespace
        self.conductor = conductor if conductor is not None else new_conductor()
        self.timeout = timeout
        self.key = relay_key(namespace, relay, "cmd")
        self.link = RelayLink()
        self._seq = 0
        self._seq_lock = threading.Lock()
        self._beat_stop = threading.Event()
        self._beat: threading.Thread | None = None

    def _next(self, op: str, fields: dict[str, Any]) -> tuple[int, bytes]:
        with self._seq_lock:
            self._seq += 1
            seq = self._seq
        request = msg.Request(op, seq, self.conductor, time.monotonic(), fields)
        return seq, msg.encode(request.to_json())

    def request(self, op: str, *, timeout: float | None = None, **fields: Any) -> msg.Reply:
        """Send one command and return its reply; a :class:`NetworkError` if refused or lost."""
        import zenoh

        seq, payload = self._next(op, fields)
        wait = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + wait
        while True:
            sent = time.monotonic()
            replies = list(
                self.session.get(
                    self.key,
                    payload=payload,
                    timeout=max(0.01, deadline - sent),
                    congestion_control=zenoh.CongestionControl.BLOCK,
                )
            )
            # No answer long before the timeout: no route to the relay yet (the session is
            # still learning of it), so the request was never delivered: send it again.
            if replies or time.monotonic() > deadline - 0.05:
                break
            time.sleep(0.02)
        if not replies:
            raise self._unanswered(op, wait)
        return self._check(op, seq, sent, replies[0])

    def send(
        self,
        op: str,
        on_done: Callable[[Outcome], None],
        *,
        timeout: float | None = None,
        **fields: Any,
    ) -> None:
        """Send one command without waiting: ``on_done`` gets its reply (or the error) once,
        from a Zenoh thread.

        Commands to many relays are then in flight together: a start to 16 relays costs one
        round trip, not 16. The relay must be reachable already (a held relay is: its
        heartbeats flow), so there is no resend for a route still being learnt.
        """
        import zenoh

        seq, payload = self._next(op, fields)
        wait = self.timeout if timeout is None else timeout
        lock = threading.Lock()
        got: list[Outcome] = []

        def finish(outcome: Outcome) -> None:
            with lock:
                if got:
                    return
                got.append(outcome)
            on_done(outcome)

        def on_reply(answer: zenoh.Reply) -> None:
            try:
                finish(self._check(op, seq, sent, answer))
            except NetworkError as exc:
                finish(exc)

        sent = time.monotonic()
        try:
            self.session.get(
                self.key,
                zenoh.handlers.Callback(on_reply, lambda: finish(self._unanswered(op, wait))),
                payload=payload,
                timeout=wait,
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
        except zenoh.ZError as exc:
            finish(NetworkError(f"relay {self.relay}: {op} not sent: {exc}"))

    def _check(self, op: str, seq: int, sent: float, answer: zenoh.Reply) -> msg.Reply:
        """The relay's reply to request ``seq``, or a :class:`NetworkError` saying why not."""
        ok = answer.ok
        if ok is None:
            err = answer.err
            text = "" if err is None else err.payload.to_bytes().decode("utf-8", "replace")
            raise NetworkError(f"relay {self.relay}: {op}: {text or 'error reply'}")
        reply = msg.decode_reply(ok.payload.to_bytes())
        self._learn(sent, time.monotonic(), reply.relay_time, network=op not in WORKED_ON)
        if not reply.ok:
            raise NetworkError(f"relay {self.relay}: {reply.error}")
        if reply.seq != seq:
            raise NetworkError(f"relay {self.relay}: {op}: reply to request {reply.seq}")
        return reply

    def _unanswered(self, op: str, wait: float) -> NetworkError:
        return NetworkError(
            f"relay {self.relay} did not answer {op} within {wait:g} s "
            "(is it running, in the same namespace, reachable with these endpoints?)"
        )

    def _learn(
        self, sent: float, received: float, relay_time: float, *, network: bool = True
    ) -> None:
        """Keep the clock offset of the exchange with the lowest round trip (NTP-style);
        a ``network`` round trip (not one the relay spent working) joins the recent ones."""
        link = self.link
        link.last_reply = received
        rtt = received - sent
        if network:
            link.recent.append(rtt)
        if rtt <= link.best_rtt:
            link.best_rtt = rtt
            link.offset = relay_time - (sent + received) / 2

    # ------------------------------------------------------------------ commands

    def hello(self) -> dict[str, Any]:
        """Claim the relay; return its description (refused if another conductor holds it)."""
        description = self.request("hello").fields.get("description")
        if not isinstance(description, dict):
            raise NetworkError(f"relay {self.relay}: hello reply without a description")
        return description

    def upload(
        self,
        text: str,
        sha256: str,
        *,
        link_loss: str = "stop",
        watchdog_ms: int = 500,
        battery_floor: float | None = None,
        timeout: float = 30.0,
    ) -> dict[str, Any]:
        """Upload a schedule's text; return the reply's fields (pre-flight rows included)."""
        reply = self.request(
            "upload",
            timeout=timeout,
            schedule=text,
            sha256=sha256,
            link_loss=link_loss,
            watchdog_ms=watchdog_ms,
            battery_floor=battery_floor,
        )
        return dict(reply.fields)

    def start(self, sha256: str, start_at: float, offset: float = 0.0) -> None:
        """Start the uploaded show at ``start_at`` on the RELAY's clock."""
        self.request("start", sha256=sha256, start_at=start_at, offset=offset)

    def release(self) -> None:
        """Stop the heartbeats and give the relay up (quietly if it is gone already)."""
        self.stop_heartbeat()
        # A relay that does not answer lets go after its watchdog anyway.
        with contextlib.suppress(NetworkError):
            self.request("release", timeout=min(self.timeout, 1.0))

    def command(self, op: str, **fields: Any) -> dict[str, Any]:
        """Any other command (pause, resume, seek, stop, probe, release): its reply's fields."""
        return dict(self.request(op, **fields).fields)

    # ------------------------------------------------------------------ heartbeat

    def start_heartbeat(
        self,
        *,
        period: float = 0.1,
        watchdog: float = 0.5,
        on_status: Callable[[dict[str, Any]], None] | None = None,
        on_lost: Callable[[float], None] | None = None,
    ) -> None:
        """Send a heartbeat every ``period``; call ``on_lost(silence)`` once after
        ``watchdog`` seconds without an answer (and send no more), ``on_status`` with each
        answer's show status."""
        import zenoh

        if self._beat is not None:
            return
        self.link.last_reply = time.monotonic()
        self._beat_stop.clear()

        def lost(silence: float) -> None:
            self.link.lost = True
            # Silent from now on: a relay that was only starved or frozen, and reads the
            # heartbeats it missed once it runs again, must still apply its link-loss policy,
            # as this side has given it up (its watchdog judges silence after a grace).
            self._beat_stop.set()
            if on_lost is not None:
                on_lost(silence)

        dog = Watchdog(watchdog, lost, name=f"relay {self.relay}")

        def on_reply(sent: float) -> Callable[[zenoh.Reply], None]:
            def handle(answer: zenoh.Reply) -> None:
                ok = answer.ok
                if ok is None or self._beat_stop.is_set():
                    return  # an answer still in flight when the heartbeats stopped: not heard
                try:
                    reply = msg.decode_reply(ok.payload.to_bytes())
                except msg.MessageError:
                    return
                if not reply.ok or self.link.lost:
                    return  # a relay once lost stays lost for this show
                dog.heard()
                self._learn(sent, time.monotonic(), reply.relay_time)
                status = reply.fields.get("show")
                if isinstance(status, dict):
                    self.link.status = status
                    if on_status is not None:
                        on_status(status)

            return handle

        def beat() -> None:
            next_at = time.monotonic()
            while not self._beat_stop.is_set():
                _, payload = self._next("heartbeat", {})
                try:
                    self.session.get(
                        self.key,
                        on_reply(time.monotonic()),
                        payload=payload,
                        timeout=watchdog,
                        congestion_control=zenoh.CongestionControl.BLOCK,
                    )
                except zenoh.ZError:
                    break  # the session is closing
                next_at += period
                self._beat_stop.wait(max(0.0, next_at - time.monotonic()))
            dog.stop()

        dog.start()
        self._beat = threading.Thread(
            target=beat, name=f"xgo-show heartbeat {self.relay}", daemon=True
        )
        self._beat.start()

    def stop_heartbeat(self) -> None:
        """Stop sending heartbeats (the relay's watchdog then applies its policy)."""
        self._beat_stop.set()
        if self._beat is not None:
            self._beat.join(1.0)
            self._beat = None


def list_relays(
    session: zenoh.Session, namespace: str = "xgo-show", *, timeout: float = 1.0
) -> list[dict[str, Any]]:
    """The descriptions of every live relay in ``namespace``, sorted by name.

    A relay that holds a liveliness token but does not answer in ``timeout`` (frozen, or
    overloaded) is listed with ``"state": "not answering"``.
    """
    alive = set()
    for answer in session.liveliness().get(relay_wildcard(namespace, "alive"), timeout=timeout):
        if answer.ok is not None:
            parts = str(answer.ok.key_expr).split("/")
            if len(parts) >= 2:
                alive.add(parts[-2])
    found: dict[str, dict[str, Any]] = {}
    for answer in session.get(relay_wildcard(namespace, "info"), timeout=timeout):
        if answer.ok is None:
            continue
        try:
            description = json.loads(answer.ok.payload.to_bytes())
        except ValueError:
            continue
        if isinstance(description, dict) and isinstance(description.get("relay"), str):
            found[description["relay"]] = description
    for name in alive - set(found):
        found[name] = {"relay": name, "state": "not answering", "robots": [], "holder": None}
    return [found[name] for name in sorted(found)]
