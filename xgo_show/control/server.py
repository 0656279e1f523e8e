"""``xgo-show serve``: take show-control commands and triggers from any Zenoh client.

The server owns the robots it was given (``--map NAME=PORT``, simulators with ``--sim``, robots
behind an ``xgo-show relay`` with ``--map NAME=zenoh:RELAY/ROBOT``, reached through the
server's own session) and
answers the API of docs/zenoh-api.md: queryables ``NS/control/COMMAND`` and ``NS/status``,
triggers on ``NS/trigger/NAME`` (put or get), events on ``NS/event/...``. A show runs through
the runtime's launch stages (open, pre-flight, arm, run) with a
:class:`~xgo_show.control.director.Director` holding it at its waits; nothing of the
orchestration is copied here.

Threads. Zenoh calls the handlers on its own threads: status, triggers and ``panic`` are
answered there at once (each takes a lock for microseconds, or sends stop frames); the other
commands queue for one control thread (bounded: a full queue is answered "busy"), so a long
compile never delays a panic or a trigger. A show runs in a thread of its own.

Triggers. Each trigger the loaded show's sections wait for has a subscriber of its own
(``NS/trigger/NAME``, declared at load) whose handler runs on Zenoh's receiving thread itself
(no hand-over to another thread), raised to real-time priority while a show plays (where
permitted: :func:`~xgo_show.runtime.realtime.raise_thread`, under the guard that lowers a
thread using more than half a CPU); it is decided there (the director releases the wait: a
flag per robot) and only then told about (events), so nothing stands between the trigger and
the first frame. Puts for any other name reach one wildcard subscriber whose samples wait in
a bounded ring (:data:`UNKNOWN_RING`) that a normal-priority thread drains every
:data:`DRAIN_PERIOD`: a flood of triggers nobody waits for wakes no Python thread per message
and never runs at real-time priority. They are counted and told in a ``warning`` event at most
once a second. A trigger *query* is answered on the receiving thread: one for an unknown name
gets an error reply (at most :data:`UNKNOWN_REPLIES` a second), before its payload is parsed
or any lock is taken. ``log``: the trigger's times (received, decided, the writer's release,
the section's first frame written) go to the run log as ``trigger`` records, beside the
show's own.
"""

from __future__ import annotations

import collections
import contextlib
import itertools
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from xgo_show.choreo.sections import trigger_names
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.director import ControlError, Director
from xgo_show.control.keys import control_key, status_key, trigger_key
from xgo_show.control.protocol import (
    PROTOCOL_VERSION,
    LoadRequest,
    SeekRequest,
    StartRequest,
    StopRequest,
    TriggerRequest,
    error_payload,
    ok_payload,
    parse_request,
)
from xgo_show.control.publisher import EventPublisher
from xgo_show.control.status import place, robots_status, show_summary, wall_time
from xgo_show.errors import XgoShowError
from xgo_show.relay.options import ConductorOptions, use_relays
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.events import Event, EventBus, FrameSent, StateChanged
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.launch import Launch
from xgo_show.runtime.preflight import PreflightError
from xgo_show.runtime.realtime import HELPER_PRIORITY, lower_thread, raise_thread, threads_named
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.show_runner import ShowResult, ShowRunner
from xgo_show.sim.bench import SimBench

if TYPE_CHECKING:
    import zenoh

    from xgo_show.timecode.osc import Command, OscServer

__all__ = ["DRAIN_PERIOD", "UNKNOWN_REPLIES", "UNKNOWN_RING", "ServeOptions", "ShowServer"]

#: Name prefix of Zenoh's receiving threads (its Rust runtime's ``rx-0``, ``rx-1``, ...).
ZENOH_RX = "rx-"
_QUEUE = 64  # control commands waiting for the control thread
_COUNTERS = ("triggers", "accepted", "refused", "unknown", "malformed", "busy", "cancelled")
#: Error replies a second, at most, to queries for triggers nobody waits for (the rest are
#: dropped unanswered, counted): a flood of queries is not answered by a flood of replies.
UNKNOWN_REPLIES = 100
#: Seconds between drains of the puts for triggers nobody waits for (counted in batches).
DRAIN_PERIOD = 0.05
#: Puts for unknown triggers kept between drains: more in one period are dropped uncounted
#: (counted exactly up to UNKNOWN_RING / DRAIN_PERIOD = 80,000 a second).
UNKNOWN_RING = 4096
_EMPTY = (b"", b"{}", b'{"v":1}', b'{"v": 1}')  # trigger payloads with nothing to parse
_NO_PAYLOAD = TriggerRequest.model_validate({})
_OSC_TRIGGER = TriggerRequest.model_validate({"source": "osc"})


