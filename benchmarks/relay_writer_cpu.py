"""A relayed robot's writer thread: its CPU per frame against a local one's, one relay addition
at a time.

A relay plays its robots with the same executor as a local ``xgo-show run``; what its writer
thread does more is (1) read a slewing clock (:class:`~xgo_show.net.slew.SlewingClock`, the
conductor's time) instead of the monotonic clock, (2) hand every event to the bookkeeping
thread (:class:`~xgo_show.relay.deferred.DeferredListeners`: a queue and a kernel timer armed
per batch; that thread then writes the run log and collects the events for the conductor) and
(3) in the benchmarks only, the test tracer (``XGO_SHOW_TEST_TRACE``). This plays
the same one-robot show in this process under each configuration in turn, round after round
(so every configuration sees the same load), with the writer under SCHED_FIFO as a relay's is,
and reads the writer thread's own CPU time (``time.thread_time``, in the writer, at every
frame) and the bookkeeping thread's: CPU per frame, not wall time, so the load on the machine
moves the figures far less than it moves a delivery. The link is pyserial's ``loop://`` (no
pseudo-terminal, no kernel worker): only the writer's own work is measured.

``--rate`` sets the frames per second: at a show's 20-50 frames/s every frame finds the caches
cold (the machine ran other things between two frames), at 500/s they stay warm; the ratio is
how much a frame's work costs more in a real show than in ``timeit``. Usage (root, or another
way to SCHED_FIFO)::

    python benchmarks/relay_writer_cpu.py [--rounds 8] [--frames 400] [--rate 50] [--rate 500]
"""

from __future__ import annotations

import argparse
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.net.offset import Timebase
from xgo_show.net.slew import SlewingClock
from xgo_show.net.testhooks import StartTracer
from xgo_show.profiles import get_profile
from xgo_show.relay.deferred import DeferredListeners
from xgo_show.relay.forward import EventCollector
from xgo_show.runtime import realtime
from xgo_show.runtime.clock import Clock, MonotonicClock
from xgo_show.runtime.events import Event, EventBus, FrameSent
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.report import percentile
from xgo_show.runtime.runlog import RunLog
from xgo_show.transports import open_transport
from xgo_show.wire.xgo import write_frame

MODEL = "mini"

#: name -> (slewing clock, bookkeeping, tracer, run log file)
CONFIGS: dict[str, tuple[bool, bool, bool, str | None]] = {
    "local (monotonic clock, no bookkeeping)": (False, False, False, None),
    "+ slewing clock": (True, False, False, None),
    "+ bookkeeping hand-off (no run log file)": (False, True, False, None),
    "+ bookkeeping, run log to a file": (False, True, False, os.devnull),
    "+ bookkeeping, run log kept in memory": (False, True, False, ""),
    "+ test tracer": (False, False, True, None),
    "relay as shipped (clock + bookkeeping)": (True, True, False, None),
    "relay in the benchmarks (+ tracer)": (True, True, True, None),
}


def make_schedule(frames: int, rate: float) -> Schedule:
    profile = get_profile(MODEL)
    reg = profile.register("body_z")
    rows = tuple(
        ScheduledFrame(k / rate, write_frame(reg.address, bytes((0x40 + k % 128,)),
                                             write_type=profile.write_type))
        for k in range(frames)
    )
    perf = PerformerSchedule("robot", MODEL, profile.link, rows, end=rows[-1].t + 0.05)
    return Schedule("writer cpu", "-", (perf,), rate)


@dataclass
class Meter:
    """CPU time of the thread that publishes each frame, read in that thread."""

    times: list[float] = field(default_factory=list)

    def on_frame(self, ev: Event) -> None:
        if isinstance(ev, FrameSent) and ev.kind == "frame":
            self.times.append(time.thread_time())

    def per_frame(self) -> float:
        """us of CPU per frame, from the second frame to the last (whole frame cycles)."""
        t = self.times[1:]
        return (t[-1] - t[0]) / (len(t) - 1) * 1e6 if len(t) > 2 else 0.0


def play(config: tuple[bool, bool, bool, str | None], schedule: Schedule
         ) -> tuple[float, float]:
    """Writer and bookkeeping-thread CPU per frame (us) of one play under ``config``."""
    slew, bookkeeping, tracer, path = config
    clock: Clock = MonotonicClock()
    if slew:
        clock = SlewingClock(MonotonicClock())
        clock.follow(Timebase(0.0, 20e-6, time.monotonic(), 1e-4, 1e-6))  # 20 ppm, as a relay
    events = EventBus()
    meter = Meter()
    events.subscribe(meter.on_frame, FrameSent)
    booked_meter = Meter()
    closers: list[Callable[[], object]] = []
    if bookkeeping:
        booked = EventBus()
        booked.subscribe(booked_meter.on_frame, FrameSent)
        deferred = DeferredListeners(events, [booked.publish])
        # as `xgo-show relay` makes it (--log FILE or none); "": records made and kept in
        # memory, as every relay without --log made them before 2026-11-27 (less the keeping)
        log = RunLog(None, keep=True) if path == "" else RunLog(path, keep=False)
        sub = log.attach(booked)
        collector = EventCollector(booked)
        closers += [deferred.close, sub.close, collector.close, log.close]
    if tracer:
        start_tracer = StartTracer(events, clock, lambda event, **fields: None)
        closers.append(start_tracer.close)
    link = open_transport("loop://", baudrate=schedule.performers[0].link.baud)
    link.open()
    try:
        runner = local_runner(schedule, {"robot": link}, clock=clock, events=events,
                              telemetry=False)
        result = runner.run(lead=0.1, handle_signals=False)
        if not result.completed:
            raise SystemExit(f"the show did not complete: {result.reason}")
    finally:
        for close in closers:
            close()
        link.close()
    return meter.per_frame(), booked_meter.per_frame()


