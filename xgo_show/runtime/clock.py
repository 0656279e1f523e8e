"""Clocks for the runtime: one monotonic time base, deadlines, interruptible waits.

Every deadline the runtime waits for is ``start + offset`` from one monotonic start, never
``previous + interval``, so sleep errors never add up. :class:`MonotonicClock` sleeps until a
little before a deadline and then spins, which hits the deadline to some microseconds on an
idle machine. In a real-time (SCHED_FIFO) thread the wait blocks in the kernel to
:data:`EARLY` (0.2 ms) before the deadline and runs out only that on its CPU (such a thread
runs as soon as its timer fires, but the wake-up itself takes it tens of microseconds), and
the thread calls :func:`hand_off_cpu` after each write. :class:`FakeClock` jumps straight to
each deadline, so tests and ``dry-run --fast`` run schedules without waiting.

Waits take an optional :class:`threading.Event`: setting it wakes the waiter at once (the way a
stop request cuts a wait short), and ``sleep_until`` then returns ``False``.
"""

from __future__ import annotations

import ctypes
import os
import sys
import threading
import time
from typing import Protocol

__all__ = [
    "EARLY",
    "HANDOFF",
    "Clock",
    "FakeClock",
    "MonotonicClock",
    "hand_off_cpu",
    "is_realtime",
    "tighten_timer_slack",
]

_PR_SET_TIMERSLACK = 29


class Clock(Protocol):
    """A monotonic time source with interruptible absolute waits."""

    def now(self) -> float:
        """Monotonic seconds (the same time base as :func:`time.monotonic`)."""
        ...

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        """Wait until ``now() >= deadline``; return False early if ``interrupt`` gets set."""
        ...


class MonotonicClock:
    """The real clock: ``time.monotonic`` with sleep-then-spin waits.

    A wait sleeps until ``margin`` before the deadline (a loaded machine wakes sleepers a
    millisecond or so late), then takes short sleeps that aim ``aim`` before it (a sleeper
    wakes ~0.1 ms late), and spins only the last ``spin``. Spinning longer would be more exact
    on an idle machine but, on a busy one, a spinning thread is the first to lose its CPU to
    another process for a whole time slice; short sleeps keep the thread a "sleeper" that the
    scheduler runs as soon as it wakes. A real-time thread only sleeps (see
    :func:`_block_until`).

    On Linux ``time.monotonic`` is ``CLOCK_MONOTONIC``, shared by every process on the machine,
    which lets a simulator in another process timestamp what it receives on the same base.
    """

    def __init__(
        self, *, margin: float = 0.0015, aim: float = 0.00012, spin: float = 0.0002
    ) -> None:
        self.margin = margin
        self.aim = aim
        self.spin = spin

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        if is_realtime():
            return _block_until(deadline, interrupt)
        now = time.monotonic
        spin = self.spin
        while True:
            left = deadline - now()
            if left <= spin:
                break
            nap = left - self.margin if left > self.margin + spin else left - self.aim
            if interrupt is None:
                time.sleep(nap)
            elif interrupt.wait(nap):
                return False
        while now() < deadline:
            if interrupt is not None and interrupt.is_set():
                return False
            time.sleep(0)  # release the GIL so other writer threads keep their deadlines
        return not (interrupt is not None and interrupt.is_set())


def _block_until(deadline: float, interrupt: threading.Event | None) -> bool:
    """A real-time thread's wait: blocked in the kernel until :data:`EARLY` before the
    deadline, then on its CPU for the rest (at most :data:`EARLY`, holding Python's lock).

    A SCHED_FIFO thread that spins keeps every normal thread (the kernel worker that moves
    its bytes included) off its CPU, so it blocks for all but the last :data:`EARLY`: waking
    from the kernel takes it some tens of microseconds, more from an idle CPU. It keeps
    Python's lock through the last part, so the frames of other writers due at the same
    instant are written by it (:class:`~xgo_show.runtime.executor.IssueGroup`) rather than
    each waiting for the lock in turn.
    """
    now = time.monotonic
    early = EARLY
    while (left := deadline - now()) > early:
        if interrupt is None:
            time.sleep(left - early)
        elif interrupt.wait(left - early):
            return False
        if _TIMEOUTS_ON_MONOTONIC and not early:
            return True  # a timed wait that ran out ended past the deadline: no second read
    if interrupt is None:
        while now() < deadline:
            pass
        return True
    while now() < deadline:
        if interrupt.is_set():
            return False
    return not interrupt.is_set()


