"""Run a whole show: several performers from one shared start time, one safety policy.

:class:`ShowRunner` owns no ports and builds nothing: it is handed one
:class:`~xgo_show.runtime.performer.Performer` per performer of the schedule (a local
:class:`PerformerExecutor`, a proxy of a robot behind a relay...) and the
:class:`~xgo_show.runtime.events.EventBus` they publish on (:mod:`~xgo_show.runtime.launch`
builds both). It guarantees that every way a show can end badly ends in a safe stop on every
performer:

- a performer fault (port error, fallen Rider, flat battery): with ``on_failure="halt_all"``
  (the default) every performer is safe-stopped; with ``"continue"`` only the failing one is;
- SIGINT (Ctrl-C) or SIGTERM while :meth:`run` is running in the main thread;
- any exception in the coordinating thread, or :meth:`stop` from another thread.

Safe stops run in parallel, one short-lived thread per performer, so a blocked port cannot
delay the others; the whole stop is bounded by ``stop_timeout`` (100 ms by default).
"""

from __future__ import annotations

import contextlib
import gc
import math
import os
import select
import signal
import sys
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import FrameType
from typing import Any

from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import SetupError, UsageError
from xgo_show.profiles.model import Profile
from xgo_show.runtime.clock import Clock, FakeClock, MonotonicClock
from xgo_show.runtime.events import (
    Event,
    EventBus,
    FaultRaised,
    FrameSent,
    ProgressTick,
    RunnerFailed,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
)
from xgo_show.runtime.executor import ExecutorState, Progress, ReachFn, SafeStopResult
from xgo_show.runtime.performer import Performer
from xgo_show.runtime.realtime import HELPER_PRIORITY, enter_show_thread, leave_show_thread
from xgo_show.runtime.stats import SendStats

__all__ = ["FAILURE_POLICIES", "ShowProgress", "ShowResult", "ShowRunner", "default_reach"]

FAILURE_POLICIES = ("halt_all", "continue")
_SWITCH_INTERVAL = 0.0005  # seconds

#: Seconds after an instant of the show's grid at which progress is published (see
#: :meth:`ShowRunner._after_instant`). None (every ``1 / progress_hz`` from whenever, as
#: before) is set only by ``benchmarks/runtime_timing.py --suspects`` for its before row and
#: by a test of the interval alone.
PROGRESS_AFTER: float | None = 0.001


@dataclass(frozen=True)
class ShowProgress:
    """A snapshot of the whole show for progress displays."""

    show_time: float
    duration: float
    performers: tuple[Progress, ...]
    telemetry: Mapping[str, Mapping[str, float]]


@dataclass
class ShowResult:
    """How a run ended."""

    completed: bool  # every performer played its part to the end
    reason: str  # "completed", "SIGINT", "fault: ...", ...
    performers: dict[str, Performer] = field(default_factory=dict)
    stops: dict[str, SafeStopResult] = field(default_factory=dict)
    faults: dict[str, str] = field(default_factory=dict)
    start_at: float = 0.0
    offset: float = 0.0
    stop_latency: float | None = None  # seconds from the stop request to the last stop frame
    stats: dict[str, SendStats] = field(default_factory=dict)  # what each one sent


def default_reach(schedule: PerformerSchedule, profile: Profile) -> ReachFn:
    """Catch-up frames from the compiler: the register state at ``t``, and frames to reach it.

    The function has an ``after_rest(t)`` too, which the executor uses to resume from a hold
    at ``t``: a robot held at rest kept its posture, so only the registers the rest frames
    changed (speeds and periodic motions) are written back, and none the frames planned at
    ``t`` itself write anyway (they go out next). Usually nothing, so a held show goes on with
    its own first frame the moment it is released.
    """
    return _StateReach(schedule, profile)


