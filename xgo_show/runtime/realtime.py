"""Real-time scheduling of the show's pacing threads: decided once per process.

A frame is due at a planned time; a writer thread at normal priority shares the CPUs with every
other program, and on a busy machine the OS preempts it for milliseconds at a time (measured:
~140 involuntary switches a second, issue lateness p99 72 ms with one CPU busy). Under
SCHED_FIFO the writer runs the moment its wait ends. So every command that plays a show
(``run``, ``dry-run``, ``relay``, ``serve``, ``behave``) calls :func:`decide` once, and each
writer thread calls :func:`enter_show_thread` as it starts:

- ``auto`` (the default): SCHED_FIFO priority :data:`PRIORITY` for the writer threads when the
  process is permitted (root, CAP_SYS_NICE, or an RLIMIT_RTPRIO of at least the priority);
  otherwise normal priority and one line saying so (:attr:`RealtimePolicy.notice`);
- ``required`` (``--realtime``): the same, but a process that is not permitted stops with a
  clear error before anything opens;
- ``off`` (``--no-realtime``, or ``XGO_SHOW_REALTIME=off``): normal priority.

Only the show's own threads are raised, never the process, and only while a show plays: the
writers at :data:`PRIORITY`, and at :data:`HELPER_PRIORITY` the other threads that run Python
code while frames are due (each performer's telemetry reader, the thread that supervises the
show), since a writer waits for Python's lock behind whichever thread holds it. ``serve``
also raises, at :data:`HELPER_PRIORITY` while a show plays, Zenoh's receiving threads (which
run its trigger handlers: :func:`raise_thread`, :func:`threads_named`) and the director's
thread. Other Zenoh threads, listeners' own threads and simulators keep normal priority.
A FIFO thread that never blocked would keep every lower-priority thread off its CPU, so the
design is bounded twice: the real clock's waits block in the kernel under FIFO for all but
their last 0.2 ms (:data:`~xgo_show.runtime.clock.EARLY`, see
:class:`~xgo_show.runtime.clock.MonotonicClock`), and a
:class:`_Guard` thread checks the CPU time of every raised thread each :data:`GUARD_PERIOD`
and returns one that used more than :data:`GUARD_SHARE` of a CPU to normal priority, saying
so. The kernel's own limit on real-time CPU (``/proc/sys/kernel/sched_rt_runtime_us``, 95 %
by default) is the last line.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from xgo_show.errors import UsageError

__all__ = [
    "ENV",
    "GUARD_PERIOD",
    "GUARD_SHARE",
    "HELPER_PRIORITY",
    "PRIORITY",
    "Mode",
    "RealtimePolicy",
    "add_realtime_arguments",
    "configure",
    "decide",
    "enter_show_thread",
    "leave_show_thread",
    "lower_thread",
    "policy",
    "raise_thread",
    "restore",
    "threads_named",
]

Mode = Literal["auto", "required", "off"]
MODES: tuple[Mode, ...] = ("auto", "required", "off")

#: SCHED_FIFO priority of the writer threads: above every normal thread, below the kernel's
#: threaded interrupt handlers (50, which move a USB adapter's bytes) and audio servers
#: (PipeWire's data threads get 20 through rtkit).
PRIORITY = 10

#: SCHED_FIFO priority of the show's other threads that run Python while frames are due (each
#: performer's telemetry reader, the thread that supervises the show): one below the writers.
#: Python's lock (the GIL) knows no priorities: a writer that needs it waits for whichever
#: thread holds it, and a normal thread preempted while holding it kept a real-time writer
#: waiting for tens of ms on a busy machine (docs/realtime.md). Raised, they are never
#: preempted by normal threads, and each holds the lock for microseconds at a time.
HELPER_PRIORITY = PRIORITY - 1

#: The environment variable that gives the mode when no option does (``auto``, ``off``,
#: ``required``); child processes (a relay child of ``run``) inherit it.
ENV = "XGO_SHOW_REALTIME"

#: Seconds between the guard's checks of the raised threads' CPU time.
GUARD_PERIOD = 0.25
#: A raised thread that used more than this share of one CPU over a guard period is spinning:
#: it goes back to normal priority. A writer at 1,000 frames a second uses a few per cent.
GUARD_SHARE = 0.5


@dataclass(frozen=True)
class RealtimePolicy:
    """What this process decided: the mode asked for and whether writer threads get FIFO."""

    mode: Mode
    granted: bool
    why: str = ""  # why not, when refused

    @property
    def summary(self) -> str:
        """One phrase for the pre-flight table and run logs."""
        if self.granted:
            return f"SCHED_FIFO priority {PRIORITY} for the writer threads"
        if self.mode == "off":
            return "off (--no-realtime)"
        return f"not permitted ({self.why}): normal priority"

    @property
    def notice(self) -> str | None:
        """The line to print when ``auto`` could not have it (None otherwise)."""
        if self.granted or self.mode != "auto":
            return None
        return (
            f"note: real-time scheduling not permitted ({self.why}); the writer threads run at "
            "normal priority, so other load on this machine can delay frames (run as root, "
            f"give the interpreter CAP_SYS_NICE, or set RLIMIT_RTPRIO >= {PRIORITY}; "
            "--no-realtime silences this)"
        )


_OFF = RealtimePolicy("off", False)
_policy: RealtimePolicy = _OFF  # library default: nothing is raised until a command asks


def policy() -> RealtimePolicy:
    """The process's current decision (``off`` until :func:`configure`)."""
    return _policy


