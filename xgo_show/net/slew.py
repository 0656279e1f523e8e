"""A relay's show clock: its own monotonic clock mapped onto the conductor's timebase.

A relay runs the ordinary executor on a :class:`SlewingClock`. Its ``now()`` is the
conductor's time as this host best knows it, so every time the conductor sends (start, pause,
resume, seek, stop) means the same instant on every host, and the relay's run log reads in the
conductor's time. The mapping comes from :class:`~xgo_show.net.offset.Timebase` estimates the
conductor keeps sending during a show (see :mod:`xgo_show.net.timesync`).

A new estimate is never applied as a jump. The clock keeps running from where it is, at the
new estimate's rate plus or minus ``max_slew`` (500 ppm by default: 10 us over a 20 ms frame),
until it meets the new mapping, and follows it from then on. So ``now()`` is continuous and
strictly increasing, no frame interval changes by more than ``max_slew`` of itself, and a
1 ms correction takes 2 s. Only the first estimate (or the first after :meth:`reset`, which a
relay calls between shows) sets the mapping at once.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

from xgo_show.net.offset import Timebase
from xgo_show.runtime.clock import Clock, MonotonicClock

__all__ = ["DEFAULT_MAX_SLEW", "SlewingClock"]

#: Largest rate change a correction may apply (a fraction: 500e-6 is 500 ppm).
DEFAULT_MAX_SLEW = 500e-6

# A wait longer than this is cut into hops so a correction that arrives meanwhile moves the
# wake-up; the last hop is at most _HOP long, so it can be off by at most _HOP * max_slew
# (25 us). Frame intervals (20 ms at 50 Hz) take one wait.
_HOP = 0.05
_LONG_HOP = 0.25

#: :meth:`SlewingClock.hold_off`: seconds before a writer's deadline from which another thread
#: of the relay holds off running Python, and after it until which it still does (a writer on
#: this shared 2-CPU machine writes up to some tenths of a ms after its deadline)
HOLD_BEFORE = 0.002
HOLD_AFTER = 0.0005
#: ... and the longest it holds off in one call (a relay with many robots due at many times)
HOLD_LONGEST = 0.005


@dataclass(frozen=True, slots=True)
class _Segment:
    """``now = c0 + (b - b0) * slope`` until base time ``b1``, then ``target.to_conductor(b)``.

    ``target``'s numbers are copied into the segment (``ref``, ``offset``, ``rate`` and
    ``div`` = 1 + rate) so a read computes the same as :meth:`Timebase.to_conductor` without
    calling it: a relay's writer reads this clock several times a frame.
    """

    b0: float
    c0: float
    slope: float
    b1: float
    target: Timebase
    ref: float = field(init=False)
    offset: float = field(init=False)
    rate: float = field(init=False)
    div: float = field(init=False)

    def __post_init__(self) -> None:
        t = self.target
        object.__setattr__(self, "ref", t.ref)
        object.__setattr__(self, "offset", t.offset)
        object.__setattr__(self, "rate", t.rate)
        object.__setattr__(self, "div", 1.0 + t.rate)

    def at(self, b: float) -> float:
        if b < self.b1:
            return self.c0 + (b - self.b0) * self.slope
        return self.ref + (b - self.ref - self.offset) / self.div  # target.to_conductor(b)

    def base_time(self, c: float) -> float:
        """The base time at which this segment reads ``c`` (the inverse of :meth:`at`)."""
        if self.b1 > self.b0 and c < self.c0 + (self.b1 - self.b0) * self.slope:
            return self.b0 + (c - self.c0) / self.slope
        return c + self.offset + self.rate * (c - self.ref)  # target.to_relay(c)


_IDENTITY = Timebase(0.0, 0.0, 0.0, 0.0, 0.0)


class SlewingClock:
    """A :class:`~xgo_show.runtime.clock.Clock` reading the conductor's time on a relay.

    ``base`` is this host's clock (the same one the time-sync server stamps replies with).
    Until the first :meth:`follow`, ``now()`` is ``base.now()``. Thread-safe.
    """

    def __init__(self, base: Clock, *, max_slew: float = DEFAULT_MAX_SLEW) -> None:
        if not 0 < max_slew < 0.1:
            raise ValueError("max_slew must be a small positive fraction (e.g. 500e-6)")
        self.base = base
        # The base clock's reading itself: time.monotonic for the real clock, without the call
        # to its now() on every read (the same value).
        self._read = time.monotonic if type(base) is MonotonicClock else base.now
        self.max_slew = max_slew
        self._lock = threading.Lock()
        self._segment = _Segment(0.0, 0.0, 1.0, 0.0, _IDENTITY)
        self._set = False
        #: waiting thread -> the base time it wakes at for its deadline (see hold_off)
        self._due: dict[int, float] = {}

    @property
    def timebase(self) -> Timebase | None:
        """The estimate being followed (None before the first)."""
        with self._lock:
            return self._segment.target if self._set else None

    def now(self) -> float:
        # No lock: the segment is immutable and replaced whole (one attribute read). A writer
        # reads this clock several times per frame, some of them right after its write: its
        # at() inlined here (the same sums).
        seg = self._segment
        b = self._read()
        if b < seg.b1:
            return seg.c0 + (b - seg.b0) * seg.slope
        return seg.ref + (b - seg.ref - seg.offset) / seg.div

    def mapping(self) -> _Segment:
        """The mapping in force now, as a value: its ``base_time(t)`` is :meth:`to_base` as
        things stand now, and stays so (a tracer converts times with it later)."""
        return self._segment

    def error(self) -> float:
        """How far ``now()`` still is from the newest estimate (positive: behind it)."""
        b = self.base.now()
        with self._lock:
            seg = self._segment
        return seg.target.to_conductor(b) - seg.at(b)

    def follow(self, timebase: Timebase) -> float:
        """Slew towards a new estimate (set it at once if none is set); return the correction.

        The correction is how far the new estimate is from ``now()`` (positive: the clock will
        run fast until it has caught up); it takes ``abs(correction) / max_slew`` seconds.
        """
        b = self.base.now()
        with self._lock:
            if not self._set:
                self._segment = _Segment(b, timebase.to_conductor(b), 1.0, b, timebase)
                self._set = True
                return 0.0
            c = self._segment.at(b)
            error = timebase.to_conductor(b) - c
            slope = 1.0 / (1.0 + timebase.rate)
            slew = self.max_slew if error > 0 else -self.max_slew
            duration = abs(error) / self.max_slew
            self._segment = _Segment(b, c, slope + slew, b + duration, timebase)
            return error

    def reset(self) -> None:
        """Forget the mapping (between shows): the next :meth:`follow` sets it at once."""
        b = self.base.now()
        with self._lock:
            c = self._segment.at(b)
            self._segment = _Segment(b, c, 1.0, b, Timebase(b - c, 0.0, 0.0, 0.0, 0.0))
            self._set = False
            self._due.clear()  # the show's writers are gone

    def hold_off(self) -> None:
        """Wait, without Python's lock, while a thread waiting on this clock is due.

        For a thread about to run Python that no writer needs (a Zenoh callback answering a
        heartbeat or a time-sync ping: zenoh-python runs each on a thread of its own): if a
        deadline a thread waits for with :meth:`sleep_until` is less than
        :data:`HOLD_BEFORE` away, or passed less than :data:`HOLD_AFTER` ago, it sleeps until
        :data:`HOLD_AFTER` past it (:data:`HOLD_LONGEST` at most in all). Python's lock knows
        no priorities: a writer that wakes for its frame while such a thread holds it waits
        until that thread lets go, and on a busy host that thread may itself be waiting for a
        CPU meanwhile (traced: a relay's writer waited 0.25-0.4 ms for its own heartbeat or
        time-sync answer in about half of its frames issued 0.35 ms or more late, 4 relays on
        this 2-CPU VM).
        """
        read = self._read
        # Bounded by its own sleeps, not by the base clock's reading: a base that does not move
        # with real time (a fake one) would otherwise keep this thread here for ever.
        left = HOLD_LONGEST
        while left > 0:
            now = read()
            due = [t for t in tuple(self._due.values()) if now - HOLD_AFTER < t < now + HOLD_BEFORE]
            if not due:
                return
            pause = min(max(due) + HOLD_AFTER - now, left)
            time.sleep(pause)
            left -= pause

    def to_base(self, t: float) -> float:
        """The base clock's reading when this clock will read ``t`` (as things stand now)."""
        return self._segment.base_time(t)

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        base = self.base
        while True:
            target = self._segment.base_time(deadline)  # to_base(), one call fewer a frame
            left = target - self._read()
            if left <= _HOP:
                self._due[threading.get_ident()] = target  # for hold_off
                return base.sleep_until(target, interrupt)
            hop = min(target - _HOP / 2, base.now() + _LONG_HOP)
            if not base.sleep_until(hop, interrupt):
                return False