class _StateReach:
    """:func:`default_reach`'s function (a class for its ``after_rest``)."""

    def __init__(self, schedule: PerformerSchedule, profile: Profile) -> None:
        self.schedule = schedule
        self.profile = profile
        self._rested: frozenset[str] | None = None  # registers the rest frames write

    def __call__(self, t: float) -> list[tuple[bytes, str]]:
        from xgo_show.compiler import frames_to_reach, state_at

        return [(f.data, f.label) for f in frames_to_reach(self.profile,
                                                           state_at(self.schedule, t))]

    def rested(self) -> frozenset[str]:
        """The registers the rest frames write."""
        if self._rested is None:
            from xgo_show.compiler.schedule import ScheduledFrame
            from xgo_show.families import get_family
            from xgo_show.runtime.safety import rest_frames

            rest = [ScheduledFrame(0.0, f.data) for f in rest_frames(self.profile)]
            self._rested = frozenset(get_family(self.profile).state_at(self.profile, rest, 0.0))
        return self._rested

    def after_rest(self, t: float) -> list[tuple[bytes, str]]:
        """Catch-up after a hold at ``t`` (see :func:`default_reach`)."""
        from xgo_show.compiler import frames_to_reach, state_at
        from xgo_show.families import get_family

        rested = self.rested()
        at_t = [f for f in self.schedule.frames if abs(f.t - t) < 1e-9]
        written = get_family(self.profile).state_at(self.profile, at_t, t) if at_t else {}
        wanted = {name: raw for name, raw in state_at(self.schedule, t).items()
                  if name in rested and name not in written}
        return [(f.data, f.label) for f in frames_to_reach(self.profile, wanted)]

    def at_rest(self, t: float) -> bool:
        """Whether the robot holding at ``t`` (every frame before ``t`` sent) is at rest
        already: each register the rest frames write at its initial value, which is what
        they write (speeds and periodic motions neutral). Then a hold needs no rest frames."""
        from xgo_show.compiler import frames_to_reach, state_at

        rested = self.rested()
        before = state_at(self.schedule, t - 1e-6)
        return not frames_to_reach(self.profile, {name: raw for name, raw in before.items()
                                                  if name in rested})


