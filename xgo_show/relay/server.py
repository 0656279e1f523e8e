"""The relay: owns local robots, announces itself on Zenoh, plays uploaded schedules on time.

A :class:`Relay` serves, under ``NS/relay/NAME/`` (:mod:`xgo_show.net.keys`):

- a liveliness token ``alive``;
- ``info``: its description (robots with model, firmware, battery and state; who holds it);
- ``cmd``: the commands of :mod:`xgo_show.net.messages`, answered one at a time by a worker
  thread (a slow pre-flight never delays heartbeats, which are answered at once).

One conductor at a time holds the relay (``hello``); any other is refused with the holder's
name. An upload is validated (:func:`~xgo_show.relay.validate.validate_upload`), then every
robot in it is checked (:func:`~xgo_show.runtime.preflight.preflight`). ``start`` arms the show
at a time on the relay's own clock; the show then runs in a
:class:`~xgo_show.runtime.show_runner.ShowRunner` over the relay's open ports (the same executor
as a local ``xgo-show run``), so frames never cross the network during a show.

Watchdog: a conductor that has not been heard for its ``watchdog_ms`` (500 ms by default) is
gone. A show in progress then gets the upload's link-loss policy: ``stop`` safe-stops every
robot, ``continue`` plays the uploaded show to its end. Either way the relay is released once
no show runs. Between shows nothing is sent; :meth:`Relay.close` (Ctrl-C) safe-stops.
"""

from __future__ import annotations

import contextlib
import gc
import queue
import threading
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import RelayRefused, TimeSyncError, XgoShowError
from xgo_show.net import messages as msg
from xgo_show.net.keys import check_relay_name, relay_key
from xgo_show.net.offset import Timebase
from xgo_show.net.slew import SlewingClock
from xgo_show.net.testhooks import DelayInjector, StartTracer
from xgo_show.net.timesync import TimeServer, serve_time
from xgo_show.net.watchdog import Watchdog
from xgo_show.relay.deferred import DeferredListeners
from xgo_show.relay.forward import EventCollector
from xgo_show.relay.performer import executor_lead
from xgo_show.relay.robots import OwnedRobot
from xgo_show.relay.validate import validate_upload
from xgo_show.runtime.clock import Clock, MonotonicClock
from xgo_show.runtime.events import EventBus
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.preflight import preflight
from xgo_show.runtime.realtime import policy
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.show_runner import ShowResult, ShowRunner

if TYPE_CHECKING:
    import zenoh

    from xgo_show.behave.relay_host import StageHost

__all__ = ["DEFAULT_WATCHDOG_MS", "Relay", "RelayState"]

DEFAULT_WATCHDOG_MS = 500
#: Seconds between two checks of the watchdog.


class RelayState:
    """The relay's show states (plain strings in messages)."""

    IDLE = "idle"  # no show uploaded
    LOADED = "loaded"  # a show uploaded and checked
    ARMED = "armed"  # a start time set
    RUNNING = "running"
    ENDED = "ended"  # the last show is over (see "last")



@dataclass
class _Holder:
    conductor: msg.Conductor
    watchdog: Watchdog  # hears every command and heartbeat from the holder


@dataclass
class _Show:
    schedule: Schedule
    sha256: str
    link_loss: str
    runner: ShowRunner | None = None
    thread: threading.Thread | None = None
    start_at: float | None = None
    offset: float = 0.0
    link_lost: bool = False
    battery_floor: float | None = None  # the conductor's, else the schedule's
    #: set when the runner has returned (its robots stopped or done): a stop waits for this,
    #: not for the show's thread, which still hands the show's last events on
    ran: threading.Event = field(default_factory=threading.Event)


