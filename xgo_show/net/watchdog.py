"""A watchdog: notices when a peer has not been heard for ``timeout`` seconds, on time.

Zenoh's liveliness notices a killed process at once but a frozen one (SIGSTOP, a hung host, a
pulled cable: the TCP socket stays open) only when its lease ends, 10 s by default. So both
ends of a relay link send heartbeats and each runs a :class:`Watchdog` fed by what it hears:
the relay hears the conductor's heartbeat queries, the conductor hears their replies.

The watchdog's thread sleeps until exactly ``last heard + timeout`` (no polling interval is
added to the detection time) and, if nothing was heard meanwhile, calls ``on_silence(silence)``
once. If the peer is heard again afterwards, ``on_back(gap)`` says so (a frozen peer that is
thawed) and the watchdog arms again; what to do about a peer that comes back is the caller's
business (a relay does not restart a show it stopped). The clock is injected, so tests run it
on a :class:`~xgo_show.runtime.clock.FakeClock`; the decision itself, :meth:`Watchdog.check`,
is a pure function of the times given.

It judges the peer's silence, not its own host's. A watchdog thread that wakes more than
:data:`LATE` after its deadline was starved of CPU (a host busy with other work, a process at
nice 19): the peer's messages of that time may be sitting unread in this process's own socket
buffers, held up by the same starvation. So it first gives this process a grace period
(:data:`GRACE` or as long as it was late, at most the timeout) to read them, and declares the
peer lost only if nothing was heard by the end of a grace it woke from on time. Measured: 16
relays at nice 19 on a loaded 2-CPU machine tripped their watchdog (1 start in 5 failed) while
their conductor kept sending; a really silent peer is noticed at most the grace later.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from xgo_show.runtime.clock import Clock, MonotonicClock

__all__ = ["DEFAULT_TIMEOUT", "GRACE", "LATE", "Watchdog"]

#: Seconds of silence after which a peer is lost (the issue's 500 ms default).
DEFAULT_TIMEOUT = 0.5
#: A wake-up later than this after its deadline means this host starved the watchdog (a sleeper
#: wakes about 0.1 ms late on an idle machine, a few ms on a busy one).
LATE = 0.02
#: The shortest grace a starved watchdog gives its process to read what arrived meanwhile.
GRACE = 0.05


class Watchdog:
    """Calls ``on_silence(seconds)`` once when :meth:`heard` was not called for ``timeout``.

    ``on_back(gap)`` is called when a peer declared lost is heard again (``gap``: seconds since
    it was last heard before). Callbacks run on the watchdog's thread (or the caller's, for
    :meth:`heard`'s ``on_back``); they must not block for long.
    """

    def __init__(
        self,
        timeout: float = DEFAULT_TIMEOUT,
        on_silence: Callable[[float], None] | None = None,
        *,
        on_back: Callable[[float], None] | None = None,
        clock: Clock | None = None,
        name: str = "peer",
    ) -> None:
        if not timeout > 0:
            raise ValueError("a watchdog timeout must be positive")
        self.timeout = timeout
        self.on_silence = on_silence
        self.on_back = on_back
        self.clock: Clock = MonotonicClock() if clock is None else clock
        self.name = name
        self._lock = threading.Lock()
        self._last = self.clock.now()
        self._lost = False
        # Wakes the thread: set by stop(), by set_timeout() and by heard() after a loss.
        self._poke = threading.Event()
        self._stopped = False
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ the decision

    @property
    def last_heard(self) -> float:
        with self._lock:
            return self._last

    @property
    def lost(self) -> bool:
        """Whether the peer is silent past the timeout (until heard again)."""
        with self._lock:
            return self._lost

    @property
    def deadline(self) -> float:
        """When the peer is lost unless heard before."""
        with self._lock:
            return self._last + self.timeout

    def heard(self, at: float | None = None) -> None:
        """The peer said something (at clock time ``at``, default now)."""
        now = self.clock.now() if at is None else at
        with self._lock:
            gap = now - self._last
            self._last = max(self._last, now)
            back = self._lost
            self._lost = False
        if back:
            self._poke.set()
            if self.on_back is not None:
                self.on_back(gap)

    def set_timeout(self, timeout: float) -> None:
        """Change the timeout (it counts from the last time the peer was heard)."""
        if not timeout > 0:
            raise ValueError("a watchdog timeout must be positive")
        with self._lock:
            self.timeout = timeout
        self._poke.set()

    def check(self, now: float) -> float | None:
        """At clock time ``now``: the silence if the peer just became lost, else None.

        Returns a value once per loss; the thread calls it, and tests may call it directly.
        """
        with self._lock:
            silence = now - self._last
            if self._lost or silence < self.timeout:
                return None
            self._lost = True
            return silence

    # ------------------------------------------------------------------ the thread

    def start(self, *, grace: float = 0.0) -> Watchdog:
        """Start counting from now (plus ``grace`` for a peer still setting up) on a thread."""
        with self._lock:
            self._last = self.clock.now() + grace
            self._lost = False
        self._thread = threading.Thread(
            target=self._run, name=f"xgo-show watchdog {self.name}", daemon=True
        )
        self._thread.start()
        return self

    def _run(self) -> None:
        grace_until: float | None = None  # after a late wake-up: the end of its grace
        while not self._stopped:
            if self.lost:
                self._poke.wait()
                self._poke.clear()
                continue
            deadline = self.deadline
            target = deadline if grace_until is None else max(deadline, grace_until)
            if not self.clock.sleep_until(target, self._poke):
                self._poke.clear()
                continue
            now = self.clock.now()
            if now < self.deadline:  # heard meanwhile (during a grace, too)
                grace_until = None
                continue
            late = now - target
            if late > LATE:
                # This host starved us: let its other threads read what the peer sent meanwhile
                # before judging the peer (again, if this grace too ends late).
                grace_until = now + min(max(late, GRACE), self.timeout)
                continue
            grace_until = None
            silence = self.check(now)
            if silence is not None and self.on_silence is not None and not self._stopped:
                self.on_silence(silence)

    def stop(self) -> None:
        """Stop watching (no callback after this returns, unless one is running)."""
        self._stopped = True
        self._poke.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(2.0)
        self._thread = None

    def __enter__(self) -> Watchdog:
        return self.start() if self._thread is None else self

    def __exit__(self, *exc: object) -> None:
        self.stop()
