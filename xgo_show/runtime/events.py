"""Typed runtime events and the bus that carries them.

Everything the runtime does that someone may want to watch is published as a frozen event:
a frame written, a telemetry reading, a fault, a state change, a safe stop, and the show-level
moments (pre-flight done, start, pause, resume, progress tick, end). The run log, the end-of-show
report, the progress display, a relay forwarding to its conductor and a behaviour engine are all
subscribers of one :class:`EventBus`; none of them reaches into an executor.

Two ways to subscribe:

- :meth:`EventBus.subscribe` calls a listener synchronously in the publishing thread (often a
  writer thread with a deadline to keep): listeners must be quick and must not block. A
  listener that raises is isolated: the error is counted in :attr:`EventBus.listener_errors`
  and the others still run, so a broken display can never stop a robot mid-move.
- :meth:`EventBus.channel` gives a bounded queue for a consumer in its own thread, with an
  explicit overflow policy: ``"drop_oldest"`` (a ring: the latest events win, e.g. telemetry for
  a display) or ``"drop_newest"`` (the first events win). Publishing never blocks on a full
  channel; :attr:`EventChannel.dropped` says how many were lost.

Memory stays bounded for a show of any length: the bus keeps nothing, and every channel has a
fixed size.
"""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from xgo_show.compiler.schedule import ScheduledFrame
    from xgo_show.runtime.executor import ExecutorState, SafeStopResult

__all__ = [
    "Event",
    "EventBus",
    "EventChannel",
    "EventRecorder",
    "FaultRaised",
    "FrameSent",
    "Listener",
    "Overflow",
    "PreflightDone",
    "ProgressTick",
    "RunnerFailed",
    "SafeStopped",
    "ShowEnded",
    "ShowPaused",
    "ShowResumed",
    "ShowSought",
    "ShowStarted",
    "StateChanged",
    "Subscription",
    "TelemetryRead",
]


@dataclass(frozen=True, slots=True)
class Event:
    """Base of every runtime event; ``t`` is the clock time it happened (monotonic seconds)."""

    t: float


@dataclass(frozen=True, slots=True)
class FrameSent(Event):
    """One frame written to a performer's link.

    ``kind``: ``frame`` (scheduled), ``reach`` (catch-up for a mid-show start, resume or seek),
    ``read`` (telemetry request), ``rest`` or ``stop``. ``index`` is the schedule index of a
    scheduled frame. ``planned`` is when the schedule wanted it (None for frames the schedule does
    not hold); ``t`` is when the write was issued. ``planned_show``/``actual_show`` are the same
    two instants in show time. ``frame`` is the schedule's frame for scheduled frames; ``note``
    names the others (``label`` gives either, derived only when read).
    """

    performer: str
    kind: str
    index: int | None
    planned: float | None
    data: bytes
    note: str
    planned_show: float | None
    actual_show: float
    frame: ScheduledFrame | None = None

    @property
    def label(self) -> str:
        return self.frame.label if self.frame is not None else self.note

    @property
    def actual(self) -> float:
        """When the write was issued (the event time)."""
        return self.t

    @property
    def nbytes(self) -> int:
        return len(self.data)

    @property
    def error(self) -> float | None:
        """Seconds late (negative = early) against the plan."""
        return None if self.planned is None else self.t - self.planned


@dataclass(frozen=True, slots=True)
class TelemetryRead(Event):
    """A value decoded from a robot's reply (``t`` is when it was read)."""

    performer: str
    name: str
    value: float


@dataclass(frozen=True, slots=True)
class FaultRaised(Event):
    """A performer faulted (port error, fallen robot, flat battery); it stops sending."""

    performer: str
    reason: str


@dataclass(frozen=True, slots=True)
class StateChanged(Event):
    """A performer moved to a new state at show time ``show_time``."""

    performer: str
    state: ExecutorState
    show_time: float


@dataclass(frozen=True, slots=True)
class SafeStopped(Event):
    """A performer's safe stop finished (or failed: see ``result.ok``)."""

    performer: str
    result: SafeStopResult


@dataclass(frozen=True, slots=True)
class PreflightDone(Event):
    """Pre-flight finished; ``report`` is a :class:`~xgo_show.runtime.preflight.PreflightReport`."""

    report: Any
    forced: bool = False


@dataclass(frozen=True, slots=True)
class ShowStarted(Event):
    """The show was armed: show time ``offset`` happens at clock time ``start_at``."""

    show: str
    offset: float
    start_at: float
    performers: tuple[str, ...]
    on_failure: str
    battery_floor: float


@dataclass(frozen=True, slots=True)
class ShowPaused(Event):
    show_time: float


@dataclass(frozen=True, slots=True)
class ShowResumed(Event):
    show_time: float


@dataclass(frozen=True, slots=True)
class ShowSought(Event):
    """The show jumped to ``show_time`` (taking effect at clock time ``at``)."""

    show_time: float
    at: float


@dataclass(frozen=True, slots=True)
class ProgressTick(Event):
    """A periodic snapshot of the whole show (a few times a second)."""

    progress: Any  # ShowProgress (show_runner imports this module)


