"""Test-only hooks that let one machine behave like several: a wrong clock and a slow network.

All hosts of a test share this machine's clock and loopback, so without help the time-sync
estimator would only ever see an offset of zero and a round trip of a few microseconds. Two
environment variables, read by the relay process, change that; nothing reads them in a show:

- ``XGO_SHOW_TEST_CLOCK="offset=12.5,ppm=-80"``: the relay's clock reads 12.5 s ahead of this
  machine's monotonic clock and runs 80 ppm slow (:class:`SkewedClock`).
- ``XGO_SHOW_TEST_SYNC_DELAY="mean=0.005,jitter=0.002,seed=1"``: every time-sync reply waits a
  uniformly random 3-7 ms after the relay stamped it, a one-way (so asymmetric) network delay
  (:class:`DelayInjector`; ``tc netem`` is not available in this kernel).
- ``XGO_SHOW_TEST_TRACE=1``: the relay's run log gets a ``first_frame`` record per robot and
  show (:class:`StartTracer`): the first frame's planned and actual write time on the show
  clock and on this machine's own monotonic clock, which the simulators share, so a benchmark
  can split a start's skew into the clock estimate's error, the relay's lateness and delivery;
  and, when the show ends, a ``frames_host`` record with the same two times of every scheduled
  frame, so the skew late in a long show splits the same way.
"""

from __future__ import annotations

import os
import random
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from xgo_show.runtime.clock import Clock, MonotonicClock
from xgo_show.runtime.events import EventBus, FrameSent, ShowEnded, ShowStarted, Subscription

__all__ = [
    "CLOCK_ENV",
    "DELAY_ENV",
    "TRACE_ENV",
    "DelayInjector",
    "SkewedClock",
    "StartTracer",
    "clock_from_env",
    "delay_from_env",
    "host_time",
    "trace_from_env",
]

CLOCK_ENV = "XGO_SHOW_TEST_CLOCK"
DELAY_ENV = "XGO_SHOW_TEST_SYNC_DELAY"
TRACE_ENV = "XGO_SHOW_TEST_TRACE"


class SkewedClock:
    """A clock ``offset`` seconds off ``base`` and running ``ppm`` parts per million fast.

    ``now() = base.now() + offset + (base.now() - anchor) * ppm * 1e-6``, with ``anchor`` the
    base time when it was made, so ``offset`` is the offset at creation.
    """

    def __init__(self, base: Clock, *, offset: float = 0.0, ppm: float = 0.0) -> None:
        if abs(ppm) >= 10_000:
            raise ValueError("a test clock's rate error must be under 10,000 ppm")
        self.base = base
        self.offset = offset
        self.ppm = ppm
        self._rate = ppm * 1e-6
        self._anchor = base.now()

    def now(self) -> float:
        b = self.base.now()
        return b + self.offset + (b - self._anchor) * self._rate

    def to_base(self, t: float) -> float:
        """The base clock's reading when this clock reads ``t``."""
        return self._anchor + (t - self.offset - self._anchor) / (1.0 + self._rate)

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        return self.base.sleep_until(self.to_base(deadline), interrupt)


@dataclass
class DelayInjector:
    """Delays of ``mean`` +- ``jitter`` seconds (uniform), reproducible with ``seed``."""

    mean: float
    jitter: float = 0.0
    seed: int | None = None
    _random: random.Random = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.mean < 0 or self.jitter < 0 or self.jitter > self.mean:
            raise ValueError("an injected delay needs 0 <= jitter <= mean")
        self._random = random.Random(self.seed)

    def draw(self) -> float:
        """One delay in seconds."""
        return self.mean + self._random.uniform(-self.jitter, self.jitter)

    def wait(self) -> float:
        """Sleep one drawn delay; return it."""
        delay = self.draw()
        time.sleep(delay)
        return delay


def _fields(name: str, text: str, allowed: tuple[str, ...]) -> dict[str, float]:
    values: dict[str, float] = {}
    for part in text.split(","):
        key, sep, value = part.partition("=")
        key = key.strip()
        if not sep or key not in allowed:
            raise ValueError(f"{name}={text!r}: expected {', '.join(k + '=N' for k in allowed)}")
        try:
            values[key] = float(value)
        except ValueError:
            raise ValueError(f"{name}={text!r}: {key} is not a number") from None
    return values


def clock_from_env(env: Mapping[str, str] | None = None, base: Clock | None = None) -> Clock:
    """The relay's base clock: ``base`` (the monotonic clock), skewed if the test asked."""
    env = os.environ if env is None else env
    base = MonotonicClock() if base is None else base
    text = env.get(CLOCK_ENV, "").strip()
    if not text:
        return base
    values = _fields(CLOCK_ENV, text, ("offset", "ppm"))
    return SkewedClock(base, offset=values.get("offset", 0.0), ppm=values.get("ppm", 0.0))