class Relay:
    """A relay over an open Zenoh ``session`` for ``robots`` (see the module docstring).

    Keyword options: ``namespace``, ``clock`` (this host's clock; tests give a skewed one),
    ``allow_unsafe``, ``log`` (a :class:`RunLog`), ``telemetry`` (poll robots during shows),
    ``sync_delay`` (test-only: hold time-sync replies back, as a slow network would),
    ``trace`` (test-only: log each robot's first frame on this machine's clock too,
    :class:`~xgo_show.net.testhooks.StartTracer`).
    Use as a context manager, or call :meth:`start` and :meth:`close`.
    """

    def __init__(
        self,
        session: zenoh.Session,
        name: str,
        robots: Mapping[str, OwnedRobot],
        *,
        namespace: str = "xgo-show",
        clock: Clock | None = None,
        allow_unsafe: bool = False,
        log: RunLog | None = None,
        telemetry: bool = True,
        sync_delay: DelayInjector | None = None,
        trace: bool = False,
    ) -> None:
        self.session = session
        self.name = check_relay_name(name)
        self.robots = dict(robots)
        self.namespace = namespace
        #: this host's clock; the time-sync server stamps pings with it
        self.base: Clock = clock if clock is not None else MonotonicClock()
        #: the show clock: the holder's timebase once it has pushed one (every time in a
        #: command, every event time), this host's clock until then
        self.clock = SlewingClock(self.base)
        self.sync_delay = sync_delay
        self.allow_unsafe = allow_unsafe
        self.log = log if log is not None else RunLog(None, keep=False)
        #: every show's runtime events (frames, faults, safe stops), published by the writers
        self.events = EventBus()
        # The run log and the collector (events sent back in heartbeat answers) listen on a
        # bus of their own, fed a few ms late by a thread of ours: not in the writer threads
        # right after a write, when the robot's end needs the CPU (relay/deferred.py).
        self._booked = EventBus()
        self._bookkeeping = DeferredListeners(self.events, [self._booked.publish])
        self._log_sub = self.log.attach(self._booked)
        self._collector = EventCollector(self._booked)
        self._tracer = StartTracer(self.events, self.clock, self.log.event) if trace else None
        self.telemetry = telemetry
        self.instance = uuid.uuid4().hex[:12]  # tells a restarted relay from the old one
        self._lock = threading.RLock()
        self._holder: _Holder | None = None
        self._show: _Show | None = None
        self._last: dict[str, Any] | None = None
        self._work: queue.Queue[zenoh.Query | None] = queue.Queue()
        self._closed = threading.Event()
        self._threads: list[threading.Thread] = []
        self._declared: list[Any] = []
        self._time: TimeServer | None = None
        #: a remote behaviour's stage (``stage_*`` commands), while its conductor holds us
        self._stage: StageHost | None = None

    # ------------------------------------------------------------------ life cycle

    def start(self) -> Relay:
        """Declare the queryables and the liveliness token; start the worker and watchdog."""
        s = self.session
        ns, name = self.namespace, self.name
        self._time = serve_time(
            s,
            relay_key(ns, name, "time"),
            self.base,
            on_timebase=self._on_timebase,
            delay=self.sync_delay,
            hold_off=self.clock.hold_off,
        )
        self._declared = [
            s.declare_queryable(relay_key(ns, name, "cmd"), self._on_command),
            s.declare_queryable(relay_key(ns, name, "info"), self._on_info),
            s.liveliness().declare_token(relay_key(ns, name, "alive")),
        ]
        th = threading.Thread(target=self._serve, name="xgo-show relay commands", daemon=True)
        th.start()
        self._threads.append(th)
        self.log.event("relay_start", relay=name, robots=list(self.robots), instance=self.instance)
        return self

    def close(self, reason: str = "relay closed", *, stop_idle: bool = True) -> None:
        """Safe-stop every robot, withdraw from Zenoh, stop the threads (ports stay open).

        With ``stop_idle`` false, robots are only stopped if a show is running (a conductor
        that ends a relay it started between shows leaves its robots as the show left them).
        """
        if self._closed.is_set():
            return
        self._closed.set()
        for entity in reversed(self._declared):
            with contextlib.suppress(Exception):
                entity.undeclare()
        if self._time is not None:
            self._time.close()
        with self._lock:
            holder = self._holder
        if holder is not None:
            holder.watchdog.stop()
        self._work.put(None)
        if stop_idle or self._busy():
            self.stop_show(reason)
        for th in self._threads:
            th.join(2.0)
        self._bookkeeping.close()  # what the show's end published is logged first
        self.log.event("relay_stop", relay=self.name, reason=reason)
        self._log_sub.close()
        self._collector.close()
        if self._tracer is not None:
            self._tracer.close()

    def __enter__(self) -> Relay:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ description

    def describe(self) -> dict[str, Any]:
        """The relay's description (``info`` and the ``hello`` reply)."""
        with self._lock:
            holder = self._holder.conductor.to_json() if self._holder else None
            state = self._state()
            states = self._robot_states()
            return {
                "v": msg.PROTOCOL_VERSION,
                "relay": self.name,
                "instance": self.instance,
                "relay_time": self.clock.now(),
                "allow_unsafe": self.allow_unsafe,
                "holder": holder,
                "state": state,
                "last": self._last,
                "robots": [r.describe(states.get(n, "idle")) for n, r in self.robots.items()],
            }

    def _state(self) -> str:
        show = self._show
        if show is None:
            return RelayState.ENDED if self._last is not None else RelayState.IDLE
        if show.start_at is None:
            return RelayState.LOADED
        # Armed from the start command (which starts the show's thread) to the start time.
        return RelayState.ARMED if self.clock.now() < show.start_at else RelayState.RUNNING

    def _robot_states(self) -> dict[str, str]:
        show = self._show
        if show is None or show.runner is None:
            return {}
        return {n: p.state.value for n, p in show.runner.performers.items()}

    # ------------------------------------------------------------------ Zenoh callbacks

    def _on_info(self, query: zenoh.Query) -> None:
        self.clock.hold_off()
        # On its own key, not the query's: a listing asks NS/relay/*/info, and Zenoh keeps
        # one reply per key, so relays answering on the wildcard hid each other.
        query.reply(relay_key(self.namespace, self.name, "info"), msg.encode(self.describe()))

    def _on_command(self, query: zenoh.Query) -> None:
        # Heartbeats are answered here, at once (once no writer is due: Zenoh runs this on a
        # thread of its own, which would hold Python's lock a writer needs, see
        # SlewingClock.hold_off); everything else by the worker, in order.
        payload = query.payload
        data = b"" if payload is None else payload.to_bytes()
        if len(data) < 1024 and b'"heartbeat"' in data:
            self.clock.hold_off()
            self._reply(query, data)
            return
        self._work.put(query)

    def _serve(self) -> None:
        while True:
            query = self._work.get()
            if query is None:
                return
            payload = query.payload
            self._reply(query, b"" if payload is None else payload.to_bytes())

    def _reply(self, query: zenoh.Query, data: bytes) -> None:
        seq = -1
        try:
            request = msg.decode_request(data)
            seq = request.seq
            fields = self.handle(request)
            out: dict[str, Any] = {
                "v": msg.PROTOCOL_VERSION,
                "seq": seq,
                "ok": True,
                "error": None,
                "relay": self.name,
                "relay_time": self.clock.now(),
                **fields,
            }
        except XgoShowError as exc:
            out = msg.error_reply(self.name, self.clock.now(), seq, str(exc))
        except Exception as exc:  # a bug must not kill the relay: say it, keep serving
            out = msg.error_reply(self.name, self.clock.now(), seq, f"internal error: {exc!r}")
            self.log.event("internal_error", error=repr(exc))
        try:
            try:
                data = msg.encode(out)
            except ValueError as exc:  # a NaN or infinity in a reading: say so, never crash
                data = msg.encode(msg.error_reply(self.name, self.clock.now(), seq, str(exc)))
            query.reply(query.key_expr, data)
        finally:
            query.drop()  # type: ignore[no-untyped-call]  # the stub lacks a return type

    # ------------------------------------------------------------------ commands

    def handle(self, request: msg.Request) -> dict[str, Any]:
        """Carry out one command; return the reply's own fields (raise to refuse it)."""
        with self._lock:
            holder = self._holder
            if holder is None or holder.conductor.id != request.conductor.id:
                if request.op != "hello":
                    raise RelayRefused(self._not_holder(request))
                if holder is not None:
                    raise RelayRefused(self._held_by(holder))
                self._hold(request.conductor)
                return {"description": self.describe()}
            holder.watchdog.heard()
            op = request.op
            if op == "hello":
                return {"description": self.describe()}
            if op == "heartbeat":
                return {"show": self._show_status()}
            if op == "release":
                self._release("released by the conductor")
                return {}
        # The slow ones run outside the lock, so heartbeats keep being answered.
        if op.startswith("stage_"):
            return self._stage_command(request)
        if op in ("upload", "start") and self._stage is not None:
            raise RelayRefused(f"{op}: a behaviour's stage is open on this relay")
        if op == "upload":
            return self._upload(request)
        if op == "start":
            return self._start(request)
        if op in ("pause", "resume", "seek"):
            return self._timed(op, request)
        if op == "stop":
            return {"stops": self.stop_show(request.text("reason"))}
        if op == "probe":
            return {"rows": self._probe(request.text("performer"))}
        raise RelayRefused(f"{op}: not supported by this relay")

    def _held_by(self, holder: _Holder) -> str:
        return (
            f"relay {self.name} is held by conductor {holder.conductor.name!r} "
            f"(id {holder.conductor.id}); it serves one conductor at a time"
        )

    def _not_holder(self, request: msg.Request) -> str:
        if self._holder is None:
            return f"{request.op}: this conductor does not hold relay {self.name}; send hello first"
        return f"{request.op}: {self._held_by(self._holder)}"

    def _hold(self, conductor: msg.Conductor) -> None:
        """``conductor`` holds the relay from now (called with the lock held)."""
        dog = Watchdog(
            DEFAULT_WATCHDOG_MS / 1000,
            lambda silence: self._on_silence(conductor, silence),
            clock=self.base,
            name=f"conductor {conductor.name}",
        )
        self._holder = _Holder(conductor, dog)
        if not self._busy():
            self.clock.reset()  # the new conductor's timebase is set at once, not slewed to
        self.log.event("hello", conductor=conductor.name)
        dog.start()

    def _on_timebase(self, timebase: Timebase, conductor: str) -> float:
        """A timebase pushed by a conductor's clock tracker: only the holder's is followed."""
        with self._lock:
            holder = self._holder
            if holder is None or holder.conductor.id != conductor:
                raise TimeSyncError(
                    f"relay {self.name}: timebase from a conductor that does not hold it"
                )
            holder.watchdog.heard()
        return self.clock.follow(timebase)

    def _release(self, why: str) -> None:
        """Let the holder go (called with the lock held)."""
        holder = self._holder
        if holder is not None:
            self.log.event("release", conductor=holder.conductor.name, reason=why)
            # Not joined here: its thread may be waiting for the lock this caller holds.
            threading.Thread(
                target=holder.watchdog.stop, name="xgo-show watchdog stop", daemon=True
            ).start()
        self._holder = None
        stage, self._stage = self._stage, None
        if stage is not None:  # its robots are safe-stopped (not under our lock: it joins)
            threading.Thread(target=stage.close, args=(f"released: {why}",),
                             name="xgo-show stage close", daemon=True).start()
        if self._show is not None and self._show.thread is None:
            self._show = None  # an armed or loaded show never starts without its conductor

    def finish(self, reason: str) -> None:
        """The conductor is gone for good: play a ``continue`` show to its end, then close
        (safe-stopping what still runs)."""
        with self._lock:
            show = self._show
        if show is not None and show.link_loss == "continue" and show.thread is not None:
            self.log.event("finishing", relay=self.name, reason=reason)
            show.thread.join()
        self.close(reason, stop_idle=False)

    def _busy(self) -> bool:
        show = self._show
        return show is not None and show.thread is not None and show.thread.is_alive()

    def _upload(self, request: msg.Request) -> dict[str, Any]:
        if self._busy():
            raise RelayRefused("a show is running on this relay; stop it before uploading")
        schedule, unsafe = validate_upload(
            request.text("schedule"),
            request.text("sha256"),
            self.robots,
            allow_unsafe=self.allow_unsafe,
        )
        transports = {p.name: self.robots[p.name].transport for p in schedule.performers}
        urls = {n: self.robots[n].url for n in transports}
        report = preflight(
            schedule, transports, urls=urls, battery_floor=request.maybe_number("battery_floor")
        )
        for row in report.rows:
            robot = self.robots[row.performer]
            robot.firmware = row.firmware or robot.firmware
            robot.battery = row.battery if row.battery is not None else robot.battery
            robot.voltage = row.voltage if row.voltage is not None else robot.voltage
        # The show's runner collects garbage before it starts (and none while it plays): done
        # here, and what exists frozen, that costs nothing between the start command and
        # the start time, which a busy host would otherwise begin late by.
        gc.collect()
        gc.freeze()
        with self._lock:
            if self._holder is not None:
                self._holder.watchdog.set_timeout(request.whole("watchdog_ms") / 1000)
            self._show = _Show(
                schedule,
                request.text("sha256"),
                request.text("link_loss"),
                battery_floor=request.maybe_number("battery_floor"),
            )
            self._last = None
            self._bookkeeping.flush()
            self._collector.drain()  # nothing of an earlier show goes to this one
        self.log.event(
            "upload",
            show=schedule.name,
            sha256=request.text("sha256"),
            performers=[p.name for p in schedule.performers],
            preflight_ok=report.ok,
            unsafe_allowed=unsafe,
        )
        return {
            "sha256": request.text("sha256"),
            "preflight_ok": report.ok,
            "preflight": [
                {
                    "performer": r.performer,
                    "model": r.model,
                    "port": r.port,
                    "opened": r.opened,
                    "firmware": r.firmware,
                    "detected": r.detected,
                    "battery": r.battery,
                    "voltage": r.voltage,
                    "low_latency": r.low_latency,
                    "problems": r.problems,
                    "notes": r.notes,
                }
                for r in report.rows
            ],
        }

    def _start(self, request: msg.Request) -> dict[str, Any]:
        sha = request.text("sha256")
        start_at = request.maybe_number("start_at")
        start_in = request.maybe_number("start_in")
        if start_in is not None and start_at is None:
            start_at = self.clock.now() + start_in  # the naive way: a lead after arrival
        elif start_at is None or start_in is not None:
            raise RelayRefused("start: give start_at or start_in (not both)")
        offset = request.number("offset")
        with self._lock:
            show = self._show
            if show is None or show.sha256 != sha:
                raise RelayRefused(f"start: no uploaded show with SHA-256 {sha[:12]}...")
            if show.thread is not None:
                raise RelayRefused("start: this show has already started")
            if not 0 <= offset < show.schedule.duration:
                raise RelayRefused(f"start: offset {offset:g} s is outside the show")
            if start_at <= self.clock.now():
                raise RelayRefused(
                    f"start: the start time passed {(self.clock.now() - start_at) * 1e3:.1f} ms "
                    "ago (give a longer lead time)"
                )
            # Refused rather than started late: a late host would play behind the others.
            need = max(executor_lead(p, offset) for p in show.schedule.performers)
            margin = start_at - (self.clock.now() + need)
            if margin < 0:
                raise RelayRefused(
                    f"start: the robots need {need * 1e3:.0f} ms to be ready and the start time "
                    f"is {(need + margin) * 1e3:.0f} ms away (give a longer lead time)"
                )
            runner = local_runner(
                show.schedule,
                {p.name: self.robots[p.name].transport for p in show.schedule.performers},
                clock=self.clock,
                events=self.events,
                telemetry=self.telemetry,
                battery_floor=show.battery_floor,
                allow_unsafe=self.allow_unsafe,
            )
            show.runner, show.start_at, show.offset = runner, start_at, offset
            show.thread = threading.Thread(
                target=self._play, args=(show,), name="relay show", daemon=True
            )
            show.thread.start()
        self.log.event("armed", sha256=sha, start_at=start_at, margin_ms=round(margin * 1e3, 3))
        return {"start_at": start_at, "margin": margin}

    def _play(self, show: _Show) -> None:
        runner = show.runner
        assert runner is not None and show.start_at is not None
        # The writer threads raise themselves (runtime/realtime.py); Zenoh's stay normal.
        self.log.event("realtime", granted=policy().summary)
        try:
            result = runner.run(
                offset=show.offset, lead=0.0, start_at=show.start_at, handle_signals=False
            )
        except Exception as exc:  # the runner has safe-stopped every robot already
            result = ShowResult(False, f"exception: {exc!r}")
        late = result.start_at - show.start_at if result.start_at else 0.0
        if late > 0:  # the host was too busy to be ready in time: say so, it plays behind
            self.log.event("late_start", late_ms=round(late * 1e3, 3))
        with self._lock:
            self._last = {
                "sha256": show.sha256,
                "completed": result.completed,
                "reason": result.reason,
                "faults": dict(result.faults),
                "link_lost": show.link_lost,
                "late_start_ms": round(max(0.0, late) * 1e3, 3),
                "stops": {n: s.ok for n, s in result.stops.items()},
                "stop_latency_ms": (
                    None if result.stop_latency is None else round(result.stop_latency * 1e3, 3)
                ),
            }
        show.ran.set()  # a stop command answers now, not after the bookkeeping below
        # The show's last events are logged and collected before it is reported over (the
        # state stays "running" until then, so a conductor keeps collecting).
        self._bookkeeping.flush()
        with self._lock:
            if self._show is show:
                self._show = None

    def _timed(self, op: str, request: msg.Request) -> dict[str, Any]:
        """pause, resume or seek at a time on the show clock (the executors act on it)."""
        with self._lock:
            show = self._show
            if show is None or show.runner is None:
                raise RelayRefused(f"{op}: no show is running")
            runner = show.runner
        at = request.maybe_number("at")
        now = self.clock.now()
        if at is not None and at < now:
            # Acting late would leave this host on another frame than the others, for good.
            raise RelayRefused(
                f"{op}: its time passed {(now - at) * 1e3:.1f} ms before it arrived "
                "(give a longer command lead)"
            )
        when = now if at is None else at
        if op == "pause":
            runner.pause(at=when)
        elif op == "resume":
            runner.resume(at=when)
        else:
            runner.seek(request.number("show_time"), at=when)
        return {"at": when}

    def _stage_command(self, request: msg.Request) -> dict[str, Any]:
        """A remote behaviour's command (:mod:`xgo_show.behave.relay_host`)."""
        from xgo_show.behave.relay_host import StageHost

        with self._lock:
            if self._busy():
                raise RelayRefused(f"{request.op}: a show is running on this relay")
            if self._stage is None:
                self._stage = StageHost(self.robots, clock=self.clock, events=self.events,
                                        allow_unsafe=self.allow_unsafe)
            stage = self._stage
            if request.op == "stage_open" and self._holder is not None:
                self._holder.watchdog.set_timeout(request.whole("watchdog_ms") / 1000)
        return stage.handle(request)

    def stop_show(self, reason: str) -> dict[str, bool]:
        """Safe-stop every robot now, whatever runs; return per robot whether it worked."""
        with self._lock:
            stage, self._stage = self._stage, None
        if stage is not None:  # its writers end first: one writer on a port at a time
            stage.close(reason)
        with self._lock:
            show = self._show
        if show is not None and show.runner is not None and show.thread is not None:
            show.runner.stop(reason)
            show.ran.wait(1.0)
            return {n: s.ok for n, s in (show.runner.result or ShowResult(False, "")).stops.items()}
        with self._lock:
            self._show = None
            out = {}
            for name, robot in self.robots.items():
                error = robot.safe_stop()
                out[name] = not error
            self.log.event("safe_stop", relay=self.name, reason=reason, ok=out)
            return out

    def _probe(self, performer: str) -> list[list[str]]:
        robot = self.robots.get(performer)
        if robot is None:
            raise RelayRefused(f"probe: no robot {performer!r} on relay {self.name}")
        if self._busy():
            raise RelayRefused(f"probe: a show is running on relay {self.name}")
        from xgo_show.families import get_family

        rows = get_family(robot.profile).probe(robot.client(), given=robot.model)
        return [[k, v] for k, v in rows]

    def _show_status(self) -> dict[str, Any]:
        show = self._show
        t = self.clock.now()  # the show clock now: when the show times below were read
        runner = show.runner if show is not None else None
        snap = runner.snapshot() if runner is not None else None
        if snap is not None and any(p.state.ended for p in snap.performers):
            # A robot's end goes out with the events that led to it: the conductor's runner
            # returns once it sees every robot ended, and the bookkeeping thread hands events
            # on a few ms late (relay/deferred.py), so they would miss the conductor's log.
            self._bookkeeping.flush()
        status: dict[str, Any] = {
            "t": t,
            "state": self._state(),
            "last": self._last,
            "events": self._collector.drain(),
            "dropped": self._collector.dropped,
        }
        if self._stage is not None:
            status["stage"] = self._stage.status()
        if runner is not None and snap is not None:
            status["show_time"] = snap.show_time
            status["performers"] = {
                p.performer: {
                    "state": p.state.value,
                    "show_time": p.show_time,
                    "sent": p.sent,
                    "total": p.total,
                    "cue": p.cue,
                    "fault": runner.performers[p.performer].fault,
                }
                for p in snap.performers
            }
        return status

    # ------------------------------------------------------------------ watchdog

    def _on_silence(self, conductor: msg.Conductor, silence: float) -> None:
        """The holder was not heard for its watchdog time: apply the link-loss policy."""
        with self._lock:
            holder = self._holder
            if holder is None or holder.conductor.id != conductor.id:
                return
            show = self._show
            running = show is not None and show.thread is not None
            self.log.event(
                "link_lost",
                conductor=conductor.name,
                silent_ms=round(silence * 1e3, 3),
                policy=show.link_loss if running and show is not None else None,
            )
            if not running or show is None:
                self._release(f"conductor silent for {silence * 1e3:.0f} ms")
                return
            show.link_lost = True
            self._release(f"link lost during the show; policy {show.link_loss}")
            policy = show.link_loss
        if policy == "stop":
            self.stop_show(
                f"link lost: conductor {conductor.name} silent for {silence * 1e3:.0f} ms"
            )
