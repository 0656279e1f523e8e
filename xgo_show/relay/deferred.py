"""A relay's bookkeeping, run after its frames are delivered, not in its writer threads.

An :class:`~xgo_show.runtime.events.EventBus` calls its listeners in the publishing thread: for a
frame, the SCHED_FIFO writer thread, right after its write. On a relay two listeners do real work
there: the run log (a JSON line per frame, and now and then a disk write) and the event collector
that carries events back to the conductor. Measured with ``benchmarks/relay_sync.py`` (its
tracer's ``seen_host``), the writer spent 0.26 ms (p50) on them after each write, at real-time
priority, exactly when the kernel's pty worker and the robot's end (the simulator, or a USB
adapter's driver) need a CPU to deliver the frame: a relayed robot received its frames 0.3-0.5 ms
later than the same robot driven from a local process.

:class:`DeferredListeners` takes those listeners off the writer: the writer only appends the
event to a queue (microseconds), and a thread of the relay's own calls the listeners, in
publishing order, :data:`DELAY` after the oldest queued event, when the frame has long been
delivered and the next one is still far off. That thread runs just below the writers
(:data:`~xgo_show.runtime.realtime.HELPER_PRIORITY`, where real-time scheduling is granted, from
the first event until :data:`IDLE` passes without one), so a busy host's normal processes cannot
preempt it while it holds Python's lock, which a writer waking for its next frame would then
wait for.

The thread is woken by a one-shot kernel timer the writer arms when it queues the first event
(:class:`Alarm`, a Linux ``timerfd``), not by a notification: a notification woke the thread
at once, right after the write, to go back to sleep for the delay, and that real-time wake-up
landed on a CPU while the frame was being delivered (measured with
``benchmarks/delivery_trace.py --relays --sim normal``: in 66 % of a relayed robot's frames,
0.06 ms per frame on average). Arming a timer wakes nobody.
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from xgo_show.runtime.events import Event, EventBus, Subscription
from xgo_show.runtime.realtime import HELPER_PRIORITY, enter_show_thread, leave_show_thread

__all__ = ["BACKLOG", "DELAY", "IDLE", "Alarm", "DeferredListeners"]

#: Seconds from an event to its listeners: past a frame's delivery (about 1 ms on a busy host),
#: well before the next frame at 20-50 frames a second.
DELAY = 0.004
#: Seconds without an event after which the thread goes back to normal priority.
IDLE = 0.3
#: Events queued at most; beyond, the newest are dropped and counted (a thread starved this long
#: has a host in trouble: the writers, which never wait on it, come first).
BACKLOG = 100_000

Listener = Callable[[Event], object]

_CLOCK_MONOTONIC = 1
_TFD_CLOEXEC = 0o2000000


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


class _Itimerspec(ctypes.Structure):
    _fields_ = [("it_interval", _Timespec), ("it_value", _Timespec)]


def _timerfd() -> tuple[int, Callable[..., int]] | None:
    """A Linux timerfd and its ``timerfd_settime``, or None where there is none.

    ``timerfd_settime`` has no ``argtypes``: its arguments are C ints, a pointer and NULL,
    which ctypes passes as they are, and the conversions argtypes would add cost the writer
    that arms it after every write a few microseconds more (16 us a call against 4).
    """
    if not sys.platform.startswith("linux"):
        return None
    try:
        # PyDLL: the call keeps Python's lock, so a writer that arms the timer never hands the
        # lock to another thread it would then wait for.
        libc = ctypes.PyDLL(None, use_errno=True)
        create, settime = libc.timerfd_create, libc.timerfd_settime
    except (OSError, AttributeError):
        return None
    fd = int(create(_CLOCK_MONOTONIC, _TFD_CLOEXEC))
    if fd < 0:
        return None
    return fd, settime


class Alarm:
    """A one-shot timer: one thread :meth:`wait` s for it, any thread :meth:`arm` s it.

    On Linux a ``timerfd``: the kernel fires it at the time set, so arming it wakes nobody (a
    writer arms it right after its write). Elsewhere a condition variable, whose waiter wakes
    to take each new time. Arming again replaces the time set; every arming ends one wait, at
    the latest time set before it fired.
    """

    def __init__(self) -> None:
        self._kernel = _timerfd()
        self._cond = threading.Condition()
        self._at: float | None = None
        #: delay -> its timer setting (the argument): made once, a writer arms the same delay
        #: after every write
        self._specs: dict[float, Any] = {}

    def _spec(self, delay: float) -> Any:
        spec = self._specs.get(delay)
        if spec is None:
            ns = max(1, round(delay * 1e9))  # 0 would disarm it
            value = _Timespec(ns // 1_000_000_000, ns % 1_000_000_000)
            spec = ctypes.pointer(_Itimerspec(_Timespec(0, 0), value))
            if len(self._specs) < 16:
                self._specs[delay] = spec
        return spec

    def arm(self, delay: float) -> None:
        """Fire ``delay`` seconds from now (0: at once)."""
        if self._kernel is not None:
            fd, settime = self._kernel
            if settime(fd, 0, self._spec(delay), None) == 0:
                return
            self.close()  # cannot happen with a valid fd; the portable way from here on
        with self._cond:
            self._at = time.monotonic() + delay
            self._cond.notify_all()

    def prepared(self, delay: float) -> Callable[[], object]:
        """A callable that arms ``delay`` as :meth:`arm` does, made once for a caller that
        arms the same delay after every write: on Linux the system call itself, with its
        arguments bound (no Python line runs). Valid until :meth:`close`: the caller that
        closes the alarm drops it (its fd is given back)."""
        if self._kernel is None:
            return functools.partial(self.arm, delay)
        fd, settime = self._kernel
        return functools.partial(settime, fd, 0, self._spec(delay), None)

    def wait(self) -> None:
        """Until the timer fires."""
        if self._kernel is not None:
            try:
                os.read(self._kernel[0], 8)
                return
            except OSError:
                if self._kernel is not None:
                    raise
        with self._cond:
            while True:
                if self._at is not None:
                    left = self._at - time.monotonic()
                    if left <= 0:
                        self._at = None
                        return
                    self._cond.wait(left)
                else:
                    self._cond.wait()

    def close(self) -> None:
        """Give the timerfd back (the alarm keeps working, the portable way)."""
        kernel, self._kernel = self._kernel, None
        if kernel is not None:
            os.close(kernel[0])


class DeferredListeners:
    """Calls ``listeners`` for every event of ``bus``, on a thread of its own, ``delay`` later.

    :meth:`flush` waits until every event published so far was handed on (a show's end, before
    its result is reported); :meth:`close` flushes, then stops the thread.
    """

    def __init__(
        self,
        bus: EventBus,
        listeners: Sequence[Listener],
        *,
        delay: float = DELAY,
        realtime: bool = True,
        name: str = "xgo-show relay bookkeeping",
    ) -> None:
        self.listeners = tuple(listeners)
        self.delay = delay
        self.realtime = realtime
        self.dropped = 0
        self.listener_errors = 0
        self._cond = threading.Condition()
        self._alarm = Alarm()
        #: arms the alarm for ``delay``: what a writer calls for the first event of a batch
        self._arm_delay = self._alarm.prepared(delay)
        self._queue: deque[Event] = deque()
        self._queued = 0  # events ever queued, and handed on (for flush)
        self._done = 0
        self._last = 0.0  # when the newest event was queued
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()
        self._sub: Subscription = bus.subscribe(self._put)

    def _put(self, event: Event) -> None:
        with self._cond:
            if self._closed:
                return
            if len(self._queue) >= BACKLOG:
                self.dropped += 1
                return
            self._queue.append(event)
            self._queued += 1
            self._last = time.monotonic()
            if len(self._queue) == 1:
                self._arm_delay()  # in the kernel: this wakes nobody now
            elif len(self._queue) == BACKLOG // 2:
                self._alarm.arm(0.0)  # hand on before the queue fills

    def _run(self) -> None:
        raised = False
        try:
            while True:
                self._alarm.wait()
                with self._cond:
                    batch = list(self._queue)
                    self._queue.clear()
                if batch and self.realtime and not raised:
                    raised = enter_show_thread(HELPER_PRIORITY)
                for event in batch:
                    for listener in self.listeners:
                        try:
                            listener(event)
                        except Exception:  # as on the bus: one broken listener stops nothing
                            self.listener_errors += 1
                with self._cond:
                    self._done += len(batch)
                    self._cond.notify_all()
                    if self._queue:
                        continue  # its first event armed the alarm
                    if self._closed:
                        return  # closed and drained
                    if raised:  # no show: nothing real-time between shows
                        quiet = time.monotonic() - self._last
                        if quiet < IDLE:
                            self._alarm.arm(IDLE - quiet)
                            continue
                if raised:
                    leave_show_thread()
                    raised = False
        finally:
            if raised:
                leave_show_thread()
            with self._cond:  # arming happens under this lock: no arming of a closed fd
                self._alarm.close()
                self._arm_delay = self._alarm.prepared(self.delay)  # the portable way now

    def flush(self, timeout: float = 2.0) -> bool:
        """Hand on every event published so far now; False if that took over ``timeout``."""
        deadline = time.monotonic() + timeout
        with self._cond:
            target = self._queued
            if self._done < target:
                self._alarm.arm(0.0)  # cut the thread's wait short
            while self._done < target:
                left = deadline - time.monotonic()
                if left <= 0 or not self._thread.is_alive():
                    return False
                self._cond.wait(min(left, 0.01))
                if self._queue and self._done < target:
                    self._alarm.arm(0.0)  # a writer's arming replaced ours
            return True

    def close(self) -> None:
        """Stop taking events, hand on the queued ones, end the thread."""
        self._sub.close()
        with self._cond:
            self._closed = True
            self._alarm.arm(0.0)
        self._thread.join(2.0)