@dataclass(frozen=True, slots=True)
class ShowEnded(Event):
    completed: bool
    reason: str
    faults: Mapping[str, str] = field(default_factory=dict)
    states: Mapping[str, str] = field(default_factory=dict)
    stop_latency: float | None = None


@dataclass(frozen=True, slots=True)
class RunnerFailed(Event):
    """The coordinating thread broke (a bug, Ctrl-C without handlers); every robot is being
    safe-stopped and the error re-raised."""

    error: str
    type: str


Listener = Callable[[Event], None]
Overflow = Literal["drop_oldest", "drop_newest"]


class Subscription:
    """What :meth:`EventBus.subscribe` returns: call :meth:`close` (or use ``with``) to stop."""

    def __init__(self, bus: EventBus, entry: tuple[Listener, tuple[type[Event], ...]]) -> None:
        self._bus = bus
        self._entry = entry

    def close(self) -> None:
        self._bus._remove(self._entry)

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class EventBus:
    """Publishes events to listeners and bounded channels; thread-safe, keeps nothing."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        # Copy-on-write: publish() reads the tuple without a lock.
        self._entries: tuple[tuple[Listener, tuple[type[Event], ...]], ...] = ()
        self.listener_errors = 0
        self.last_listener_error: BaseException | None = None

    def subscribe(
        self, listener: Listener, *kinds: type[Event]
    ) -> Subscription:
        """Call ``listener(event)`` for every event (or only events of the ``kinds`` given)."""
        entry = (listener, tuple(kinds))
        with self._lock:
            self._entries = (*self._entries, entry)
        return Subscription(self, entry)

    def channel(
        self, maxlen: int, *kinds: type[Event], overflow: Overflow = "drop_oldest"
    ) -> EventChannel:
        """A bounded queue of events (all, or of ``kinds``) for a consumer thread."""
        ch = EventChannel(maxlen, overflow=overflow)
        ch.subscription = self.subscribe(ch.put, *kinds)
        return ch

    def publish(self, event: Event) -> None:
        """Hand ``event`` to every matching listener, in subscription order."""
        for listener, kinds in self._entries:
            if kinds and not isinstance(event, kinds):
                continue
            try:
                listener(event)
            except Exception as exc:  # a listener never breaks the publisher (a writer thread)
                self.listener_errors += 1
                self.last_listener_error = exc

    def _remove(self, entry: tuple[Listener, tuple[type[Event], ...]]) -> None:
        with self._lock:
            self._entries = tuple(e for e in self._entries if e is not entry)


class EventChannel:
    """A bounded FIFO of events with an explicit overflow policy (see the module doc)."""

    def __init__(self, maxlen: int, *, overflow: Overflow = "drop_oldest") -> None:
        if maxlen < 1:
            raise ValueError("a channel holds at least one event")
        if overflow not in ("drop_oldest", "drop_newest"):
            raise ValueError(f"unknown overflow policy {overflow!r}")
        self.maxlen = maxlen
        self.overflow = overflow
        self.dropped = 0
        self.subscription: Subscription | None = None
        self._items: collections.deque[Event] = collections.deque()
        self._cond = threading.Condition()

    def put(self, event: Event) -> None:
        with self._cond:
            if len(self._items) >= self.maxlen:
                self.dropped += 1
                if self.overflow == "drop_newest":
                    return
                self._items.popleft()
            self._items.append(event)
            self._cond.notify()

    def get(self, timeout: float | None = None) -> Event | None:
        """The oldest event, waiting up to ``timeout`` seconds; None if none came."""
        with self._cond:
            if not self._items and not self._cond.wait_for(lambda: bool(self._items), timeout):
                return None
            return self._items.popleft()

    def drain(self) -> list[Event]:
        """Every event queued now, oldest first (does not wait)."""
        with self._cond:
            items = list(self._items)
            self._items.clear()
            return items

    def __len__(self) -> int:
        return len(self._items)

    def __iter__(self) -> Iterator[Event]:
        return iter(self.drain())

    def close(self) -> None:
        """Stop receiving events."""
        if self.subscription is not None:
            self.subscription.close()
            self.subscription = None


class EventRecorder:
    """Keeps every event published on a bus (all, or of ``kinds``), in order.

    Grows with the show: for tests and short scripts, not for a long show (use a channel).
    """

    def __init__(self, bus: EventBus, *kinds: type[Event]) -> None:
        self.events: list[Event] = []
        self._lock = threading.Lock()
        self.subscription = bus.subscribe(self._add, *kinds)

    def _add(self, event: Event) -> None:
        with self._lock:
            self.events.append(event)

    def sent(self, performer: str | None = None) -> list[FrameSent]:
        """The frames written (every kind), optionally of one performer only."""
        with self._lock:
            return [
                e
                for e in self.events
                if isinstance(e, FrameSent) and (performer is None or e.performer == performer)
            ]

    def close(self) -> None:
        self.subscription.close()