def restore(saved: RealtimePolicy) -> None:
    """Put back a policy :func:`policy` returned (tests, benchmarks that compare modes)."""
    global _policy
    _policy = saved


def configure(mode: str | None = None) -> RealtimePolicy:
    """Decide for this process: ``mode`` (None: :data:`ENV`, else ``auto``).

    Raises :class:`UsageError` for ``required`` when the process may not use SCHED_FIFO, and
    for an unknown mode.
    """
    global _policy
    chosen = mode if mode is not None else os.environ.get(ENV, "").strip().lower() or "auto"
    if chosen not in MODES:
        where = "" if mode is not None else f" (from {ENV})"
        raise UsageError(f"real-time mode {chosen!r}{where}: use one of {', '.join(MODES)}")
    checked: Mode = "auto" if chosen == "auto" else "required" if chosen == "required" else "off"
    if checked == "off":
        _policy = _OFF
        return _policy
    why = _probe()
    if why and checked == "required":
        raise UsageError(
            f"--realtime: SCHED_FIFO is not permitted ({why}); run as root, give the "
            f"interpreter CAP_SYS_NICE, or set RLIMIT_RTPRIO >= {PRIORITY} (ulimit -r); "
            "or leave out --realtime"
        )
    _policy = RealtimePolicy(checked, not why, why)
    return _policy


def add_realtime_arguments(parser: argparse.ArgumentParser) -> None:
    """``--realtime`` (required) and ``--no-realtime`` (off); neither: ``auto`` (or :data:`ENV`).

    :func:`decide` takes ``args.realtime``.
    """
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--realtime", dest="realtime", action="store_const", const="required",
        help=f"require SCHED_FIFO (priority {PRIORITY}) for the threads that send frames: stop "
        "with an error where it is not permitted. Without either option it is used where "
        "permitted (root, CAP_SYS_NICE or RLIMIT_RTPRIO), else a one-line note says so; "
        "docs/realtime.md",
    )
    group.add_argument(
        "--no-realtime", dest="realtime", action="store_const", const="off",
        help="send frames from threads of normal priority (no SCHED_FIFO)",
    )
    parser.set_defaults(realtime=None)


def decide(mode: str | None, *, virtual: bool = False) -> RealtimePolicy:
    """What a command calls: :func:`configure` with its options' ``mode`` (``args.realtime``
    from :func:`add_realtime_arguments`), printing the notice on standard error when ``auto``
    is refused. ``virtual``: this run never waits for real time, so nothing is raised."""
    decided = configure("off" if virtual and mode != "required" else mode)
    if decided.notice:
        print(decided.notice, file=sys.stderr, flush=True)
    return decided


def _probe() -> str:
    """Try SCHED_FIFO on a throwaway thread; '' when permitted, else why not."""
    if not hasattr(os, "sched_setscheduler") or not hasattr(os, "SCHED_FIFO"):
        return f"not available on {sys.platform}"
    out: list[str] = []

    def attempt() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PRIORITY))
        except OSError as exc:
            out.append(exc.strerror or str(exc))
        else:
            out.append("")

    probe = threading.Thread(target=attempt, name="realtime probe")
    probe.start()
    probe.join()
    return out[0] if out else "the probe thread failed"


