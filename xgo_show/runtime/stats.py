"""What a run sent, per performer, in memory that does not grow with the show's length.

:class:`SendStats` subscribes to :class:`~xgo_show.runtime.events.FrameSent` events and keeps
counts, bytes, the rest frames of the end or of pauses, and the send-time error distribution as
an :class:`ErrorHistogram` (1 µs bins near zero, coarser further out), so a one-hour show costs
the same memory as a one-minute one. The end-of-show report reads it.
"""

from __future__ import annotations

import math
import threading
from array import array
from collections.abc import Sequence
from dataclasses import dataclass

from xgo_show.runtime.events import Event, FrameSent

__all__ = [
    "P99_TARGET_MS",
    "P999_TARGET_MS",
    "ErrorHistogram",
    "ErrorStats",
    "SendStats",
    "error_stats",
    "percentile",
]


def percentile(values: Sequence[float], q: float) -> float:
    """The ``q`` quantile (0..1) of ``values`` by linear interpolation (nan when empty)."""
    if not values:
        return math.nan
    ordered = sorted(values)
    pos = (len(ordered) - 1) * q
    lo = math.floor(pos)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (pos - lo)


# The send-time targets (issue 12): p99 within 0.5 ms and p99.9 within 2 ms of the plan.
P99_TARGET_MS = 0.5
P999_TARGET_MS = 2.0


@dataclass(frozen=True)
class ErrorStats:
    """Send-time error in milliseconds (late is positive)."""

    count: int
    p50: float
    p95: float
    p99: float
    max: float
    p999: float = math.nan

    def format(self) -> str:
        if not self.count:
            return "no frames sent"
        return (
            f"p50 {self.p50:.3f} ms, p95 {self.p95:.3f} ms, p99 {self.p99:.3f} ms, "
            f"p99.9 {self.p999:.3f} ms, max {self.max:.3f} ms"
        )

    def over_target(self) -> str:
        """As send-time errors: "" within the targets, else which percentile is over and by
        what, for the report to flag rather than print plainly."""
        over = [f"{name} {value:.3f} ms > {target:g} ms" for name, value, target in
                (("p99", self.p99, P99_TARGET_MS), ("p99.9", self.p999, P999_TARGET_MS))
                if value > target]
        return f"ABOVE TARGET: {', '.join(over)}" if over else ""


def error_stats(errors_s: Sequence[float]) -> ErrorStats:
    """Statistics of send-time errors given in seconds."""
    ms = [e * 1000.0 for e in errors_s]
    return ErrorStats(
        len(ms),
        percentile(ms, 0.50),
        percentile(ms, 0.95),
        percentile(ms, 0.99),
        max(ms) if ms else math.nan,
        percentile(ms, 0.999),
    )


# Bin edges in microseconds: 1 µs wide from -1 ms to 5 ms, 10 µs to 50 ms, 1 ms to 5 s.
_RANGES = ((-1_000, 5_000, 1), (5_000, 50_000, 10), (50_000, 5_000_000, 1_000))


class ErrorHistogram:
    """Send-time errors in fixed bins: exact count, min and max; quantiles to the bin width."""

    def __init__(self) -> None:
        self._counts = array("q", bytes(8 * sum((hi - lo) // w for lo, hi, w in _RANGES)))
        self._below = 0
        self._above = 0
        self.count = 0
        self.min = math.inf
        self.max = -math.inf

    def add(self, seconds: float) -> None:
        us = seconds * 1e6
        self.count += 1
        self.min = min(self.min, us)
        self.max = max(self.max, us)
        base = 0
        for lo, hi, width in _RANGES:
            if us < lo:
                self._below += 1
                return
            if us < hi:
                self._counts[base + int((us - lo) // width)] += 1
                return
            base += (hi - lo) // width
        self._above += 1

    def quantile_ms(self, q: float) -> float:
        """The ``q`` quantile in ms: the middle of the bin it falls in (exact min/max at 0/1)."""
        if not self.count:
            return math.nan
        rank = q * (self.count - 1)
        if rank < self._below or q <= 0:
            return self.min / 1000
        if q >= 1:  # the exact maximum, not the middle of its bin
            return self.max / 1000
        seen = self._below
        base = 0
        for lo, hi, width in _RANGES:
            n = (hi - lo) // width
            for i in range(n):
                c = self._counts[base + i]
                if c and seen + c > rank:
                    mid = lo + (i + 0.5) * width
                    return min(max(mid, self.min), self.max) / 1000
                seen += c
            base += n
        return self.max / 1000

    def stats(self) -> ErrorStats:
        if not self.count:
            return ErrorStats(0, math.nan, math.nan, math.nan, math.nan)
        q = self.quantile_ms
        return ErrorStats(self.count, q(0.5), q(0.95), q(0.99), self.max / 1000, q(0.999))


class SendStats:
    """Per-performer totals of what went on the wire (a :class:`FrameSent` listener)."""

    def __init__(self) -> None:
        self.frames = 0  # scheduled frames sent
        self.bytes = 0
        self.reads = 0
        self.errors = ErrorHistogram()
        # The rest frames sent (end of show, pauses): distinct labels, and how many rests.
        self.rest_labels: dict[str, None] = {}
        self.rests = 0
        self._first_rest = ""
        self._lock = threading.Lock()

    def on_event(self, event: Event) -> None:
        if not isinstance(event, FrameSent):
            return
        with self._lock:
            self.bytes += len(event.data)
            kind = event.kind
            if kind == "frame":
                self.frames += 1
                if event.planned is not None:
                    self.errors.add(event.t - event.planned)
            elif kind == "read":
                self.reads += 1
            elif kind == "rest":
                label = event.note
                if not self.rest_labels:
                    self._first_rest = label
                if label == self._first_rest:
                    self.rests += 1  # the first frame of the sequence starts each rest
                if len(self.rest_labels) < 32:
                    self.rest_labels.setdefault(label, None)
