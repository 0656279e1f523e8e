"""Running a behaviour in real time on robots over their ports (serial devices or simulators).

:class:`PortStage` is the :class:`~xgo_show.behave.engine.Stage` over open transports: one
seat per performer, and on each seat at most one
:class:`~xgo_show.runtime.executor.PerformerExecutor` at a time, so there is never a second
writer on a port. Between routines a seat runs a watcher (an executor with no frames) that
polls telemetry; a routine's executor polls it while it plays. A routine pre-empted by another
is paused first (the executor rests the robot: speeds to neutral), then ended, then the next
one starts.

:class:`BehaviourRunner` owns the engine in one thread: every input (triggers, runtime events
from the bus, routine ends) goes through one queue, so the engine is never entered twice.
"""

from __future__ import annotations

import datetime as dt
import queue
import threading
from collections.abc import Callable, Mapping
from dataclasses import replace

from xgo_show.behave.engine import BehaviourNote, Engine
from xgo_show.behave.loader import Behaviour
from xgo_show.compiler.schedule import PerformerSchedule
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import Clock, MonotonicClock
from xgo_show.runtime.events import (
    Event,
    EventBus,
    FaultRaised,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, PerformerExecutor
from xgo_show.runtime.show_runner import default_reach
from xgo_show.runtime.telemetry import TelemetryPoller
from xgo_show.transports.base import Transport

__all__ = ["BehaviourRunner", "PortStage"]

_WATCH_FOREVER = 1e9  # seconds of show time a watcher lingers (until it is ended)
_HANDOVER_TIMEOUT = 0.5  # seconds allowed for a pre-empted routine to rest the robot


class _Seat:
    """One performer's port and the executor writing on it now."""

    def __init__(
        self, name: str, model: str, transport: Transport, stage: PortStage
    ) -> None:
        self.name = name
        self.profile = get_profile(model)
        self.transport = transport
        self.stage = stage
        self.executor: PerformerExecutor | None = None
        self.play_id = 0
        self.routine: str | None = None
        link = next(iter(stage.behaviour.routines.values())).performers[0].link
        for schedule in stage.behaviour.routines.values():
            for part in schedule.performers:
                if part.name == name:
                    link = part.link
        self.idle = PerformerSchedule(name, model, link, (), 0.0)

    def _start(self, part: PerformerSchedule, *, linger: float, rest: bool) -> None:
        st = self.stage
        executor = PerformerExecutor(
            part,
            self.transport,
            clock=st.clock,
            profile=self.profile,
            telemetry=TelemetryPoller(
                self.profile, interval=st.telemetry_interval, detect_falls=False
            ),
            reach=default_reach(part, self.profile),
            linger_until=linger,
            events=st.events,
            rest_at_end=rest,
        )
        self.executor = executor
        # Now: the writer waits for the link itself, and nothing precedes the first frame.
        executor.start(st.clock.now())

    def watch(self) -> None:
        """Poll telemetry with nothing to play."""
        self.end(rest=False)
        self.routine = None
        self._start(self.idle, linger=_WATCH_FOREVER, rest=False)

    def play(self, part: PerformerSchedule, routine: str, play_id: int) -> None:
        self.end(rest=self.routine is not None)
        self.routine, self.play_id = routine, play_id
        self._start(part, linger=0.0, rest=True)

    def end(self, *, rest: bool) -> None:
        """End the executor on the port now; with ``rest``, through the rest posture first.

        Its reader is stopped before this returns: two threads reading one port steal each
        other's bytes (pyserial then reports the port as disconnected), so the next executor
        starts only once this one is gone (a reader wakes every 50 ms to see it must stop).
        """
        old = self._stop_writer(rest=rest)
        if old is not None:
            old.close()

    def _stop_writer(self, *, rest: bool) -> PerformerExecutor | None:
        """Stop the writing executor (its writer thread has ended on return); with ``rest``,
        through the rest posture first. Returns it, still reading, or None."""
        executor, self.executor = self.executor, None
        if executor is None:
            return None
        if rest and not executor.done:
            executor.pause()
            deadline = self.stage.clock.now() + _HANDOVER_TIMEOUT
            while executor.state is not ExecutorState.PAUSED and not executor.done:
                if self.stage.clock.now() > deadline:
                    break
                self.stage.clock.sleep_until(self.stage.clock.now() + 0.001)
        executor.abort()
        executor.join(1.0)
        return executor

    def safe_stop(self, reason: str) -> None:
        if self.executor is not None:
            self.executor.safe_stop(reason)
        self.watch()


class PortStage:
    """The engine's stage over open transports (see the module doc)."""

    def __init__(
        self,
        behaviour: Behaviour,
        transports: Mapping[str, Transport],
        *,
        clock: Clock,
        events: EventBus,
        telemetry_interval: float = 0.25,
    ) -> None:
        self.behaviour = behaviour
        self.clock = clock
        self.events = events
        self.telemetry_interval = telemetry_interval
        self.seats = {
            name: _Seat(name, ref.model, transports[name], self)
            for name, ref in behaviour.model.performers.items()
        }

    def start(self) -> None:
        for seat in self.seats.values():
            seat.watch()

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float) -> None:
        schedule = self.behaviour.routines[routine]
        for part in schedule.performers:
            if part.name in performers:
                self.seats[part.name].play(replace(part), routine, play_id)

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        for p in performers:
            self.seats[p].end(rest=True)
            self.seats[p].watch()

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        for p in performers:
            self.seats[p].safe_stop(reason)

    def finished(self, performer: str) -> int | None:
        """The play id whose routine just finished on ``performer`` (None: not a routine)."""
        seat = self.seats[performer]
        executor = seat.executor
        if seat.routine is None or executor is None or executor.state is not ExecutorState.FINISHED:
            return None
        seat.watch()
        return seat.play_id

    def close(self) -> None:
        for seat in self.seats.values():
            seat.end(rest=False)


