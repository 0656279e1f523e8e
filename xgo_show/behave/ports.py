"""Running a behaviour in real time on robots over their ports (serial devices or simulators).

:class:`PortStage` is the :class:`~xgo_show.behave.engine.Stage` over open transports: one
seat per performer, and on each seat at most one
:class:`~xgo_show.runtime.executor.PerformerExecutor` at a time, so there is never a second
writer on a port. Between routines a seat runs a watcher (an executor with no frames) that
polls telemetry; a routine's executor polls it while it plays. The seat alone reads the port
(one reader, across executors), and the items a fall or tilt shows in are read every
:data:`WATCH_INTERVAL` seconds, the rest in rotation. A routine pre-empted by another is
ended, and the next executor's first frames rest the robot (speeds to neutral) and bring it to
its default posture before the next routine's first frame.

:class:`BehaviourRunner` owns the engine in one thread: every input (triggers, runtime events
from the bus, routine ends) goes through one queue, so the engine is never entered twice.
"""

from __future__ import annotations

import datetime as dt
import queue
import threading
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import TYPE_CHECKING

from xgo_show.behave.engine import BehaviourNote, Engine
from xgo_show.behave.loader import Behaviour
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import TransportError
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
from xgo_show.runtime.safety import rest_frames, stop_frames
from xgo_show.runtime.telemetry import TelemetryPoller
from xgo_show.transports.base import Transport

if TYPE_CHECKING:
    from xgo_show.behave.relayed import RelayAccess, RelayedStage

__all__ = ["WATCH_INTERVAL", "BehaviourRunner", "PortStage"]

_WATCH_FOREVER = 1e9  # seconds of show time a watcher lingers (until it is ended)
#: seconds between reads of the items a fall or tilt shows in, by default: each read is a
#: ~20-byte exchange (~2 ms at 115200 baud, 10% of the link), and sets the reaction time
WATCH_INTERVAL = 0.02
_WATCHED = ("status", "attitude")  # the telemetry items falls and tilts are read from


class _Seat:
    """One performer's port, its one reader, and the executor writing on it now.

    The seat reads the port itself for as long as it is open and hands the bytes to the
    latest executor (:meth:`PerformerExecutor.received`): executors come and go without a
    reader of their own, so a hand-over never waits for one to stop and there is never a
    second reader on the port. One :class:`TelemetryPoller` serves them all, so the cadence
    of reads carries on across hand-overs.
    """

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
        self.poller = TelemetryPoller(
            self.profile, interval=stage.telemetry_interval, detect_falls=False,
            watch={item: stage.watch_interval for item in _WATCHED}
            if stage.watch_interval is not None else None,
        )
        self._feed: PerformerExecutor | None = None  # the latest executor (reads go to it)
        self._pending: list[tuple[bytes, str]] = []  # frames for the next executor to send
        self.rest = [(f.data, f.label) for f in rest_frames(self.profile)]
        rest = len(self.rest)
        #: the safe stop's frames after the rest ones: back to the default posture (XGO's
        #: reset action; none for a robot whose stop only halts it)
        self.posture = [(f.data, f.label) for f in stop_frames(self.profile)[rest:]]
        self._reader: threading.Thread | None = None
        self._reader_stop = threading.Event()
        link = self.profile.link
        for schedule in stage.routines.values():
            for part in schedule.performers:
                if part.name == name:
                    link = part.link
        self.idle = PerformerSchedule(name, model, link, (), 0.0)

    def _start(
        self, part: PerformerSchedule, *, linger: float, rest: bool, at: float | None = None
    ) -> None:
        st = self.stage
        executor = PerformerExecutor(
            part,
            self.transport,
            clock=st.clock,
            profile=self.profile,
            telemetry=self.poller,
            # no reach: a seat's executor starts at its part's beginning and is never paused
            # or sought (a routine cut is ended, and the next starts through the rest posture)
            linger_until=linger,
            events=st.events,
            rest_at_end=rest,
            read_port=False,
        )
        self.executor = self._feed = executor
        if self._pending:
            executor.send(self._pending)
            self._pending = []
        if self._reader is None and self.poller.enabled:
            self._reader = threading.Thread(target=self._read_loop, daemon=True,
                                            name=f"xgo-show behave reader {self.name}")
            self._reader.start()
        # Now (or at the time a relay was given): the writer waits for the link itself, and
        # nothing precedes the first frame.
        now = st.clock.now()
        executor.start(now if at is None else max(at, now))

    def _read_loop(self) -> None:
        while not self._reader_stop.is_set() and self._read_once():
            pass

    def _read_once(self) -> bool:
        """One read of the port (up to 50 ms: the stop flag is seen that often), its bytes
        handed to the latest executor at the clock's time; False: the port failed (a fault of
        the executor's, unless the seat is closing), so stop reading."""
        try:
            chunk = self.transport.read(256, timeout=0.05)
        except (TransportError, OSError) as exc:
            if not self._reader_stop.is_set() and self._feed is not None:
                self._feed.port_failed(f"port {self.transport.url}: {exc}")
            return False
        executor = self._feed
        if chunk and executor is not None:
            executor.received(chunk, self.stage.clock.now())
        return True

    def send(self, frames: list[tuple[bytes, str]]) -> None:
        """Write frames beside whatever plays (by the executor writing now, or the next)."""
        if self.executor is not None and not self.executor.done:
            self.executor.send(frames)
        else:
            self._pending += frames

    def watch(self) -> None:
        """Poll telemetry with nothing to play."""
        self.end(rest=False)
        self.routine = None
        self._start(self.idle, linger=_WATCH_FOREVER, rest=False)

    def play(
        self, part: PerformerSchedule, routine: str, play_id: int, at: float | None = None
    ) -> None:
        preempted = self.routine is not None  # a routine still playing (an ended one watches)
        self.end(rest=preempted)
        if preempted:
            # Through the safe stop's posture: the next routine was compiled for a robot in
            # its default posture, not wherever the cut one left it.
            self._pending += self.posture
        self.routine, self.play_id = routine, play_id
        self._start(part, linger=0.0, rest=True, at=at)

    def end(self, *, rest: bool) -> None:
        """Stop the executor writing on the port (its writer thread has ended on return);
        with ``rest``, the next executor's first frames bring the robot to rest (speeds to
        neutral): one writer at a time, and a rest never cut short by the stop."""
        executor, self.executor = self.executor, None
        if executor is None:
            return
        busy = not executor.done
        executor.abort()
        executor.join(1.0)
        if rest and busy:
            self._pending += self.rest

    def close(self) -> None:
        """End the executor and stop reading the port."""
        self.end(rest=False)
        self._reader_stop.set()
        if self._reader is not None:
            self._reader.join(1.0)

    def safe_stop(self, reason: str) -> None:
        if self.executor is not None:
            self.executor.safe_stop(reason)
        self.watch()