def enter_show_thread(priority: int = PRIORITY) -> bool:
    """Raise the calling thread to SCHED_FIFO ``priority`` if the policy grants it: a writer
    at :data:`PRIORITY`, a telemetry reader or the show's supervising thread at
    :data:`HELPER_PRIORITY`.

    Returns whether it did. Pair with :func:`leave_show_thread` when the thread's work ends.
    """
    return raise_thread(threading.get_native_id(), priority)


def leave_show_thread() -> None:
    """Back to normal priority (a no-op for a thread that was never raised)."""
    lower_thread(threading.get_native_id())


def raise_thread(native: int, priority: int = HELPER_PRIORITY) -> bool:
    """Raise this process's thread ``native`` (its kernel id: also a thread Python did not
    start, such as one of Zenoh's runtime threads, see :func:`threads_named`) to SCHED_FIFO
    ``priority`` if the policy grants it, under the same guard as the writers: one that uses
    more than :data:`GUARD_SHARE` of a CPU goes back to normal priority. Returns whether it
    did; pair with :func:`lower_thread`."""
    if not _policy.granted:
        return False
    try:
        os.sched_setscheduler(native, os.SCHED_FIFO, os.sched_param(priority))
    except OSError:
        return False
    _GUARD.watch(native)
    return True


def lower_thread(native: int) -> None:
    """Thread ``native`` back to normal priority (a no-op unless :func:`raise_thread` or
    :func:`enter_show_thread` raised it and the guard has not lowered it already)."""
    if _GUARD.forget(native):
        _to_normal(native)


def threads_named(prefix: str) -> list[int]:
    """Kernel ids of this process's threads whose name starts with ``prefix`` (Zenoh's Rust
    runtime names its threads ``rx-0``, ``tx-0``, ...: /proc/self/task/ID/comm)."""
    out = []
    with contextlib.suppress(OSError):
        for task in os.listdir("/proc/self/task"):
            with contextlib.suppress(OSError):
                name = Path(f"/proc/self/task/{task}/comm").read_text(encoding="utf-8")
                if name.startswith(prefix):
                    out.append(int(task))
    return sorted(out)


def _to_normal(tid: int) -> None:
    with contextlib.suppress(OSError):  # the thread has ended meanwhile
        os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))


Reporter = Callable[[str], None]


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


class _Guard:
    """Returns a raised thread that spins to normal priority (see the module's docstring).

    Runs only while raised threads exist, at one priority above them so a spinning writer
    cannot keep it off its CPU; it sleeps between checks and does a few system calls each.
    """

    def __init__(self, report: Reporter = _say) -> None:
        self.report = report
        self._lock = threading.Lock()
        self._watched: dict[int, float] = {}  # native thread id -> CPU seconds at last check
        self._thread: threading.Thread | None = None
        self.demoted = 0

    def watch(self, native: int) -> None:
        with self._lock:
            self._watched[native] = _cpu_time(native)
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._run, name="realtime guard",
                                                daemon=True)
                self._thread.start()

    def forget(self, native: int) -> bool:
        with self._lock:
            return self._watched.pop(native, None) is not None

    def _run(self) -> None:
        with contextlib.suppress(OSError):  # else still useful whenever a CPU is free
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PRIORITY + 1))
        while True:
            time.sleep(GUARD_PERIOD)
            with self._lock:
                if not self._watched:
                    self._thread = None
                    return
                spinning = self._check()
            for native in spinning:
                _to_normal(native)
                self.demoted += 1
                self.report(
                    f"warning: show thread {native} used over {GUARD_SHARE:.0%} of a CPU "
                    f"for {GUARD_PERIOD:g} s under SCHED_FIFO: back to normal priority"
                )

    def _check(self) -> list[int]:
        """Native ids of the watched threads over their share since the last check (they
        are forgotten); the others' CPU time is noted for the next one."""
        spinning = []
        for native, before in list(self._watched.items()):
            now = _cpu_time(native)
            if now < 0:  # the thread has ended without leaving
                del self._watched[native]
            elif now - before > GUARD_SHARE * GUARD_PERIOD:
                del self._watched[native]
                spinning.append(native)
            else:
                self._watched[native] = now
        return spinning


def _cpu_time(native: int) -> float:
    """CPU seconds this process's thread ``native`` has used (-1 once it has ended).

    Read from /proc by the kernel's thread id: unlike a pthread handle, it is safe to ask
    about a thread that has ended.
    """
    try:
        with open(f"/proc/self/task/{native}/schedstat", encoding="ascii") as fh:
            return int(fh.read().split()[0]) / 1e9
    except (OSError, ValueError, IndexError):
        return -1.0


_GUARD = _Guard()