class BehaviourRunner:
    """Runs a behaviour on open transports in real time (see the module doc).

    ``say(t, line)`` gets each decision for people; every
    :class:`~xgo_show.behave.engine.BehaviourNote` is also published on ``events``.
    """

    def __init__(
        self,
        behaviour: Behaviour,
        transports: Mapping[str, Transport],
        *,
        clock: Clock | None = None,
        events: EventBus | None = None,
        say: Callable[[float, str], None] | None = None,
        telemetry_interval: float = 0.25,
    ) -> None:
        self.clock: Clock = clock if clock is not None else MonotonicClock()
        self.events = events if events is not None else EventBus()
        self.say = say
        self.stage = PortStage(behaviour, transports, clock=self.clock, events=self.events,
                               telemetry_interval=telemetry_interval)
        self.engine = Engine(behaviour, self.stage, emit=self._emit, wall=self._wall)
        self._inbox: queue.SimpleQueue[tuple[str, object]] = queue.SimpleQueue()
        self._sub = self.events.subscribe(self._on_event, TelemetryRead, FaultRaised, StateChanged)
        self._stop = threading.Event()

    def _wall(self, t: float) -> dt.datetime:
        return dt.datetime.now() + dt.timedelta(seconds=t - self.clock.now())

    def _emit(self, event: Event) -> None:
        self.events.publish(event)
        if self.say is not None and isinstance(event, BehaviourNote):
            self.say(event.t, f"rule {event.rule}: {event.kind}: {event.text}")

    def _on_event(self, event: Event) -> None:
        if isinstance(event, StateChanged) and event.state is not ExecutorState.FINISHED:
            return
        self._inbox.put(("event", event))

    def trigger(self, name: str) -> None:
        """Fire a remote trigger (from any thread)."""
        self._inbox.put(("trigger", name))

    def stop(self) -> None:
        """End :meth:`run` (from any thread); the robots are safe-stopped."""
        self._stop.set()
        self._inbox.put(("stop", None))

    def run(self, duration: float | None = None) -> None:
        """Run until :meth:`stop` or for ``duration`` seconds; then safe-stop every robot."""
        clock, engine = self.clock, self.engine
        end = None if duration is None else clock.now() + duration
        self.stage.start()
        engine.start(clock.now())
        try:
            while not self._stop.is_set():
                now = clock.now()
                if end is not None and now >= end:
                    break
                deadline = engine.next_deadline()
                limits = [t for t in (deadline, end) if t is not None]
                timeout = max(0.0, min(limits) - now) if limits else 0.5
                try:
                    kind, item = self._inbox.get(timeout=min(timeout, 0.5))
                except queue.Empty:
                    engine.advance(clock.now())
                    continue
                self._handle(kind, item)
                engine.advance(clock.now())
        finally:
            self._sub.close()
            names = tuple(self.stage.seats)
            for seat in self.stage.seats.values():
                if seat.executor is not None:
                    seat.executor.safe_stop("behaviour ended")
            self.stage.close()
            del names

    def _handle(self, kind: str, item: object) -> None:
        now = self.clock.now()
        if kind == "trigger" and isinstance(item, str):
            self.engine.trigger(item, now)
        elif isinstance(item, StateChanged):
            play_id = self.stage.finished(item.performer)
            if play_id is not None:
                self.engine.routine_ended(item.performer, play_id, now, True)
        elif isinstance(item, Event):
            self.engine.on_event(item)