def _timeouts_on_monotonic() -> bool:
    """Whether CPython's timed waits (time.sleep, and a lock's acquire under Event.wait),
    which round the timeout up, wait on CLOCK_MONOTONIC, the clock time.monotonic reads: on
    Linux with glibc 2.30 or later (sem_clockwait). Then one that ran out ended past its
    deadline, and the writer's wait needs no clock read to confirm it (a read per frame
    fewer). Elsewhere (musl, an older glibc, other systems) the loop above checks."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        name, _, version = (os.confstr("CS_GNU_LIBC_VERSION") or "").partition(" ")
        major, minor = (int(part) for part in version.split(".")[:2])
    except (ValueError, OSError):
        return False  # not glibc, or a version this cannot read: check with the clock
    return name == "glibc" and (major, minor) >= (2, 30)


_TIMEOUTS_ON_MONOTONIC = _timeouts_on_monotonic()


#: Seconds a real-time thread sleeps after a write (see :func:`hand_off_cpu`).
HANDOFF = 50e-6

#: Seconds before its deadline a real-time thread's wait stops blocking and runs out the
#: rest on its CPU (see :func:`_block_until`). Waking from the kernel took a SCHED_FIFO
#: thread 0.05 ms (p50) to 0.11 ms (p99) past its timer on this 2-CPU VM, 0.2-1.6 ms at
#: p99.9, more from a CPU that had halted; finishing on the CPU it is 0.00 / 0.01 / 0.17 ms
#: (docs/realtime.md). It costs the writer up to this much CPU a wait: 1 % of a CPU at 50
#: frames/s. Only ``benchmarks/runtime_timing.py --suspects`` changes it (0: the wait as it
#: was, for its before row).
EARLY = 0.0002


def is_realtime() -> bool:
    """Whether the calling thread runs under SCHED_FIFO or SCHED_RR."""
    try:
        return os.sched_getscheduler(0) in (os.SCHED_FIFO, os.SCHED_RR)
    except (AttributeError, OSError):
        return False


def hand_off_cpu() -> None:
    """After a write: a real-time thread gives its CPU away for :data:`HANDOFF` seconds.

    The bytes of a write to a pseudo-terminal (and every byte received, on any port) are moved
    by a kernel worker thread of normal priority. A SCHED_FIFO thread that goes on running
    after its write keeps that worker off its CPU, and the bytes arrive late (measured on ptys:
    a few tenths of a ms more at the 99th percentile). A USB serial adapter's write needs no
    worker, so there the hand-off only costs the writer 50 us it has to spare. Does nothing
    for threads of normal priority, which the scheduler preempts for the worker anyway.
    """
    if is_realtime():
        time.sleep(HANDOFF)


def tighten_timer_slack() -> bool:
    """Ask Linux to wake this thread's sleeps on time (timer slack 1 ns instead of 50 us).

    Best effort: returns whether it was set.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


class FakeClock:
    """A clock for tests: ``sleep_until`` jumps time forward instead of waiting.

    Thread-safe; time never goes backwards. ``advance`` moves it by hand (e.g. to make a frame
    late). With ``keep_waits`` every wait is recorded in ``waits`` so tests can check the
    deadlines asked for (off for ``dry-run --fast``: the list would grow with the show).
    """

    def __init__(self, start: float = 1000.0, *, keep_waits: bool = True) -> None:
        self._now = start
        self._lock = threading.Lock()
        self.keep_waits = keep_waits
        self.waits: list[float] = []

    def fork(self) -> FakeClock:
        """An independent fake clock at the same time (one per writer thread: one writer
        jumping ahead must not make the others late)."""
        return FakeClock(self.now(), keep_waits=self.keep_waits)

    def now(self) -> float:
        with self._lock:
            return self._now

    def advance(self, seconds: float) -> None:
        """Move time forward by ``seconds``."""
        with self._lock:
            self._now += seconds

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        if interrupt is not None and interrupt.is_set():
            return False
        with self._lock:
            if self.keep_waits:
                self.waits.append(deadline)
            self._now = max(self._now, deadline)
        return True