class _Tally:
    """A counter any thread bumps without a lock: ``next()`` on an :func:`itertools.count`
    is one step under the GIL. Reading takes a value from it too, so reads are counted and
    taken off (:meth:`value`: under the caller's lock, one reader at a time)."""

    def __init__(self) -> None:
        self._bumps = itertools.count()
        self._reads = 0

    def bump(self) -> None:
        next(self._bumps)

    def add(self, n: int) -> None:
        """``n`` bumps at once (in C: a zero-length deque consumes them)."""
        collections.deque(itertools.islice(self._bumps, n), maxlen=0)

    def value(self) -> int:
        n = next(self._bumps) - self._reads
        self._reads += 1
        return n


@dataclass
class _Trace:
    """One trigger that released a held wait, timed (clock seconds) for the run log."""

    trigger: str
    section: str
    received: float  # the Zenoh callback began
    parsed: float  # the payload was read
    decided: float  # the director released the wait (every robot's resume asked)
    woke: float | None = None  # the first writer took the release (catch-up frames begin)
    released: float | None = None  # ... and plays the section
    first_write: float | None = None  # its first write after the release (catch-up or frame)
    first_frame: float | None = None  # the section's first scheduled frame written


@dataclass(frozen=True)
class ServeOptions:
    """What ``serve`` owns and how it runs shows."""

    namespace: str = "xgo-show"
    maps: dict[str, str] = field(default_factory=dict)  # performer -> port or URL
    #: how to reach relays (performers mapped to ``zenoh:RELAY/ROBOT``) and their link-loss
    #: policy; the server's own session carries them
    conductor: ConductorOptions = field(default_factory=ConductorOptions)
    sim: bool = False  # performers not mapped get a simulated robot on a pty
    telemetry: bool = True
    arm_margin: float = 0.1
    allow_unsafe: bool = False
    log: Path | None = None  # run log (JSON lines) of every show played, and triggers' times
    #: ``osc:[HOST:]PORT``: also take the sound desk's OSC cues (``/go``, ``/stop``,
    #: ``/pause``, ``/resume``, ``/seek``, ``/bar``, ``/trigger NAME``)
    follow: str | None = None


@dataclass
class _Run:
    """One show being played."""

    schedule: Schedule
    launch: Launch
    runner: ShowRunner
    director: Director
    sims: SimBench | None
    thread: threading.Thread | None = None
    result: ShowResult | None = None
    faults: dict[str, str] = field(default_factory=dict)
    start_at: float | None = None  # clock time of a start given a time (``at``, ``in``)