class PortStage:
    """The engine's stage over open transports (see the module doc).

    ``routines`` and ``writes`` are the compiled schedules by name (a behaviour's, or on a
    relay those uploaded by SHA-256); ``models`` the performer of each transport's model.
    ``at`` (on ``clock``) starts a routine at a given time instead of now (a relay is given
    one); a time already past means now.
    """

    def __init__(
        self,
        routines: Mapping[str, Schedule],
        writes: Mapping[str, Schedule],
        models: Mapping[str, str],
        transports: Mapping[str, Transport],
        *,
        clock: Clock,
        events: EventBus,
        telemetry_interval: float = 0.25,
        watch_interval: float | None = WATCH_INTERVAL,
    ) -> None:
        self.routines = routines
        self.writes = writes
        self.watch_interval = watch_interval
        self.clock = clock
        self.events = events
        self.telemetry_interval = telemetry_interval
        self.seats = {
            name: _Seat(name, model, transports[name], self) for name, model in models.items()
        }

    def start(self) -> None:
        for seat in self.seats.values():
            seat.watch()

    def play(
        self, routine: str, performers: tuple[str, ...], play_id: int, t: float,
        at: float | None = None,
    ) -> None:
        schedule = self.routines[routine]
        for part in schedule.performers:
            if part.name in performers:
                self.seats[part.name].play(replace(part), routine, play_id, at)

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        for p in performers:
            self.seats[p].end(rest=True)
            self.seats[p].watch()

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        for p in performers:
            self.seats[p].safe_stop(reason)

    def write(self, key: str, performers: tuple[str, ...], t: float) -> None:
        for part in self.writes[key].performers:
            if part.name in performers:
                self.seats[part.name].send([(f.data, f.label) for f in part.frames])

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
            seat.close()


