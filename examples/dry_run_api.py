"""Run a show on simulated robots through the Python API: the launch stages and events.

What ``xgo-show dry-run`` does, written against the runtime's public API: compile the routine,
serve one simulated robot per performer on its own real pseudo-terminal (:class:`SimBench`),
then launch in stages (open the ports, pre-flight, arm, run) with a listener on the event bus
that prints cues as they start and every fault. At the end: the runtime's report and what each
simulated robot received and did.

    python examples/dry_run_api.py [ROUTINE.yaml] [--real-time] [--start SECONDS]

By default the run is fast (a virtual clock: no waiting between frames; every frame still
reaches the robots).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.errors import XgoShowError
from xgo_show.runtime import (
    Event,
    FakeClock,
    FaultRaised,
    FrameSent,
    Launch,
    MonotonicClock,
    format_report,
)
from xgo_show.sim.bench import SimBench, format_summaries

DEFAULT_ROUTINE = (
    Path(__file__).resolve().parent.parent / "choreographies" / "duet_mini_lite_mirror.yaml"
)


def main(path: Path = DEFAULT_ROUTINE, *, real_time: bool = False, start: float = 0.0) -> int:
    """Play ``path`` on simulated robots; 0 if every performer finished its part."""
    schedule = compile_show(load_show(path))
    seen: set[str] = set()

    def on_event(event: Event) -> None:
        # Runs in the writer threads: quick work only. Print each cue when it first plays.
        if isinstance(event, FrameSent) and event.frame is not None:
            origin = event.frame.origin
            cue = origin.cue if origin is not None else ""
            if cue and cue not in seen:
                seen.add(cue)
                print(f"  {event.actual_show:7.2f} s  {cue}", flush=True)
        elif isinstance(event, FaultRaised):
            print(f"  fault on {event.performer}: {event.reason}", flush=True)

    with SimBench(schedule, [p.name for p in schedule.performers]) as sims, Launch(
        schedule,
        sims.urls,
        clock=MonotonicClock() if real_time else FakeClock(),
        telemetry=real_time,  # battery/status polls need real time to be answered
    ) as launch:
        launch.events.subscribe(on_event)
        launch.open()
        print(launch.preflight().table())
        launch.arm()
        print(
            f"playing {schedule.name!r} ({schedule.duration:.1f} s) on "
            f"{', '.join(f'{p.name} ({p.model})' for p in schedule.performers)}"
        )
        result = launch.run(offset=start)
        print(format_report(result))
        sims.settle()
        print(format_summaries(sims.summaries(), fast=not real_time))
    return 0 if result.completed else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "routine",
        nargs="?",
        type=Path,
        default=DEFAULT_ROUTINE,
        help="routine file (default: choreographies/duet_mini_lite_mirror.yaml)",
    )
    parser.add_argument(
        "--real-time", action="store_true", help="wait for every frame's time, as on stage"
    )
    parser.add_argument(
        "--start",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="start mid-show at this show time",
    )
    args = parser.parse_args()
    try:
        sys.exit(main(args.routine, real_time=args.real_time, start=args.start))
    except XgoShowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