class ShowRunner:
    """Runs every performer of ``schedule`` (``performers``: name -> :class:`Performer`).

    The runner builds nothing and reaches into nothing: it starts, steers and stops performers
    through the protocol and learns what they do from the ``events`` bus they publish on (the
    same bus it publishes the show-level events on). Keyword options: ``clock`` (default
    :class:`MonotonicClock`; the time base of ``start_at`` and every ``at``), ``on_failure``
    (default the schedule's), ``battery_floor`` (for the start event; default the
    schedule's), ``progress_hz`` (rate of :class:`ProgressTick` events), ``stop_timeout``
    (seconds allowed for the safe stop of all performers), ``command_lead`` (seconds between a
    pause/resume/seek request and the clock time every performer acts on: room for remote
    performers to receive it), ``hold_gc`` (no cyclic garbage collection while the show plays,
    see :meth:`run`).
    """

    def __init__(
        self,
        schedule: Schedule,
        performers: Mapping[str, Performer],
        *,
        events: EventBus,
        clock: Clock | None = None,
        on_failure: str | None = None,
        battery_floor: float | None = None,
        progress_hz: float = 4.0,
        stop_timeout: float = 0.1,
        command_lead: float = 0.0,
        hold_gc: bool = True,
    ) -> None:
        missing = [p.name for p in schedule.performers if p.name not in performers]
        if missing:
            raise SetupError(f"no port for performer(s) {', '.join(missing)}")
        self.schedule = schedule
        self.on_failure = on_failure or schedule.on_failure
        if self.on_failure not in FAILURE_POLICIES:
            raise SetupError(
                f"unknown failure policy {self.on_failure!r}; one of {', '.join(FAILURE_POLICIES)}"
            )
        self.battery_floor = schedule.battery_floor if battery_floor is None else battery_floor
        self.clock: Clock = clock if clock is not None else MonotonicClock()
        self.events = events
        self.performers: dict[str, Performer] = {
            p.name: performers[p.name] for p in schedule.performers
        }
        # Performers that play no robot (the soundtrack) keep time with the others too.
        self.performers.update({n: p for n, p in performers.items() if n not in self.performers})
        self.progress_interval = 1.0 / progress_hz
        self.stop_timeout = stop_timeout
        self.command_lead = command_lead
        self.hold_gc = hold_gc
        self._waker = _Waker()
        self._lock = threading.Lock()
        self._stop_reason: str | None = None
        self._stop_requested_at: float | None = None
        self._toggles = 0  # pause/resume requests from SIGTSTP (Ctrl-Z)
        self._paused = False
        self._faulted: list[tuple[str, str, float]] = []
        self.stats = {name: SendStats() for name in self.performers}
        self._subs = [
            events.subscribe(self._on_fault, FaultRaised),
            events.subscribe(self._on_frame, FrameSent),
        ]
        self.result: ShowResult | None = None

    # ------------------------------------------------------------------ control (any thread)

    def stop(self, reason: str = "stop requested") -> None:
        """Ask for a safe stop of every performer (returns at once; :meth:`run` does it).

        Lock-free, so that a signal handler may call it.
        """
        if self._stop_reason is None:
            self._stop_requested_at = self.clock.now()
            self._stop_reason = reason
        self._waker.wake()

    def _when(self, at: float | None) -> float:
        return self.clock.now() + self.command_lead if at is None else at

    def pause(self, *, at: float | None = None) -> None:
        """Pause every performer at clock time ``at`` (default: now + ``command_lead``)."""
        when = self._when(at)
        self._paused = True
        self.events.publish(ShowPaused(self.clock.now(), self.snapshot().show_time))
        for p in self.performers.values():
            p.pause(at=when)

    def resume(self, *, at: float | None = None) -> None:
        """Resume every performer where the show was paused, together at clock time ``at``."""
        when = self._when(at)
        self._paused = False
        self.events.publish(ShowResumed(self.clock.now(), self.snapshot().show_time))
        for p in self.performers.values():
            p.resume(at=when)

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        """Jump every performer to ``show_time``, together at clock time ``at``."""
        if not 0.0 <= show_time < self.schedule.duration:
            raise UsageError(
                f"seek to {show_time:g} s: outside the show (0 to {self.schedule.duration:g} s)"
            )
        when = self._when(at)
        lead = max((p.lead_time(show_time) for p in self.performers.values()), default=0.0)
        when = max(when, self.clock.now() + lead)
        self.events.publish(ShowSought(self.clock.now(), show_time, when))
        for p in self.performers.values():
            p.seek(show_time, at=when)

    @property
    def paused(self) -> bool:
        return self._paused

    def _on_frame(self, event: Event) -> None:
        assert isinstance(event, FrameSent)
        stats = self.stats.get(event.performer)
        if stats is not None:
            stats.on_event(event)

    def _on_fault(self, event: Event) -> None:
        assert isinstance(event, FaultRaised)
        with self._lock:
            self._faulted.append((event.performer, event.reason, event.t))
        self._waker.wake()

    # ------------------------------------------------------------------ run

    def run(
        self,
        *,
        offset: float = 0.0,
        lead: float = 0.05,
        start_at: float | None = None,
        handle_signals: bool = True,
    ) -> ShowResult:
        """Play the show from show time ``offset``; returns when it is over or stopped.

        The start is ``start_at`` (a clock time) or ``lead`` seconds from the call, whichever
        is later than what every performer needs (catch-up frames of a mid-show start, a
        remote host's lead). While this runs in the main thread with ``handle_signals``,
        SIGINT and SIGTERM become a safe stop and SIGTSTP (Ctrl-Z) pauses/resumes instead of
        suspending the process with robots in motion.
        """
        self._waker.open()
        restore = self._install_signals() if handle_signals else {}
        # Writer threads hand the GIL to each other at their deadlines; a CPU-bound thread (a
        # reader parsing, a progress callback) must not hold it for the default 5 ms.
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, _SWITCH_INTERVAL))
        # A cyclic garbage collection stops every thread while it walks the heap: with
        # ``hold_gc`` none runs during the show (what exists now is frozen out of its reach, and
        # the runtime's per-frame objects are freed by reference counting alone), and one runs
        # after it.
        collecting = gc.isenabled()
        if self.hold_gc:
            gc.collect()
            gc.freeze()
            gc.disable()
        raised = False
        result = ShowResult(False, "")
        self.result = result
        result.performers = dict(self.performers)
        result.stats = self.stats
        result.offset = offset
        try:
            now = self.clock.now()
            need = max((p.lead_time(offset) for p in self.performers.values()), default=0.0)
            begin = max(now + max(lead, need), start_at if start_at is not None else now)
            result.start_at = begin
            self.events.publish(
                ShowStarted(
                    now,
                    self.schedule.name,
                    offset,
                    begin,
                    tuple(self.performers),
                    self.on_failure,
                    self.battery_floor,
                )
            )
            for p in self.performers.values():
                p.start(begin, offset=offset)
            # This thread publishes progress and handles faults while frames are due: below
            # the writers, above normal threads (Python's lock: realtime.HELPER_PRIORITY).
            # Raised only now, so the threads the performers started do not inherit it.
            raised = not isinstance(self.clock, FakeClock) and enter_show_thread(HELPER_PRIORITY)
            self._supervise(result)
        except BaseException as exc:
            # Whatever broke the coordinating thread (a progress listener, a bug, a
            # KeyboardInterrupt without the handlers): stop every robot first, then say why.
            why = f"exception: {exc!r}"
            self._stop_all(why, result)
            result.reason = why
            self.events.publish(RunnerFailed(self.clock.now(), repr(exc), type(exc).__name__))
            raise
        finally:
            for p in self.performers.values():
                p.join(1.0)
                p.close()
            for sub in self._subs:
                sub.close()
            self._restore_signals(restore)
            self._waker.close()
            if raised:
                leave_show_thread()
            sys.setswitchinterval(switch)
            if self.hold_gc:
                gc.unfreeze()
                if collecting:
                    gc.enable()
            result.faults = {n: p.fault for n, p in self.performers.items() if p.fault}
            self.events.publish(
                ShowEnded(
                    self.clock.now(),
                    result.completed,
                    result.reason,
                    dict(result.faults),
                    {n: p.state.value for n, p in self.performers.items()},
                    result.stop_latency,
                )
            )
        return result

    def _supervise(self, result: ShowResult) -> None:
        next_progress = 0.0
        while True:
            self._waker.wait(min(self.progress_interval,
                                 max(0.0, next_progress - self.clock.now())))
            with self._lock:
                faulted, self._faulted = self._faulted, []
            stop_reason = self._stop_reason
            if stop_reason is not None:
                self._stop_all(stop_reason, result, requested=self._stop_requested_at)
                result.reason = stop_reason
                return
            while self._toggles:
                self._toggles -= 1
                if self._paused:
                    self.resume()
                else:
                    self.pause()
            for name, reason, when in faulted:
                why = f"fault on {name}: {reason}"
                if self.on_failure == "halt_all":
                    self._stop_all(why, result, requested=when)
                    result.reason = why
                    return
                self._stop_some([name], why, result, requested=when)
            if all(p.done for p in self.performers.values()):
                result.completed = all(
                    p.state is ExecutorState.FINISHED for p in self.performers.values()
                )
                if not result.reason:
                    result.reason = "completed" if result.completed else "performer(s) failed"
                return
            now = self.clock.now()
            if now >= next_progress:
                progress = self.snapshot()
                self.events.publish(ProgressTick(now, progress))
                next_progress = self._after_instant(now + self.progress_interval, now,
                                                    progress.show_time)

    def _after_instant(self, when: float, now: float, show_time: float) -> float:
        """``when``, moved to :data:`PROGRESS_AFTER` past the show's next instant on its grid
        (``show_time`` is the show time at clock time ``now``).

        A progress listener runs in this thread and holds Python's lock while it works (the
        live table takes 2-12 ms to draw on this VM); a writer that wakes meanwhile waits for
        it. Right after an instant the frames of that instant are out and the next is a grid
        step away. None (or a show without a grid): ``when`` as it is.
        """
        rate = self.schedule.control_rate
        if PROGRESS_AFTER is None or not rate:
            return when
        step = 1.0 / rate
        at = show_time + (when - now)
        return when + (math.ceil(at / step) * step - at) + PROGRESS_AFTER

    def snapshot(self) -> ShowProgress:
        """Where the show is now."""
        progs = tuple(p.progress for p in self.performers.values())
        show_time = max((p.show_time for p in progs), default=0.0)
        telemetry = {n: p.readings for n, p in self.performers.items() if p.readings}
        return ShowProgress(show_time, self.schedule.duration, progs, telemetry)

    def _stop_all(self, reason: str, result: ShowResult, *, requested: float | None = None) -> None:
        self._stop_some(list(self.performers), reason, result, requested=requested)

    def _stop_some(
        self,
        names: list[str],
        reason: str,
        result: ShowResult,
        *,
        requested: float | None = None,
    ) -> None:
        """Safe-stop ``names`` in parallel; each gets ``stop_timeout`` for a stuck write.

        ``result.stop_latency`` becomes the time from ``requested`` (default: now; for a fault,
        when it was reported) to the end of the last stop sequence.
        """
        if requested is None:
            requested = self.clock.now()
        pending = [n for n in names if n not in result.stops]
        for name in pending:
            self.performers[name].abort()  # no schedule frame goes out after this line
        out: dict[str, SafeStopResult] = {}

        def one(name: str) -> None:
            out[name] = self.performers[name].safe_stop(reason, timeout=self.stop_timeout)

        threads = [
            threading.Thread(target=one, args=(n,), name=f"xgo-show stop {n}", daemon=True)
            for n in pending
        ]
        for th in threads:
            th.start()
        deadline = self.clock.now() + self.stop_timeout * 2
        for th in threads:
            th.join(max(0.0, deadline - self.clock.now()))
        for name in pending:
            result.stops[name] = out.get(
                name, SafeStopResult(name, reason, False, error="safe stop did not finish in time")
            )
        if pending:
            latency = self.clock.now() - requested
            result.stop_latency = max(result.stop_latency or 0.0, latency)

    # ------------------------------------------------------------------ signals

    def _install_signals(self) -> dict[int, Any]:
        if threading.current_thread() is not threading.main_thread():
            return {}
        saved: dict[int, Any] = {}

        # Handlers only set plain attributes and write to the wake-up pipe: they run between
        # two bytecodes of the main thread, which may hold any lock at that moment.
        def on_stop(signum: int, frame: FrameType | None) -> None:
            self.stop(signal.Signals(signum).name)

        def on_pause(signum: int, frame: FrameType | None) -> None:
            # Ctrl-Z would suspend the process with the robots still walking: instead it
            # pauses the show (robots held at rest), and a second Ctrl-Z resumes it.
            self._toggles += 1
            self._waker.wake()

        for sig in (signal.SIGINT, signal.SIGTERM):
            saved[sig] = signal.signal(sig, on_stop)
        if hasattr(signal, "SIGTSTP"):
            saved[signal.SIGTSTP] = signal.signal(signal.SIGTSTP, on_pause)
        return saved

    @staticmethod
    def _restore_signals(saved: dict[int, Any]) -> None:
        for sig, old in saved.items():
            signal.signal(sig, old)


class _Waker:
    """A self-pipe: ``wake()`` from any thread or signal handler, ``wait()`` in the supervisor.

    Lock-free on the waking side (one ``os.write``), unlike :class:`threading.Event`, whose
    internal lock a signal handler could find already held by the thread it interrupted.
    """

    def __init__(self) -> None:
        self._r = -1
        self._w = -1

    def open(self) -> None:
        if self._r < 0:
            self._r, self._w = os.pipe()
            os.set_blocking(self._r, False)
            os.set_blocking(self._w, False)

    def wake(self) -> None:
        w = self._w
        if w >= 0:
            with contextlib.suppress(OSError):  # full pipe: a wake-up is already pending
                os.write(w, b"!")

    def wait(self, timeout: float) -> None:
        if self._r < 0:
            return
        # poll(), not select(): a show with hundreds of ports has descriptors above 1024.
        poller = select.poll()
        poller.register(self._r, select.POLLIN)
        if poller.poll(max(0, int(timeout * 1000))):
            with contextlib.suppress(BlockingIOError):
                os.read(self._r, 4096)

    def close(self) -> None:
        r, w = self._r, self._w
        self._r = self._w = -1
        for fd in (r, w):
            if fd >= 0:
                os.close(fd)
