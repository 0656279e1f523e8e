"""Clock offset and drift from NTP-style exchanges: pure arithmetic, no clock, no I/O.

One exchange is four clock readings::

    conductor  t0 ──request──▶            ◀──reply── t3      (conductor's clock)
    relay                   t1 ... t2                        (relay's clock)

With ``offset = relay clock - conductor clock`` and one-way delays ``up, down >= 0``:
``t1 - t0 = offset + up`` and ``t2 - t3 = offset - down``, so whatever the delays (symmetric
or not) the true offset lies in ``[t2 - t3, t1 - t0]``, an interval as wide as the round trip
``(t3 - t0) - (t2 - t1)``. The classic estimate is its midpoint, whose error is at most half the
round trip. :func:`estimate_offset` intersects the intervals of many exchanges (the lowest
round trip dominates, a fast reply in one direction tightens one side), so its bound is never
wider than half the lowest round trip and is a hard bound, not a standard deviation: it holds
unless the clocks themselves step or run apart faster than ``max_rate``.

Clocks also run at slightly different rates (tens of ppm). :class:`DriftFit` keeps a window of
offset estimates over time and fits the rate by weighted least squares; it bounds the rate
from pairs of estimates far apart in time and gives a :class:`Timebase`: offset at a reference
time, rate, and how far either can be off.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = [
    "MAX_RATE",
    "RESOLUTION",
    "DriftFit",
    "Exchange",
    "OffsetEstimate",
    "Timebase",
    "estimate_offset",
]

#: The largest rate difference between two host clocks the bounds allow for (500 ppm). Quartz
#: oscillators are specified to tens of ppm; a larger difference means a clock is being stepped.
MAX_RATE = 500e-6

#: What one clock reading can be off by on its own: Linux's monotonic clock counts nanoseconds,
#: and a float holding some days of seconds rounds to a tenth of one.
RESOLUTION = 1e-9


@dataclass(frozen=True, slots=True)
class Exchange:
    """One request/reply: ``t0``/``t3`` on the conductor's clock, ``t1``/``t2`` on the relay's."""

    t0: float
    t1: float
    t2: float
    t3: float

    @property
    def rtt(self) -> float:
        """Round trip spent on the network (the relay's own time between t1 and t2 excluded)."""
        return (self.t3 - self.t0) - (self.t2 - self.t1)

    @property
    def low(self) -> float:
        """The smallest offset this exchange allows (the reply took no time at all)."""
        return self.t2 - self.t3

    @property
    def high(self) -> float:
        """The largest offset this exchange allows (the request took no time at all)."""
        return self.t1 - self.t0

    @property
    def at(self) -> float:
        """Conductor time in the middle of the exchange."""
        return (self.t0 + self.t3) / 2

    @property
    def valid(self) -> bool:
        """Readings in order (a clock that went backwards or a garbled reply is not).

        A relay clock running fast can make the round trip of an instant network a hair
        negative (it counts its own work a little longer); up to :data:`MAX_RATE` of it is fine.
        """
        return (
            self.t3 >= self.t0
            and self.t2 >= self.t1
            and self.rtt >= -MAX_RATE * (self.t2 - self.t1) - 4 * RESOLUTION
        )


@dataclass(frozen=True, slots=True)
class OffsetEstimate:
    """The relay's clock minus the conductor's at conductor time ``at``, within ``bound``.

    ``rtt`` is the lowest round trip seen, ``samples`` the exchanges used. ``consistent`` is
    False when the exchanges' intervals did not overlap (a clock stepped or ran apart faster
    than :data:`MAX_RATE`); the estimate then falls back on the lowest round trip alone.
    """

    offset: float
    bound: float
    rtt: float
    at: float
    samples: int
    consistent: bool = True

    @property
    def low(self) -> float:
        return self.offset - self.bound

    @property
    def high(self) -> float:
        return self.offset + self.bound


def estimate_offset(exchanges: Iterable[Exchange], *, max_rate: float = MAX_RATE) -> OffsetEstimate:
    """The offset the exchanges agree on, referred to the lowest round trip's time.

    Each interval ``[low, high]`` is widened by what drift at ``max_rate`` can add between its
    exchange and the reference time (microseconds over a burst), then all are intersected.
    Raises ValueError when no exchange is valid.
    """
    valid = [x for x in exchanges if x.valid]
    if not valid:
        raise ValueError("no valid time-sync exchange (no reply, or clock readings out of order)")
    best = min(valid, key=lambda x: x.rtt)
    ref = best.at
    low, high = -math.inf, math.inf
    for x in valid:
        slack = max_rate * (abs(x.at - ref) + (x.t3 - x.t0)) + 2 * RESOLUTION
        low = max(low, x.low - slack)
        high = min(high, x.high + slack)
    if low <= high:
        return OffsetEstimate((low + high) / 2, (high - low) / 2, best.rtt, ref, len(valid))
    bound = max(best.rtt, 0.0) / 2 + max_rate * (best.t3 - best.t0) + 2 * RESOLUTION
    return OffsetEstimate((best.low + best.high) / 2, bound, best.rtt, ref, len(valid), False)


@dataclass(frozen=True, slots=True)
class Timebase:
    """How a relay's clock maps to the conductor's: ``relay = c + offset + rate * (c - ref)``.

    ``offset`` (seconds) holds at conductor time ``ref``; ``rate`` is the relay clock's rate
    error (1e-6: one ppm fast). ``bound`` and ``rate_bound`` are how far each can be off, so the
    offset at conductor time ``c`` is known to within :meth:`bound_at`.
    """

    offset: float
    rate: float = 0.0
    ref: float = 0.0
    bound: float = math.inf
    rate_bound: float = MAX_RATE

    def to_relay(self, conductor_time: float) -> float:
        """The relay clock's reading at ``conductor_time``."""
        return conductor_time + self.offset + self.rate * (conductor_time - self.ref)

    def to_conductor(self, relay_time: float) -> float:
        """The conductor's time when the relay clock reads ``relay_time``."""
        return self.ref + (relay_time - self.ref - self.offset) / (1.0 + self.rate)

    def bound_at(self, conductor_time: float) -> float:
        """How far :meth:`to_relay` can be off at ``conductor_time``."""
        return self.bound + self.rate_bound * abs(conductor_time - self.ref)


class DriftFit:
    """Offset and rate from offset estimates over time (a sliding window of ``window``).

    The rate is a weighted least-squares slope (weights ``1 / bound**2``), kept inside the
    interval that pairs of estimates far apart in time allow; the offset at the newest estimate
    is the fitted line's value there, kept inside the interval every estimate allows once
    carried forward at a rate in that interval. Both bounds hold as long as the rate stays
    constant over the window; when the estimates contradict each other (a clock stepped) the
    window restarts from the newest estimate.
    """

    def __init__(self, *, window: int = 120, max_rate: float = MAX_RATE) -> None:
        if window < 2:
            raise ValueError("the drift window needs at least two estimates")
        self.max_rate = max_rate
        self._points: deque[OffsetEstimate] = deque(maxlen=window)

    def __len__(self) -> int:
        return len(self._points)

    def add(self, estimate: OffsetEstimate) -> Timebase:
        """Take one more estimate (newer than the last) and return the timebase now."""
        if self._points and estimate.at <= self._points[-1].at:
            raise ValueError("offset estimates must come in time order")
        self._points.append(estimate)
        timebase = _fit(list(self._points), self.max_rate)
        if timebase is None:  # contradiction: start again from what was just measured
            self._points.clear()
            self._points.append(estimate)
            timebase = _fit([estimate], self.max_rate)
            assert timebase is not None
        return timebase


def _fit(points: Sequence[OffsetEstimate], max_rate: float) -> Timebase | None:
    newest = points[-1]
    if len(points) == 1:
        return Timebase(newest.offset, 0.0, newest.at, newest.bound, max_rate)
    rate_low, rate_high = _rate_interval(points, max_rate)
    if rate_low > rate_high:
        return None
    slope, intercept_at_newest = _least_squares(points, newest.at)
    rate = min(max(slope, rate_low), rate_high)
    low, high = -math.inf, math.inf
    for p in points:
        dt = newest.at - p.at  # >= 0
        low = max(low, p.low + min(rate_low * dt, rate_high * dt))
        high = min(high, p.high + max(rate_low * dt, rate_high * dt))
    if low > high:
        return None
    offset = min(max(intercept_at_newest, low), high)
    bound = max(offset - low, high - offset)
    rate_bound = max(rate - rate_low, rate_high - rate)
    return Timebase(offset, rate, newest.at, bound, rate_bound)


def _rate_interval(points: Sequence[OffsetEstimate], max_rate: float) -> tuple[float, float]:
    """Rates every pair (k-th oldest, k-th newest) allows, intersected with +-max_rate."""
    low, high = -max_rate, max_rate
    n = len(points)
    for k in range(n // 2):
        first, last = points[k], points[n - 1 - k]
        span = last.at - first.at
        if span <= 0:
            continue
        low = max(low, (last.low - first.high) / span)
        high = min(high, (last.high - first.low) / span)
    return low, high


def _least_squares(points: Sequence[OffsetEstimate], at: float) -> tuple[float, float]:
    """Weighted slope and the fitted value at ``at`` (times taken relative to ``at``)."""
    sw = sx = sy = sxx = sxy = 0.0
    for p in points:
        w = 1.0 / max(p.bound, 1e-9) ** 2
        x = p.at - at
        sw += w
        sx += w * x
        sy += w * p.offset
        sxx += w * x * x
        sxy += w * x * p.offset
    det = sw * sxx - sx * sx
    if det <= 0 or not math.isfinite(det):
        return 0.0, sy / sw
    slope = (sw * sxy - sx * sy) / det
    return slope, (sy - slope * sx) / sw
