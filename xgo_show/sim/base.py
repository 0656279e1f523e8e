"""The interface every simulated robot implements.

A simulated robot is pure state driven by an injected time: bytes in with ``receive``, bytes
out with ``poll``. It knows nothing of threads, ports or clocks, so the same object serves an
in-process ``sim:`` transport, a real pseudo-terminal (:mod:`xgo_show.sim.pty_server`) and tests
with a fake clock.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from xgo_show.errors import FrameRejected
from xgo_show.wire.stream import StreamDecoder

__all__ = ["FrameRobot", "ReceivedFrame", "Rejected", "SimulatedRobot"]


@dataclass(frozen=True)
class ReceivedFrame:
    """One complete frame the robot received, with the monotonic time it arrived.

    ``accepted`` is False (with ``reason``) for a well-formed frame the robot refused, e.g. a
    write to a read-only register or an address outside its table.
    """

    t: float
    data: bytes
    accepted: bool = True
    reason: str = ""


class SimulatedRobot(abc.ABC):
    """A robot model that speaks the real byte protocol."""

    model: str

    @abc.abstractmethod
    def receive(self, data: bytes, now: float) -> None:
        """Bytes from the host arrived at monotonic time ``now`` (any chunking)."""

    @abc.abstractmethod
    def poll(self, now: float) -> bytes:
        """Advance time-driven state to ``now`` and return bytes the robot sends."""

    @property
    @abc.abstractmethod
    def received(self) -> list[ReceivedFrame]:
        """Every complete frame received so far, in order."""

    @property
    @abc.abstractmethod
    def discarded_bytes(self) -> int:
        """Bytes of line noise and corrupt frames thrown away."""

    @abc.abstractmethod
    def snapshot(self) -> dict[str, Any]:
        """A JSON-able summary of the robot's state (registers by name, actions run, …)."""


Rejected = FrameRejected  # the simulators' short name for it


class _Encodable(Protocol):
    def encode(self) -> bytes: ...


F = TypeVar("F", bound=_Encodable)


class FrameRobot(SimulatedRobot, Generic[F]):
    """A simulated robot that decodes frames with ``decoder`` and handles them one by one.

    Subclasses implement ``_elapse(now, dt)`` (time-driven state) and ``_handle(frame, now)``,
    which raises :class:`Rejected` for a frame the robot refuses; replies go to ``_outbox``.
    ``_emit(now)`` may add unsolicited bytes (e.g. automatic feedback) when polled.
    ``_t`` is the last time seen (None before the first ``receive``/``poll``).
    """

    def __init__(self, decoder: StreamDecoder[F]) -> None:
        self._decoder = decoder
        self._received: list[ReceivedFrame] = []
        self._outbox = bytearray()
        self._t: float | None = None

    @abc.abstractmethod
    def _elapse(self, now: float, dt: float) -> None:
        """Bring time-driven state (moves, actions, battery) forward by ``dt`` > 0 s to ``now``."""

    def _advance(self, now: float) -> None:
        # The first call only starts the clock; time never runs backwards here, so a late
        # timestamp changes nothing.
        if self._t is None:
            self._t = now
            return
        dt = now - self._t
        if dt <= 0:
            return
        self._elapse(now, dt)
        self._t = now

    @abc.abstractmethod
    def _handle(self, frame: F, now: float) -> None:
        """Act on one frame received at ``now``; raise :class:`Rejected` to refuse it."""

    def _emit(self, now: float) -> None:
        """Queue unsolicited bytes due by ``now`` (none by default)."""

    def receive(self, data: bytes, now: float) -> None:
        """Decode ``data`` and act on every complete frame at time ``now``."""
        self._advance(now)
        for frame in self._decoder.feed(data):
            try:
                self._handle(frame, now)
            except Rejected as exc:
                self._received.append(ReceivedFrame(now, frame.encode(), False, str(exc)))
            else:
                self._received.append(ReceivedFrame(now, frame.encode()))

    def poll(self, now: float) -> bytes:
        """Advance to ``now``; return pending replies and anything else due."""
        self._advance(now)
        self._emit(now)
        out = bytes(self._outbox)
        self._outbox.clear()
        return out

    @property
    def received(self) -> list[ReceivedFrame]:
        return self._received

    @property
    def discarded_bytes(self) -> int:
        return self._decoder.discarded
