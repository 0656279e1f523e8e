"""What a performer is to the show runner: the :class:`Performer` protocol.

A performer plays one robot's part of a show from a start time. The runner only ever talks to
performers through this protocol, so a robot on a local port (:class:`PerformerExecutor`), a
robot behind a relay on another host (a proxy that forwards these calls as timed commands) and
anything else that keeps time with the show (a music track) are interchangeable.

Times. Every ``at``/``start_at`` is a time on the clock the performer was built with (for a
local executor, this host's monotonic clock); ``None`` means "as soon as possible". Giving the
same ``at`` to every performer makes them act on the same frame. Show times (``offset``,
``show_time``) are seconds from the start of the show.

Events. A performer publishes what it does (frames sent, telemetry, faults, state changes, safe
stops) on the :class:`~xgo_show.runtime.events.EventBus` it was given; it calls nobody back.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult

__all__ = ["Performer"]


@runtime_checkable
class Performer(Protocol):
    """One robot's part of a show, started, steered and stopped by the show runner."""

    @property
    def name(self) -> str:
        """The performer's name in the show."""
        ...

    @property
    def model(self) -> str:
        """The robot model (``mini``, ``lite``, ``rider``, ``xarm``...)."""
        ...

    @property
    def state(self) -> ExecutorState:
        ...

    @property
    def done(self) -> bool:
        """Nothing more to play: finished, stopped or failed."""
        ...

    @property
    def fault(self) -> str | None:
        """Why the performer failed, once it has."""
        ...

    @property
    def progress(self) -> Progress:
        """Where the performer is now (state, show time, frames sent, current cue)."""
        ...

    @property
    def stop_result(self) -> SafeStopResult | None:
        """What the safe stop did, once one ran."""
        ...

    @property
    def readings(self) -> Mapping[str, float]:
        """The latest telemetry values (battery, attitude...); empty without telemetry."""
        ...

    def lead_time(self, offset: float) -> float:
        """Seconds needed between a start request and ``start_at`` for a start at ``offset``."""
        ...

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        """Play in the background: show time ``offset`` happens at clock time ``start_at``."""
        ...

    def pause(self, *, at: float | None = None) -> None:
        """Hold the robot at rest from clock time ``at`` (no frame planned at or after it goes)."""
        ...

    def resume(self, *, at: float | None = None) -> None:
        """Bring the robot back where the pause left it; the show goes on from clock time ``at``."""
        ...

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        """Jump to ``show_time``: it happens at clock time ``at`` (while paused: on resume)."""
        ...

    def abort(self) -> None:
        """Stop sending schedule frames now (no stop frames: see :meth:`safe_stop`)."""
        ...

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        """Drop pending frames and stop the robot now; from any thread; idempotent."""
        ...

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the part to end; return whether it has."""
        ...

    def close(self) -> None:
        """Release background threads (the port stays open: its owner closes it)."""
        ...
