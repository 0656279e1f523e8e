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
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Sequence

from xgo_show.runtime.events import Event, EventBus, Subscription
from xgo_show.runtime.realtime import HELPER_PRIORITY, enter_show_thread, leave_show_thread

__all__ = ["BACKLOG", "DELAY", "IDLE", "DeferredListeners"]

#: Seconds from an event to its listeners: past a frame's delivery (about 1 ms on a busy host),
#: well before the next frame at 20-50 frames a second.
DELAY = 0.004
#: Seconds without an event after which the thread goes back to normal priority.
IDLE = 0.3
#: Events queued at most; beyond, the newest are dropped and counted (a thread starved this long
#: has a host in trouble: the writers, which never wait on it, come first).
BACKLOG = 100_000

Listener = Callable[[Event], object]


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
        self._queue: deque[tuple[float, Event]] = deque()
        self._queued = 0  # events ever queued, and handed on (for flush)
        self._done = 0
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
            self._queue.append((time.monotonic(), event))
            self._queued += 1
            if len(self._queue) == 1:
                self._cond.notify_all()

    def _run(self) -> None:
        raised = False
        try:
            while True:
                with self._cond:
                    while not self._queue and not self._closed:
                        if not self._cond.wait(IDLE if raised else None) and raised:
                            leave_show_thread()  # no show: nothing real-time between shows
                            raised = False
                    if not self._queue:
                        return  # closed and drained
                    oldest = self._queue[0][0]
                    hurry = self._closed or self._queued > self._done + BACKLOG // 2
                if self.realtime and not raised:
                    raised = enter_show_thread(HELPER_PRIORITY)
                wait = oldest + self.delay - time.monotonic()
                if wait > 0 and not hurry:
                    with self._cond:  # flush() and close() wake it to hand on at once
                        self._cond.wait(wait)
                with self._cond:
                    batch = list(self._queue)
                    self._queue.clear()
                for _, event in batch:
                    for listener in self.listeners:
                        try:
                            listener(event)
                        except Exception:  # as on the bus: one broken listener stops nothing
                            self.listener_errors += 1
                with self._cond:
                    self._done += len(batch)
                    self._cond.notify_all()
        finally:
            if raised:
                leave_show_thread()

    def flush(self, timeout: float = 2.0) -> bool:
        """Hand on every event published so far now; False if that took over ``timeout``."""
        deadline = time.monotonic() + timeout
        with self._cond:
            target = self._queued
            self._cond.notify_all()  # cut the thread's wait short
            while self._done < target:
                left = deadline - time.monotonic()
                if left <= 0 or not self._thread.is_alive():
                    return False
                self._cond.notify_all()
                self._cond.wait(min(left, 0.01))
            return True

    def close(self) -> None:
        """Stop taking events, hand on the queued ones, end the thread."""
        self._sub.close()
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(2.0)