class _Stages:
    """The engine's one stage over the local seats and the performers behind relays."""

    def __init__(self, local: PortStage, remote: RelayedStage | None) -> None:
        self.local = local
        self.remote = remote

    def _here(self, performers: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(p for p in performers if p in self.local.seats)

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float) -> None:
        here = self._here(performers)
        if self.remote is None:
            self.local.play(routine, here, play_id, t)
            return
        # On one host: at once. On several: together, once the slowest relay has the command.
        at = None
        if self.remote.hosts(performers) + (1 if here else 0) > 1:
            at = self.local.clock.now() + self.remote.lead(performers)
        self.remote.play(routine, performers, play_id, t, at)  # in flight while ours hand over
        self.local.play(routine, here, play_id, t, at)

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        if self.remote is not None:
            self.remote.rest(performers, t)
        self.local.rest(self._here(performers), t)

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        if self.remote is not None:
            self.remote.safe_stop(performers, reason, t)
        self.local.safe_stop(self._here(performers), reason, t)

    def write(self, key: str, performers: tuple[str, ...], t: float) -> None:
        if self.remote is not None:
            self.remote.write(key, performers, t)
        self.local.write(key, self._here(performers), t)


class BehaviourRunner:
    """Runs a behaviour on open transports (and relays) in real time (see the module doc).

    ``say(t, line)`` gets each decision for people; every
    :class:`~xgo_show.behave.engine.BehaviourNote` is also published on ``events``.
    ``relays`` reaches the performers that are not in ``transports``: robots behind relays
    (:class:`~xgo_show.behave.relayed.RelayedStage`), opened when :meth:`run` starts.
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
        watch_interval: float | None = WATCH_INTERVAL,
        relays: RelayAccess | None = None,
    ) -> None:
        self.clock: Clock = clock if clock is not None else MonotonicClock()
        self.events = events if events is not None else EventBus()
        self.say = say
        models = {p: ref.model for p, ref in behaviour.model.performers.items()}
        self.stage = PortStage(behaviour.routines, behaviour.writes,
                               {p: m for p, m in models.items() if p in transports},
                               transports, clock=self.clock, events=self.events,
                               telemetry_interval=telemetry_interval,
                               watch_interval=watch_interval)
        self.remote: RelayedStage | None = None
        if relays is not None and relays.urls:
            from xgo_show.behave.relayed import RelayedStage

            self.remote = RelayedStage(
                behaviour, relays.urls, session=relays.session, conductor=relays.conductor,
                namespace=relays.namespace, clock=self.clock, events=self.events,
                on_ended=lambda perf, play: self._inbox.put(("ended", (perf, play))),
                on_lost=lambda perfs, why: self._inbox.put(("lost", (perfs, why))),
                watchdog=relays.watchdog, watch_interval=watch_interval,
                telemetry_interval=telemetry_interval, timeout=relays.timeout,
            )
        self.engine = Engine(behaviour, _Stages(self.stage, self.remote), emit=self._emit,
                             wall=self._wall)
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
        try:
            if self.remote is not None:
                self.remote.open()
            self.stage.start()
            end = None if duration is None else clock.now() + duration
            engine.start(clock.now())
            while not self._stop.is_set():
                now = clock.now()
                if end is not None and now >= end:
                    break
                # Until the engine's next deadline or the end, and at most half a second: a
                # clock the caller gave may jump without waking the runner.
                limits = (engine.next_deadline(), end)
                wait = min([0.5] + [t - now for t in limits if t is not None])
                try:
                    kind, item = self._inbox.get(timeout=max(0.0, wait))
                except queue.Empty:
                    engine.advance(clock.now())
                    continue
                self._handle(kind, item)
                engine.advance(clock.now())
        finally:
            self._sub.close()
            for seat in self.stage.seats.values():
                if seat.executor is not None:
                    seat.executor.safe_stop("behaviour ended")
            self.stage.close()
            if self.remote is not None:
                self.remote.close("behaviour ended")

    def _handle(self, kind: str, item: object) -> None:
        now = self.clock.now()
        if kind == "trigger" and isinstance(item, str):
            self.engine.trigger(item, now)
        elif kind == "ended" and isinstance(item, tuple):
            self.engine.routine_ended(item[0], item[1], now, True)
        elif kind == "lost" and isinstance(item, tuple):
            for performer in item[0]:
                self.engine.lost(performer, item[1], now)
        elif isinstance(item, StateChanged):
            if item.performer not in self.stage.seats:
                return
            play_id = self.stage.finished(item.performer)
            if play_id is not None:
                self.engine.routine_ended(item.performer, play_id, now, True)
        elif isinstance(item, Event):
            self.engine.on_event(item)