def delay_from_env(env: Mapping[str, str] | None = None) -> DelayInjector | None:
    """The delay to inject on time-sync replies, if the test asked for one."""
    env = os.environ if env is None else env
    text = env.get(DELAY_ENV, "").strip()
    if not text:
        return None
    values = _fields(DELAY_ENV, text, ("mean", "jitter", "seed"))
    seed = values.get("seed")
    return DelayInjector(
        values.get("mean", 0.0), values.get("jitter", 0.0), None if seed is None else int(seed)
    )


def trace_from_env(env: Mapping[str, str] | None = None) -> bool:
    """Whether the test asked for :class:`StartTracer` records."""
    env = os.environ if env is None else env
    return env.get(TRACE_ENV, "").strip() not in ("", "0")


def host_time(clock: Clock, t: float) -> float:
    """This machine's monotonic time at which ``clock`` reads ``t``.

    Walks down the chain of clocks that say how they map onto their base (a relay's
    :class:`~xgo_show.net.slew.SlewingClock` onto a :class:`SkewedClock` onto the real clock).
    """
    while True:
        to_base = getattr(clock, "to_base", None)
        base = getattr(clock, "base", None)
        if to_base is None or base is None:
            return t
        t = to_base(t)
        clock = base


class StartTracer:
    """Records each robot's scheduled frames of each show on ``log(event, **fields)``.

    Every scheduled frame's planned and actual write time is kept with the mapping the frame
    was timed by (a :class:`~xgo_show.net.slew.SlewingClock`'s :meth:`mapping`, a value) and
    converted to this machine's monotonic clock (:func:`host_time`) when the show ends: the
    writer calls this listener right after its write, when the robot's end needs the CPU, so
    it only appends a row there (2 us, against 15 us for converting it then), and nothing is
    logged until the show ends. Then, per robot, a
    ``first_frame`` record: ``planned``/``actual`` on ``clock`` (the relay's show clock),
    ``planned_host``/``actual_host`` the same instants on the host clock and ``start_host``
    the start; and one ``frames_host`` record: ``start_host`` and, per robot,
    ``[index, planned_host, actual_host, seen_host]`` rows. ``seen_host`` is when this listener
    saw the frame: what the writer thread did between its write and then (its CPU hand-off and
    the listeners subscribed before this one).
    """

    def __init__(
        self, bus: EventBus, clock: Clock, log: Callable[..., object]
    ) -> None:
        self.clock = clock
        # A slewing clock's mapping changes during a show: keep the one in force with each
        # frame; any other clock here (fixed rate and offset) converts the same at any time.
        self._mapping: Callable[[], Any] | None = getattr(clock, "mapping", None)
        self._log = log
        self._lock = threading.Lock()
        self._start: float | None = None
        self._start_host: float | None = None
        self._first: dict[str, tuple[float, float]] = {}  # show-clock planned, actual
        # per robot: (index, planned, actual, seen on the show clock, the mapping in force)
        self._frames: dict[str, list[tuple[int, float, float, float, Any]]] = {}
        self._sub: Subscription = bus.subscribe(
            self._on_event, ShowStarted, FrameSent, ShowEnded
        )

    def _on_event(self, ev: object) -> None:
        if isinstance(ev, ShowStarted):
            with self._lock:
                self._start = ev.start_at
                self._start_host = host_time(self.clock, ev.start_at)
                self._first = {}
                self._frames = {p: [] for p in ev.performers}
            return
        if isinstance(ev, ShowEnded):
            self._flush()
            return
        if not isinstance(ev, FrameSent) or ev.kind != "frame" or ev.planned is None:
            return
        seen = self.clock.now()
        mapping = None if self._mapping is None else self._mapping()
        with self._lock:
            rows = self._frames.get(ev.performer)
            if rows is None:
                return
            if not rows:
                self._first[ev.performer] = (ev.planned, ev.t)
            index = -1 if ev.index is None else ev.index
            rows.append((index, ev.planned, ev.t, seen, mapping))

    def _host(self, t: float, mapping: Any) -> float:
        """Show-clock time ``t`` on the host clock, by the mapping in force when it was kept."""
        if mapping is None:
            return host_time(self.clock, t)
        return host_time(getattr(self.clock, "base", self.clock), mapping.base_time(t))

    def _flush(self) -> None:
        with self._lock:
            kept, self._frames = self._frames, {}
            first, self._first = self._first, {}
            start, start_host = self._start, self._start_host
        if start is None or start_host is None:
            return
        frames = {
            performer: [
                (index, self._host(p, m), self._host(a, m), self._host(s, m))
                for index, p, a, s, m in rows
            ]
            for performer, rows in kept.items()
        }
        for performer, (planned, actual) in first.items():
            row = frames[performer][0]
            self._log(
                "first_frame",
                performer=performer,
                start_at=start,
                planned=planned,
                actual=actual,
                start_host=start_host,
                planned_host=row[1],
                actual_host=row[2],
                seen_host=row[3],
            )
        if any(frames.values()):
            self._log("frames_host", start_host=start_host, frames=frames)

    def close(self) -> None:
        self._sub.close()
