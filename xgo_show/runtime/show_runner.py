"""Run a whole show: several performer executors from one shared start time, one safety policy.

:class:`ShowRunner` owns no ports: it is handed one open transport per performer (a serial port
here; a relay's link later) and builds a :class:`PerformerExecutor` for each. It guarantees
that every way a show can end badly ends in a safe stop on every performer:

- a performer fault (port error, fallen Rider, flat battery): with ``on_failure="halt_all"``
  (the default) every performer is safe-stopped; with ``"continue"`` only the failing one is;
- SIGINT (Ctrl-C) or SIGTERM while :meth:`run` is running in the main thread;
- any exception in the coordinating thread, or :meth:`stop` from another thread.

Safe stops run in parallel, one short-lived thread per performer, so a blocked port cannot
delay the others; the whole stop is bounded by ``stop_timeout`` (100 ms by default).
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import sys
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import FrameType
from typing import Any

from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Profile
from xgo_show.runtime.clock import Clock, FakeClock, MonotonicClock
from xgo_show.runtime.executor import (
    ExecutorState,
    PerformerExecutor,
    Progress,
    ReachFn,
    SafeStopResult,
)
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.safety import check_unsafe
from xgo_show.runtime.telemetry import TelemetryPoller
from xgo_show.transports.base import Transport

__all__ = ["FAILURE_POLICIES", "ShowProgress", "ShowResult", "ShowRunner", "default_reach"]

FAILURE_POLICIES = ("halt_all", "continue")
_SWITCH_INTERVAL = 0.0005  # seconds


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
    executors: dict[str, PerformerExecutor] = field(default_factory=dict)
    stops: dict[str, SafeStopResult] = field(default_factory=dict)
    faults: dict[str, str] = field(default_factory=dict)
    start_at: float = 0.0
    offset: float = 0.0
    stop_latency: float | None = None  # seconds from the stop request to the last stop frame


def default_reach(schedule: PerformerSchedule, profile: Profile) -> ReachFn:
    """Catch-up frames from the compiler: the register state at ``t``, and frames to reach it."""

    def reach(t: float) -> list[tuple[bytes, str]]:
        from xgo_show.compiler import frames_to_reach, state_at

        return [(f.data, f.label) for f in frames_to_reach(profile, state_at(schedule, t))]

    return reach


class ShowRunner:
    """Runs every performer of ``schedule`` over ``transports`` (performer name -> transport).

    Keyword options: ``clock`` (default :class:`MonotonicClock`), ``fast`` (each executor gets
    its own :class:`FakeClock`: no waiting, every frame still sent; telemetry off),
    ``telemetry`` (poll battery/status/attitude), ``battery_floor`` (percent; default the
    schedule's), ``on_failure`` (default the schedule's), ``allow_unsafe``, ``log``,
    ``progress`` (called about ``progress_hz`` times a second with a :class:`ShowProgress`),
    ``stop_timeout`` (seconds allowed for the safe stop of all performers), ``reach`` (per
    performer catch-up function for mid-show starts and resume; default :func:`default_reach`).
    """

    def __init__(
        self,
        schedule: Schedule,
        transports: Mapping[str, Transport],
        *,
        clock: Clock | None = None,
        fast: bool = False,
        telemetry: bool = True,
        battery_floor: float | None = None,
        on_failure: str | None = None,
        allow_unsafe: bool = False,
        log: RunLog | None = None,
        progress: Callable[[ShowProgress], None] | None = None,
        progress_hz: float = 4.0,
        stop_timeout: float = 0.1,
        reach: Mapping[str, ReachFn | None] | None = None,
    ) -> None:
        missing = [p.name for p in schedule.performers if p.name not in transports]
        if missing:
            raise XgoShowError(f"no port for performer(s) {', '.join(missing)}")
        self.schedule = schedule
        self.on_failure = on_failure or schedule.on_failure
        if self.on_failure not in FAILURE_POLICIES:
            raise XgoShowError(
                f"unknown failure policy {self.on_failure!r}; one of {', '.join(FAILURE_POLICIES)}"
            )
        self.battery_floor = schedule.battery_floor if battery_floor is None else battery_floor
        self.clock: Clock = clock if clock is not None else MonotonicClock()
        self.fast = fast
        self.log = log if log is not None else RunLog(None)
        self.progress_cb = progress
        self.progress_interval = 1.0 / progress_hz
        self.stop_timeout = stop_timeout
        self.profiles = {p.name: get_profile(p.model) for p in schedule.performers}
        self.unsafe_found = check_unsafe(schedule, self.profiles, allow_unsafe=allow_unsafe)
        self._waker = _Waker()
        self._lock = threading.Lock()
        self._stop_reason: str | None = None
        self._stop_requested_at: float | None = None
        self._toggles = 0  # pause/resume requests from SIGTSTP (Ctrl-Z)
        self._paused = False
        self._faulted: list[tuple[str, str, float]] = []
        self.executors: dict[str, PerformerExecutor] = {}
        for perf in schedule.performers:
            profile = self.profiles[perf.name]
            poller = (
                TelemetryPoller(profile, battery_floor=self.battery_floor)
                if telemetry and not fast
                else None
            )
            if reach is not None and perf.name in reach:
                reach_fn = reach[perf.name]
            else:
                reach_fn = default_reach(perf, profile)
            self.executors[perf.name] = PerformerExecutor(
                perf,
                transports[perf.name],
                clock=FakeClock(self.clock.now()) if fast else self.clock,
                profile=profile,
                telemetry=poller,
                reach=reach_fn,
                linger_until=schedule.duration,
                log=self.log,
                on_fault=self._on_fault,
            )
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

    def pause(self) -> None:
        """Pause every performer (robots held at rest, timeline frozen)."""
        self._paused = True
        self.log.event("pause", show_time=round(self.snapshot().show_time, 6))
        for ex in self.executors.values():
            ex.pause()

    def resume(self) -> None:
        """Resume every performer where the show was paused."""
        self._paused = False
        self.log.event("resume")
        for ex in self.executors.values():
            ex.resume()

    @property
    def paused(self) -> bool:
        return self._paused

    def _on_fault(self, executor: PerformerExecutor, reason: str) -> None:
        with self._lock:
            self._faulted.append((executor.name, reason, self.clock.now()))
        self._waker.wake()

    # ------------------------------------------------------------------ run

    def run(
        self, *, offset: float = 0.0, lead: float = 0.05, handle_signals: bool = True
    ) -> ShowResult:
        """Play the show from show time ``offset``; returns when it is over or stopped.

        ``lead`` seconds pass between the call and the start (room for catch-up frames of a
        mid-show start). While this runs in the main thread with ``handle_signals``, SIGINT and
        SIGTERM become a safe stop and SIGTSTP (Ctrl-Z) pauses/resumes instead of suspending
        the process with robots in motion.
        """
        self._waker.open()
        restore = self._install_signals() if handle_signals else {}
        # Writer threads hand the GIL to each other at their deadlines; a CPU-bound thread (a
        # reader parsing, a progress callback) must not hold it for the default 5 ms.
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, _SWITCH_INTERVAL))
        result = ShowResult(False, "")
        self.result = result
        result.executors = dict(self.executors)
        result.offset = offset
        try:
            now = self.clock.now()
            if offset > 0:
                lead = max(lead, self._reach_time(offset))
            start_at = now + lead
            result.start_at = start_at
            self.log.event(
                "start",
                show=self.schedule.name,
                offset=offset,
                start_at=round(start_at, 6),
                performers=[p.name for p in self.schedule.performers],
                on_failure=self.on_failure,
                battery_floor=self.battery_floor,
                fast=self.fast,
            )
            for ex in self.executors.values():
                # In fast mode each executor runs on its own fake clock, from its own "now".
                ex.start(ex.clock.now() + lead if self.fast else start_at, offset=offset)
            self._supervise(result)
        except BaseException as exc:
            # Whatever broke the coordinating thread (a progress callback, a bug, a
            # KeyboardInterrupt without the handlers): stop every robot first, then say why.
            why = f"exception: {exc!r}"
            self._stop_all(why, result)
            result.reason = why
            self.log.event("exception", error=repr(exc), type=type(exc).__name__)
            raise
        finally:
            for ex in self.executors.values():
                ex.join(1.0)
                ex.close()
            self._restore_signals(restore)
            self._waker.close()
            sys.setswitchinterval(switch)
            result.faults = {ex.name: ex.fault for ex in self.executors.values() if ex.fault}
            self.log.event(
                "end",
                completed=result.completed,
                reason=result.reason,
                faults=result.faults,
                states={n: ex.state.value for n, ex in self.executors.items()},
                stop_latency_ms=(
                    None if result.stop_latency is None else round(result.stop_latency * 1000, 3)
                ),
            )
        return result

    def _supervise(self, result: ShowResult) -> None:
        next_progress = 0.0
        while True:
            self._waker.wait(self.progress_interval)
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
            if all(ex.done for ex in self.executors.values()):
                result.completed = all(
                    ex.state is ExecutorState.FINISHED for ex in self.executors.values()
                )
                if not result.reason:
                    result.reason = "completed" if result.completed else "performer(s) failed"
                return
            now = self.clock.now()
            if self.progress_cb is not None and now >= next_progress:
                next_progress = now + self.progress_interval
                self.progress_cb(self.snapshot())

    def snapshot(self) -> ShowProgress:
        """Where the show is now."""
        progs = tuple(ex.progress for ex in self.executors.values())
        show_time = max((p.show_time for p in progs), default=0.0)
        telemetry = {
            n: dict(ex.telemetry.last)
            for n, ex in self.executors.items()
            if ex.telemetry is not None
        }
        return ShowProgress(show_time, self.schedule.duration, progs, telemetry)

    def _reach_time(self, offset: float) -> float:
        """Seconds the catch-up frames of a mid-show start need on the slowest link (+margin)."""
        worst = 0.0
        for ex in self.executors.values():
            if ex.reach is None:
                continue
            link = ex.schedule.link
            frames = ex.reach(offset)
            worst = max(worst, sum(link.wire_time(len(d)) + link.gap for d, _ in frames))
        return worst + 0.05

    def _stop_all(self, reason: str, result: ShowResult, *, requested: float | None = None) -> None:
        self._stop_some(list(self.executors), reason, result, requested=requested)

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
            self.executors[name].abort()  # no schedule frame goes out after this line
        out: dict[str, SafeStopResult] = {}

        def one(name: str) -> None:
            out[name] = self.executors[name].safe_stop(reason, timeout=self.stop_timeout)

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
        ready, _, _ = select.select([self._r], [], [], timeout)
        if ready:
            with contextlib.suppress(BlockingIOError):
                os.read(self._r, 4096)

    def close(self) -> None:
        r, w = self._r, self._w
        self._r = self._w = -1
        for fd in (r, w):
            if fd >= 0:
                os.close(fd)