class LineCounter:
    """Python lines the writer thread runs per frame, by function: deterministic, whatever
    the load (``--lines``). Counted from the second frame to the last, as :class:`Meter`."""

    def __init__(self) -> None:
        self.counting = False
        self.frames = 0
        self.lines: dict[str, int] = {}

    def on_frame(self, ev: Event) -> None:
        if isinstance(ev, FrameSent) and ev.kind == "frame":
            self.frames += 1
            self.counting = self.frames >= 2
            if self.counting:
                self.counted = self.frames - 1

    def trace(self, frame: Any, event: str, arg: object) -> Any:
        if not threading.current_thread().name.startswith("xgo-show writer"):
            return None
        if self.counting:  # a Python function called (its frame made): counted as "calls"
            self.lines["calls"] = self.lines.get("calls", 0) + 1
        return self._line

    def _line(self, frame: Any, event: str, arg: object) -> Any:
        if event == "line" and self.counting:
            code = frame.f_code
            key = f"{os.path.basename(code.co_filename)}:{code.co_name}"
            self.lines[key] = self.lines.get(key, 0) + 1
        return self._line


def count_lines(config: tuple[bool, bool, bool, str | None], schedule: Schedule
                ) -> dict[str, float]:
    """Python lines per frame the writer thread runs under ``config``, by function."""
    counter = LineCounter()
    original = EventBus.__init__

    def init(bus: EventBus) -> None:  # the counter listens first on the show's bus
        original(bus)
        if not hasattr(count_lines, "bus"):
            count_lines.bus = bus  # type: ignore[attr-defined]
            bus.subscribe(counter.on_frame, FrameSent)

    EventBus.__init__ = init  # type: ignore[method-assign]
    threading.settrace(counter.trace)
    try:
        play(config, schedule)
    finally:
        threading.settrace(None)  # type: ignore[arg-type]
        EventBus.__init__ = original  # type: ignore[method-assign]
        del count_lines.bus  # type: ignore[attr-defined]
    n = max(1, counter.frames - 2)
    return {k: v / n for k, v in counter.lines.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--frames", type=int, default=400)
    parser.add_argument("--rate", type=float, action="append",
                        help="frames per second (repeatable; default 50 and 500)")
    parser.add_argument("--lines", action="store_true",
                        help="instead: the Python lines the writer runs per frame, by function "
                        "(traced: slow, but the same whatever the load), each configuration "
                        "against the local one")
    args = parser.parse_args()
    realtime.configure("required")
    rates = args.rate or [50.0, 500.0]
    if args.lines:
        schedule = make_schedule(args.frames, rates[0])
        base = count_lines(CONFIGS[next(iter(CONFIGS))], schedule)
        calls = base.pop("calls", 0.0)
        print(f"Python lines (and function calls) the writer runs per frame: local "
              f"{sum(base.values()):.1f} ({calls:.1f})")
        for name, config in list(CONFIGS.items())[1:]:
            got = count_lines(config, schedule)
            more = got.pop("calls", 0.0) - calls
            extra = {k: got.get(k, 0.0) - base.get(k, 0.0) for k in set(got) | set(base)}
            print(f"  {name:<42} {sum(got.values()):7.1f} ({sum(extra.values()):+.1f} lines, "
                  f"{more:+.1f} calls):  "
                  + ", ".join(f"{k} {v:+.1f}" for k, v in
                              sorted(extra.items(), key=lambda kv: -abs(kv[1]))
                              if abs(v) >= 0.5))
        return
    print(f"{args.rounds} rounds of {args.frames} frames per configuration and rate, in turn; "
          f"writer SCHED_FIFO {realtime.PRIORITY}; load average {os.getloadavg()[0]:.2f}")
    for rate in rates:
        schedule = make_schedule(args.frames, rate)
        writer: dict[str, list[float]] = {name: [] for name in CONFIGS}
        books: dict[str, list[float]] = {name: [] for name in CONFIGS}
        loads = []
        names = list(CONFIGS)
        for r in range(args.rounds):
            for name in names[r % len(names):] + names[:r % len(names)]:
                w, b = play(CONFIGS[name], schedule)
                writer[name].append(w)
                books[name].append(b)
            loads.append(os.getloadavg()[0])
        print(f"\n{rate:g} frames/s, load average {min(loads):.2f}-{max(loads):.2f}: writer CPU "
              "per frame (us): median and range of the rounds; its difference from local, "
              "round by round (median [min, max]); the bookkeeping thread's CPU per frame")
        base = writer[names[0]]
        for name in names:
            vals = writer[name]
            diffs = sorted(a - b for a, b in zip(vals, base, strict=True))
            text = (f"{percentile(diffs, .5):+6.1f} [{diffs[0]:+6.1f}, {diffs[-1]:+6.1f}]"
                    if name != names[0] else " " * 24)
            kept = [b for b in books[name] if b > 0]
            book = f"{percentile(kept, .5):6.1f}" if kept else "     -"
            print(f"  {name:<42} {percentile(vals, .5):6.1f} ({min(vals):5.1f}-{max(vals):5.1f})"
                  f"  {text}  {book}")


if __name__ == "__main__":
    threading.current_thread().name = "relay_writer_cpu"
    main()
