"""Memory the runtime keeps while a show plays: bounded, whatever the show's length.

Plays a 1-minute and a 60-minute show (four Minis, 50 frames/s each, telemetry off) on virtual
time (every frame still goes through the executor, the event bus, the run log and the report
statistics) into ports that discard the bytes, and measures with tracemalloc what the run
allocated beyond the schedule itself: the peak during the run and what is still held at the
end. Side by side: the same run with a listener that keeps every event, as the runtime did
before the event bus (each send stored in the executor and again in the run log).

    python benchmarks/runtime_memory.py [--minutes 60]
"""

from __future__ import annotations

import argparse
import gc
import os
import tracemalloc

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import EventRecorder
from xgo_show.runtime.launch import local_runner
from xgo_show.runtime.runlog import RunLog
from xgo_show.transports.base import Transport
from xgo_show.wire.xgo import write_frame

ROBOTS = 4
RATE = 50.0


class Discard(Transport):
    """A port that takes every byte and answers nothing (only the runtime is measured)."""

    def __init__(self) -> None:
        super().__init__("discard:")
        self._open = False

    def open(self) -> None:
        self._open = True

    def close(self) -> None:
        self._open = False

    @property
    def is_open(self) -> bool:
        return self._open

    def write(self, data: bytes) -> None:
        pass

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        return b""


def make_schedule(minutes: float) -> Schedule:
    profile = get_profile("mini")
    reg = profile.register("body_z")
    n = int(minutes * 60 * RATE)
    performers = []
    for k in range(ROBOTS):
        frames = tuple(
            ScheduledFrame(i / RATE, write_frame(reg.address, bytes((0x60 + i % 64,))))
            for i in range(n)
        )
        performers.append(
            PerformerSchedule(f"dog{k}", "mini", profile.link, frames, end=n / RATE)
        )
    return Schedule("memory benchmark", "-", tuple(performers), 20.0)


def measure(schedule: Schedule, *, keep_everything: bool) -> tuple[float, float, int]:
    """(peak MiB during the run, MiB still held after it, frames sent)."""
    links: dict[str, Transport] = {p.name: Discard() for p in schedule.performers}
    for link in links.values():
        link.open()
    gc.collect()
    tracemalloc.start()
    with RunLog(os.devnull) as log:
        runner = local_runner(schedule, links, clock=FakeClock(keep_waits=False), telemetry=False)
        log.attach(runner.events)
        keeper = EventRecorder(runner.events) if keep_everything else None
        result = runner.run(handle_signals=False)
        sent = sum(s.frames for s in result.stats.values())
        gc.collect()
        held, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    del keeper
    return peak / 2**20, held / 2**20, sent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=60.0, help="the long show (default 60)")
    args = parser.parse_args()
    print(f"{ROBOTS} Minis, {RATE:g} frames/s each, virtual time; MiB allocated by the run")
    print(f"{'show':>10} {'frames':>9} {'ours peak':>10} {'ours held':>10} "
          f"{'keep-all peak':>14} {'keep-all held':>14}")
    for minutes in (1.0, args.minutes):
        schedule = make_schedule(minutes)
        ours_peak, ours_held, sent = measure(schedule, keep_everything=False)
        all_peak, all_held, _ = measure(schedule, keep_everything=True)
        print(f"{minutes:>7g} min {sent:>9} {ours_peak:>10.2f} {ours_held:>10.2f} "
              f"{all_peak:>14.2f} {all_held:>14.2f}")
    print("target: ours does not grow with the show's length")


if __name__ == "__main__":
    main()