class ShowServer:
    """Serves the control API on ``session`` (see the module docstring); :meth:`close` ends it
    (a show still running is safe-stopped first). ``load``: a show to load before the first
    query is answered (a bad one raises, and nothing is served)."""

    def __init__(
        self,
        session: zenoh.Session,
        opts: ServeOptions,
        *,
        say: Callable[[str], None] = print,
        load: LoadRequest | None = None,
    ) -> None:
        import zenoh

        self._zenoh = zenoh
        self.session = session
        self.opts = opts
        self.ns = opts.namespace
        self.say = say
        self.clock = MonotonicClock()
        self._lock = threading.RLock()
        self._loaded: tuple[Schedule, str] | None = None
        self._run: _Run | None = None
        self._last: dict[str, Any] | None = None
        self._queue: collections.deque[tuple[str, Any, Any]] = collections.deque()
        self._cond = threading.Condition()
        self._closed = False
        self._closing = False  # close() began: a start armed from now on is given up
        self._panics = 0  # panics so far: a start armed across one is cancelled
        #: what came in and what became of it (status replies carry them)
        self._tallies = {name: _Tally() for name in _COUNTERS}
        self._tally_lock = threading.Lock()  # readers of the tallies, one at a time
        #: the triggers the loaded show's sections wait for (replaced whole, read unlocked)
        self._waited: frozenset[str] = frozenset()
        self._unknown_window = (float("-inf"), 0)  # (start, replies sent in it)
        self._warned_at = float("-inf")  # when unknown triggers were last told of
        self._unknown_told = 0  # the unknown tally then
        self._trace: _Trace | None = None  # a release being timed (with a log)
        #: one subscriber per trigger the loaded show waits for (replaced at each load)
        self._trigger_subs: list[Any] = []
        self._stopping = threading.Event()  # the drain thread's cue to end
        self.log = RunLog(opts.log) if opts.log is not None else None
        self.publisher = EventPublisher(self.ns, self._put, clock=self.clock)
        if load is not None:  # before answering anyone: a client never sees it unloaded
            self._cmd_load(load)
        self._worker = threading.Thread(target=self._work, name="xgo-show control", daemon=True)
        self._worker.start()
        direct = zenoh.handlers.Callback  # indirect=False: on Zenoh's receiving thread
        self._unknown_puts = session.declare_subscriber(
            trigger_key(self.ns), zenoh.handlers.RingChannel(UNKNOWN_RING))
        self._decls: list[Any] = [
            session.declare_queryable(control_key(self.ns), self._on_control),
            session.declare_queryable(status_key(self.ns), self._on_status),
            session.declare_queryable(trigger_key(self.ns),
                                      direct(self._on_trigger_query, indirect=False)),
            self._unknown_puts,
        ]
        self._drainer = threading.Thread(target=self._drain, name="xgo-show unknown triggers",
                                         daemon=True)
        self._drainer.start()
        self.osc: OscServer | None = None
        if opts.follow is not None:
            from xgo_show.timecode.osc import OscServer, parse_spec

            self.osc = OscServer(self._on_osc, *parse_spec(opts.follow))

    # ------------------------------------------------------------------ Zenoh handlers

    def _on_control(self, query: Any) -> None:
        command = str(query.key_expr).rsplit("/", 1)[-1]
        try:
            request = parse_request(command, _payload(query))
        except ControlError as exc:
            self._reply_err(query, command, exc.code, str(exc))
            return
        if command == "panic":
            self._reply(query, command, self._panic("panic"))
            return
        with self._cond:
            if len(self._queue) >= _QUEUE:
                self._count("busy")
                self._reply_err(query, command, "busy",
                                f"{_QUEUE} commands are already waiting; try again")
                return
            self._queue.append((command, request, query))
            self._cond.notify()

    def _on_status(self, query: Any) -> None:
        self._reply(query, "status", self.status())

    def _on_trigger_put(self, sample: Any) -> None:
        """A put on ``NS/trigger/NAME`` for a trigger the loaded show waits for (its own
        subscriber, on Zenoh's receiving thread)."""
        received = self.clock.now()
        name = str(sample.key_expr).rpartition("/")[2]
        try:
            request = _trigger_request(sample.payload.to_bytes())
        except ControlError as exc:
            self._count("malformed")
            self.publisher.publish_noisy("warning", message=f"trigger {name!r} dropped: {exc}")
            return
        # A refusal is said in the trigger event (rate-limited): a put has no one to answer.
        with contextlib.suppress(ControlError):
            self._trigger(name, request, received)

    def _on_trigger_query(self, query: Any) -> None:
        received = self.clock.now()
        name = str(query.key_expr).rpartition("/")[2]
        if name not in self._waited:
            message = self._unknown(name)
            if self._may_reply_unknown(received):
                self._reply_err(query, "trigger", "refused", message)
            else:
                query.drop()  # over the rate: no reply (the querier's timeout says so)
            return
        try:
            try:
                request = _trigger_request(_payload(query))
            except ControlError:
                self._count("malformed")
                raise
            fields = self._trigger(name, request, received)
        except ControlError as exc:
            self._reply_err(query, "trigger", exc.code, str(exc))
        else:
            self._reply(query, "trigger", fields)

    def _on_osc(self, command: Command | str) -> None:
        """An OSC cue (on the OSC thread): a trigger is decided here, as a Zenoh one; the
        other commands queue for the control thread like a query, their outcome said in a
        line (an OSC message has no one to answer)."""
        if isinstance(command, str):
            self.say(f"osc: {command}")
            return
        received = self.clock.now()
        if command.kind == "trigger":
            name = str(command.name)
            try:
                if name not in self._waited:
                    raise ControlError(self._unknown(name))
                self._trigger(name, _OSC_TRIGGER, received)
            except ControlError as exc:
                self.say(f"osc: {exc}")
            return
        with self._lock:
            running = self._run is not None
        request: Any
        if command.kind == "go" and running:  # as in run --follow: /go goes on
            name, request = "resume", None
        elif command.kind == "go":
            name = "start"
            request = StartRequest.model_validate({} if command.value is None
                                                  else {"time": command.value})
        elif command.kind in ("seek", "bar"):
            value = command.value
            name = "seek"
            request = SeekRequest.model_validate(
                {"time": value} if command.kind == "seek" else {"bar": int(value or 1)})
        elif command.kind == "stop":
            name, request = "stop", StopRequest.model_validate({"reason": "OSC /stop"})
        else:
            name, request = command.kind, None
        with self._cond:
            if len(self._queue) >= _QUEUE:
                self._count("busy")
                self.say(f"osc: /{command.kind} refused: {_QUEUE} commands are already waiting")
                return
            self._queue.append((name, request, None))
            self._cond.notify()

    def _drain(self) -> None:
        """Count the puts for triggers nobody waits for, a batch every :data:`DRAIN_PERIOD`
        (the wildcard subscriber also gets the waited ones: their own subscribers took them)."""
        ring = self._unknown_puts.handler
        while not self._stopping.wait(DRAIN_PERIOD):
            waited, n, last = self._waited, 0, ""
            while (sample := ring.try_recv()) is not None:
                name = str(sample.key_expr).rpartition("/")[2]
                if name not in waited:
                    n, last = n + 1, name
            if n:
                self._unknown(last, n)

    def _unknown(self, name: str, n: int = 1) -> str:
        """Refuse ``n`` triggers no section of the loaded show waits for (``name``: the
        last): counted, told in a ``warning`` event at most once a second (how many, and the
        last name). No lock, no parse. Returns the refusal's message."""
        for what in ("triggers", "refused", "unknown"):
            self._tallies[what].add(n)
        now = self.clock.now()
        if now - self._warned_at >= 1.0:  # a race may tell twice: harmless
            self._warned_at = now
            with self._tally_lock:
                total = self._tallies["unknown"].value()
            n, self._unknown_told = total - self._unknown_told, total
            self.publisher.publish(  # once a second at most: not one of the noisy events
                "warning", unknown=n, trigger=name,
                message=f"{n} trigger(s) no section waits for refused since the last such "
                f"warning (the last: {name!r})")
        waited = self._waited
        if not waited:
            return f"trigger {name!r} refused: no show with triggers is loaded"
        return (f"trigger {name!r} refused: no section of this show waits for {name!r} "
                f"(its triggers: {', '.join(sorted(waited))})")

    def _may_reply_unknown(self, now: float) -> bool:
        """Whether a query for an unknown trigger gets its error reply (the rate's limit)."""
        start, sent = self._unknown_window
        if now - start >= 1.0:
            start, sent = now, 0
        if sent >= UNKNOWN_REPLIES:
            return False
        self._unknown_window = (start, sent + 1)
        return True

    def _reply(self, query: Any, command: str, fields: dict[str, Any]) -> None:
        if query is None:  # an OSC cue's
            self.say(f"osc: {command}: {fields.get('state', 'done')}")
            return
        try:
            query.reply(query.key_expr, ok_payload(command, **fields))
        finally:
            query.drop()

    def _reply_err(self, query: Any, command: str, code: str, message: str) -> None:
        if query is None:  # an OSC cue's
            self.say(f"osc: {command} refused ({code}): {message}")
            return
        try:
            query.reply_err(error_payload(command, code, message))
        finally:
            query.drop()

    def _put(self, key: str, payload: dict[str, Any]) -> None:
        import json

        self.session.put(
            key,
            json.dumps(payload, separators=(",", ":"), allow_nan=False).encode(),
            congestion_control=self._zenoh.CongestionControl.DROP,
        )

    # ------------------------------------------------------------------ commands

    def _work(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._closed:
                    self._cond.wait()
                if self._closed:
                    for _, _, query in self._queue:
                        self._reply_err(query, "control", "closing", "the server is closing")
                    self._queue.clear()
                    return
                command, request, query = self._queue.popleft()
            try:
                fields = getattr(self, f"_cmd_{command}")(request)
            except ControlError as exc:
                self._reply_err(query, command, exc.code, str(exc))
            except PreflightError as exc:
                self._reply_err(query, command, "refused", str(exc))
            except XgoShowError as exc:
                self._reply_err(query, command, "failed", str(exc))
            except Exception as exc:  # never let a bug kill the control thread
                self._reply_err(query, command, "internal", f"internal error: {exc!r}")
            else:
                self._reply(query, command, fields)

    def _cmd_load(self, req: LoadRequest) -> dict[str, Any]:
        with self._lock:
            if self._run is not None:
                raise ControlError("a show is running: stop it before loading another")
        schedule, source = _load(req)
        waited = frozenset(trigger_names(schedule.sections))
        with self._lock:
            self._loaded = (schedule, source)
            self._declare_triggers(waited)
            self._waited = waited
        summary = show_summary(schedule, source)
        self.say(f"loaded {schedule.name!r} ({source}); triggers: "
                 f"{', '.join(summary['triggers']) or 'none'}")
        self.publisher.publish("state", state="loaded", show=schedule.name)
        return {"show": summary, "warnings": [d.format() for d in schedule.warnings]}

    def _declare_triggers(self, names: frozenset[str]) -> None:
        """One subscriber per trigger the loaded show waits for, its handler on Zenoh's
        receiving thread (the previous show's are undeclared)."""
        for sub in self._trigger_subs:
            sub.undeclare()
        direct = self._zenoh.handlers.Callback
        self._trigger_subs = [
            self.session.declare_subscriber(trigger_key(self.ns, name),
                                            direct(self._on_trigger_put, indirect=False))
            for name in sorted(names)]

    def _cmd_start(self, req: StartRequest) -> dict[str, Any]:
        with self._lock:
            panics = self._panics
            if self._run is not None:
                raise ControlError("a show is running already (stop it first)")
            if self._loaded is None:
                raise ControlError("no show is loaded: send load first")
            schedule, source = self._loaded
        offset = _show_time(schedule, req)
        if not 0.0 <= offset < schedule.duration:
            raise ControlError(f"start at {offset:g} s: outside the show (0 to "
                               f"{schedule.duration:g} s)", code="bad_request")
        run = self._arm(schedule, force=req.force)
        now_wall, now = time.time(), self.clock.now()
        start_at: float | None = None
        if req.at is not None:
            start_at = now + (req.at - now_wall)
        elif req.in_ is not None:
            start_at = now + req.in_
        if start_at is not None and start_at < now - 0.5:
            _disarm(run)
            raise ControlError(
                f"start time is {now - start_at:.3f} s in the past", code="bad_request"
            )
        thread = threading.Thread(target=self._play, args=(run, offset, start_at),
                                  name="xgo-show show", daemon=True)
        run.thread, run.start_at = thread, start_at
        # A panic or a close now finds the run (and stops it), or came before: cancel.
        with self._lock:
            closing = self._closing
            cancelled = closing or self._panics != panics
            if not cancelled:
                self._run = run
        if cancelled:
            _disarm(run)
            self._count("cancelled")
            if closing:
                raise ControlError("start cancelled: the server is closing", code="closing")
            raise ControlError("start cancelled by a panic during its pre-flight",
                               code="cancelled")
        thread.start()
        report = run.launch.report
        when = start_at if start_at is not None else now
        self.say(f"starting {schedule.name!r} from {offset:g} s ({source})")
        return {
            "show": schedule.name,
            "offset": round(offset, 6),
            "start_time": round(now_wall + (when - now), 6),
            "preflight": report.as_record() if report is not None else None,
        }

    def _arm(self, schedule: Schedule, *, force: bool) -> _Run:
        """Open, pre-flight and arm a launch (with simulators under ``--sim``)."""
        urls = {k: v for k, v in self.opts.maps.items()
                if k in {p.name for p in schedule.performers}}
        sim_names = [p.name for p in schedule.performers if p.name not in urls] if self.opts.sim \
            else []
        missing = [p.name for p in schedule.performers
                   if p.name not in urls and p.name not in sim_names and not p.port]
        if missing:
            raise ControlError(f"no robot for performer(s) {', '.join(missing)}: start serve "
                               "with --map NAME=PORT (or --sim)")
        relayed = use_relays(urls, self.opts.conductor, fast=False, schedule=schedule,
                             simulated=sim_names)
        if relayed:  # through this server's own session, not one opened for them
            from xgo_show.relay.conductor import configure

            configure(self.opts.conductor, session=self.session)
        sims = SimBench(schedule, sim_names) if sim_names else None
        bus = EventBus()
        if self.log is not None:
            self.log.attach(bus)
            bus.subscribe(self._timed)
        bus.subscribe(self.publisher.listen(schedule))
        try:
            if sims is not None:
                urls.update(sims.urls)
            launch = Launch(schedule, urls, clock=self.clock, events=bus,
                            telemetry=self.opts.telemetry, allow_unsafe=self.opts.allow_unsafe,
                            **relayed)
            try:
                launch.open()
                report = launch.preflight()
                self.publisher.publish("state", state="preflight", **report.as_record())
                runner = launch.arm(force=force)
            except BaseException:
                launch.close()
                raise
        except BaseException:
            if sims is not None:
                sims.close()
            raise
        director = Director(runner, clock=self.clock, arm_margin=self.opts.arm_margin)
        return _Run(schedule, launch, runner, director, sims)

    def _play(self, run: _Run, offset: float, start_at: float | None) -> None:
        # Zenoh's receiving threads run the trigger handlers: above normal threads while the
        # show plays (where permitted, guarded), so a trigger is not queued behind them.
        threads = threads_named(ZENOH_RX)
        if self.osc is not None and self.osc.native_id is not None:
            threads.append(self.osc.native_id)  # OSC triggers, likewise
        raised = [tid for tid in threads if raise_thread(tid, HELPER_PRIORITY)]
        try:
            run.result = run.launch.run(offset=offset, start_at=start_at, handle_signals=False)
        except BaseException as exc:  # the runner safe-stopped every robot before raising
            run.result = ShowResult(False, f"exception: {exc!r}")
        finally:
            for tid in raised:
                lower_thread(tid)
            run.director.close()
            run.launch.close()
            if run.sims is not None:
                run.sims.close()
            result = run.result
            assert result is not None
            with self._lock:
                self._last = {"show": run.schedule.name, "completed": result.completed,
                              "reason": result.reason, "faults": dict(result.faults),
                              "time": wall_time()}
                self._run = None
            self.say(f"show {run.schedule.name!r} ended: {result.reason}")

    def _cmd_stop(self, req: StopRequest) -> dict[str, Any]:
        run = self._current("stop")
        run.director.stop(req.reason)
        return self._ended(run)

    def _cmd_pause(self, req: object) -> dict[str, Any]:
        run = self._current("pause")
        run.director.pause()
        return {"state": run.director.phase}

    def _cmd_resume(self, req: object) -> dict[str, Any]:
        run = self._current("resume")
        run.director.resume()
        return {"state": run.director.phase}

    def _cmd_seek(self, req: SeekRequest) -> dict[str, Any]:
        run = self._current("seek")
        target = _show_time(run.schedule, req)
        run.director.seek(target)
        return place(run.schedule, target)

    def _current(self, what: str) -> _Run:
        with self._lock:
            run = self._run
        if run is None:
            raise ControlError(f"cannot {what}: no show is running")
        return run

    def _ended(self, run: _Run, timeout: float = 2.0) -> dict[str, Any]:
        if run.thread is not None:
            run.thread.join(timeout)
        result = run.result
        if result is None:
            return {"state": "stopping"}
        return {"state": "ended", "reason": result.reason,
                "stops": {n: {"ok": s.ok, "error": s.error} for n, s in result.stops.items()}}

    def _panic(self, reason: str) -> dict[str, Any]:
        """Safe stop everything now: the running show, a start being armed (cancelled) and
        every command still queued (cancelled). Always accepted."""
        with self._lock:
            self._panics += 1
            run = self._run
        with self._cond:
            queued = list(self._queue)
            self._queue.clear()
        for command, _, query in queued:
            self._count("cancelled")
            self._reply_err(query, command, "cancelled", f"{command} cancelled by a panic")
        if run is not None:
            run.runner.stop(reason)
            self.publisher.publish("state", state="panic")
            return self._ended(run, timeout=1.0)
        return {"state": "idle", "note": "no show is running: nothing is moving"}

    def _trigger(self, name: str, req: TriggerRequest, received: float) -> dict[str, Any]:
        """A trigger some section waits for: decided first (the release), told after."""
        parsed = self.clock.now()
        self._count("triggers")
        run = self._run  # one read of one reference: no lock on the way to the release
        try:
            if run is None:
                reason = "no show is running"
                self.publisher.publish_noisy("trigger", trigger=name, accepted=False,
                                             reason=reason)
                raise ControlError(f"trigger {name!r} refused: {reason}")
            outcome = run.director.trigger(name)  # a refusal is published by the director
        except ControlError:
            self._count("refused")
            raise
        if self.log is not None and outcome.held:
            self._trace = _Trace(name, outcome.section, received, parsed, self.clock.now())
        self._count("accepted")
        self.publisher.publish("trigger", trigger=name, accepted=True, section=outcome.section,
                               held=outcome.held, source=req.source, data=req.data)
        return {"trigger": name, "section": outcome.section, "held": outcome.held}

    def _timed(self, event: Event) -> None:
        """Bus listener (with a log): the writer's side of the release being timed."""
        trace = self._trace
        if trace is None:
            return
        if isinstance(event, StateChanged):
            if event.state is ExecutorState.REACHING and trace.woke is None:
                trace.woke = event.t
            elif event.state is ExecutorState.RUNNING and trace.released is None:
                trace.released = event.t
                if trace.woke is None:
                    trace.woke = event.t
        elif isinstance(event, FrameSent) and event.kind in ("frame", "reach"):
            if trace.first_write is None:
                trace.first_write = event.t
            if event.kind == "frame":
                trace.first_frame = event.t
                self._trace = None
                assert self.log is not None
                times: dict[str, Any] = {k: round(v, 6) if isinstance(v, float) else v
                                         for k, v in vars(trace).items()}
                self.log.write("trigger", **times)

    def _count(self, what: str) -> None:
        self._tallies[what].bump()

    @property
    def counters(self) -> dict[str, int]:
        """What came in since the server started, and what became of it."""
        with self._tally_lock:
            return {name: tally.value() for name, tally in self._tallies.items()}

    # ------------------------------------------------------------------ status

    def status(self) -> dict[str, Any]:
        """The status reply: what is loaded, the show's state and place, every robot."""
        with self._lock:
            run, loaded, last = self._run, self._loaded, self._last
        out: dict[str, Any] = {
            "state": "idle" if loaded is None else "loaded",
            "show": None if loaded is None else show_summary(*loaded),
            "last_result": last,
            "namespace": self.ns,
            "version": PROTOCOL_VERSION,
            "counters": self._counters(),
        }
        if run is not None:
            director = run.director
            progress = run.runner.snapshot()
            phase = director.phase
            if phase == "playing" and run.start_at is not None \
                    and self.clock.now() < run.start_at:
                phase = "idle"  # armed, its start time still to come
            out["state"] = "starting" if phase == "idle" else phase
            out.update(place(run.schedule, progress.show_time))
            out["duration"] = round(run.schedule.duration, 6)
            held, ahead = director.waiting_for, director.wait_ahead
            out["waiting_for"] = None if held is None or held.wait is None else {
                "section": held.name, "trigger": held.wait.trigger,
                "timeout": held.wait.timeout}
            out["next_wait"] = None if ahead is None or ahead.wait is None else {
                "section": ahead.name, "trigger": ahead.wait.trigger}
            faults = {p.performer: run.runner.performers[p.performer].fault or ""
                      for p in progress.performers if run.runner.performers[p.performer].fault}
            out["robots"] = robots_status(progress, faults)
            out["faults"] = faults
        return out

    def _counters(self) -> dict[str, int]:
        out = self.counters
        out["events_dropped"] = self.publisher.dropped
        out["events_suppressed"] = self.publisher.suppressed
        return out

    # ------------------------------------------------------------------ life

    def close(self) -> None:
        """Safe-stop a running show (a start being armed is given up), stop answering, close
        the publisher."""
        with self._lock:
            self._closing = True
            run = self._run
        if run is not None:
            run.runner.stop("serve is closing")
            if run.thread is not None:
                run.thread.join(3.0)
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._worker.join(2.0)
        self._stopping.set()
        self._drainer.join(2.0)
        if self.osc is not None:
            self.osc.close()
        for decl in [*self._decls, *self._trigger_subs]:
            decl.undeclare()
        self._decls, self._trigger_subs = [], []
        self.publisher.close()
        if self.log is not None:
            self.log.close()


def _disarm(run: _Run) -> None:
    """Give up an armed run that never started (nothing moved): close its ports."""
    run.director.close()
    run.launch.close()
    if run.sims is not None:
        run.sims.close()


def _trigger_request(payload: bytes | None) -> TriggerRequest:
    """A trigger's request: the usual empty payloads without a parse, anything else parsed
    and checked like every request."""
    if payload is None or payload in _EMPTY:
        return _NO_PAYLOAD
    request = parse_request("trigger", payload)
    assert isinstance(request, TriggerRequest)
    return request


def _payload(query: Any) -> bytes | None:
    payload = query.payload
    return None if payload is None else bytes(payload.to_bytes())


def _load(req: LoadRequest) -> tuple[Schedule, str]:
    """The schedule a load request names, compiled if it is a routine."""
    from xgo_show.compiler import compile_show
    from xgo_show.compiler.artifact import schedule_from_bytes

    if req.path is not None:
        from xgo_show.cli.run import load_schedule_file

        return load_schedule_file(Path(req.path)), req.path
    if req.schedule is not None:
        return schedule_from_bytes(req.schedule.encode(), name="<schedule>"), "<schedule>"
    assert req.routine is not None
    import tempfile

    from xgo_show.choreo import load_show

    with tempfile.TemporaryDirectory(prefix="xgo-show-load-") as tmp:
        path = Path(tmp) / "routine.yaml"
        path.write_text(req.routine, encoding="utf-8")
        try:
            return compile_show(load_show(path)), "<routine>"
        except XgoShowError as exc:
            # The client sent text, not a file: its problems are placed in "<routine>", not in
            # a temporary file it never named (gone once this returns).
            raise ControlError(str(exc).replace(str(path), "<routine>"), code="failed") from exc


def _show_time(schedule: Schedule, req: Any) -> float:
    """The show time a start or seek request names (0 when it names none)."""
    if req.section is not None:
        from xgo_show.choreo.sections import section_named

        section = section_named(schedule.sections, req.section)
        if section is None:
            names = ", ".join(s.name for s in schedule.sections) or "none"
            raise ControlError(f"no section named {req.section!r}; sections: "
                               f"{names}", code="not_found")
        return section.start
    if req.bar is not None:
        tempo = schedule.tempo()
        if tempo is None:
            raise ControlError("this show has no tempo: give time, not bar", code="bad_request")
        try:
            return tempo.position(req.bar, req.beat or 1.0)
        except ValueError as exc:
            raise ControlError(str(exc), code="bad_request") from exc
    return float(req.time or 0.0)
