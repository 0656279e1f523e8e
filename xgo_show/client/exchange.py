"""One request/response exchange over a transport, shared by the XGO and xArm clients.

Sends are paced: after each frame the link gets its wire time plus the profile's silence gap
before the next one goes out (``write`` returns when bytes are queued, so quick writes would
otherwise run together on the wire). A request drains and resets the decoder first (bytes that
arrived before it cannot answer it), then waits for the frame the caller's ``match`` accepts,
skipping every other frame. When none comes the error says why, in one line:
a near miss named by ``match`` -> :class:`ProtocolError`; only junk -> :class:`ProtocolError`;
silence -> :class:`TransportTimeout`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

from xgo_show.errors import ProtocolError, TransportTimeout
from xgo_show.profiles import Link
from xgo_show.transports.base import Transport

__all__ = ["Decoder", "Exchange", "Match"]

F = TypeVar("F")

#: ``match(frame)``: True = the reply, False = not for us (skip), str = a near miss, described
#: (e.g. "has 3 data bytes, expected 10"); kept for the error if nothing better arrives.
Match = Callable[[F], "bool | str"]

# At most this many reads of already-buffered bytes before a request (a Rider streams
# feedback continuously, so "until empty" needs a bound).
_MAX_DRAIN_READS = 64


class Decoder(Protocol[F]):
    """A streaming frame decoder (:class:`~xgo_show.wire.xgo.XgoDecoder`, ``XarmDecoder``)."""

    discarded: int

    @property
    def pending(self) -> int: ...

    def feed(self, chunk: bytes | bytearray) -> list[F]: ...

    def reset(self) -> None: ...


class Exchange(Generic[F]):
    """Paced sends and matched replies on one transport; ``protocol`` names it in errors."""

    def __init__(
        self,
        transport: Transport,
        decoder: Decoder[F],
        link: Link,
        *,
        protocol: str,
        timeout: float,
        clock: Callable[[], float],
        sleep: Callable[[float], None],
    ) -> None:
        self.transport = transport
        self.decoder = decoder
        self.link = link
        self.protocol = protocol
        self.timeout = timeout
        self._clock = clock
        self._sleep = sleep
        self._line_free_at = float("-inf")  # end of the last frame's wire time plus the gap

    def send(self, frame: bytes) -> None:
        """Write ``frame`` once the link has been silent for the gap after the previous one."""
        wait = self._line_free_at - self._clock()
        if wait > 0:
            self._sleep(wait)
        self.transport.write(frame)
        self._line_free_at = self._clock() + self.link.wire_time(len(frame)) + self.link.gap

    def request(
        self, frame: bytes, match: Match[F], *, label: str, timeout: float | None = None
    ) -> F:
        """Send ``frame`` and return the first reply ``match`` accepts.

        ``label`` names the request in errors ("a read of firmware (0x07)").
        """
        wait = self.timeout if timeout is None else timeout
        self._drain()
        self.send(frame)
        deadline = self._clock() + wait
        near_miss: str | None = None
        while True:
            left = deadline - self._clock()
            if left <= 0:
                break
            for candidate in self.decoder.feed(self.transport.read(4096, timeout=left)):
                verdict = match(candidate)
                if verdict is True:
                    return candidate
                if isinstance(verdict, str):
                    near_miss = verdict
        where = f"{self.transport.url} to {label}"
        if near_miss is not None:
            raise ProtocolError(f"reply from {where} {near_miss}")
        garbage = self.decoder.discarded + self.decoder.pending
        if garbage:
            raise ProtocolError(
                f"garbage from {where}: {garbage} bytes that are no {self.protocol} frame "
                f"(wrong baud rate, or not an {self.protocol} robot?)"
            )
        raise TransportTimeout(f"no reply from {where} within {wait:g} s")

    def _drain(self) -> None:
        for _ in range(_MAX_DRAIN_READS):
            if not self.transport.read(4096, timeout=0):
                break
        self.decoder.reset()
        self.decoder.discarded = 0
