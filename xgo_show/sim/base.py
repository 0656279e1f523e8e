"""The interface every simulated robot implements.

A simulated robot is pure state driven by an injected time: bytes in with ``receive``, bytes
out with ``poll``. It knows nothing of threads, ports or clocks, so the same object serves an
in-process ``sim:`` transport, a real pseudo-terminal (:mod:`xgo_show.sim.pty_server`) and tests
with a fake clock.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Any

__all__ = ["ReceivedFrame", "SimulatedRobot"]


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
