"""Run a show on simulated robots in this process, through the Python API.

What ``xgo-show dry-run`` does over pseudo-terminals, done here with in-process simulators
(``sim:`` transports): load and compile the routine, give every performer its own simulated
robot, play the schedule with :class:`~xgo_show.runtime.ShowRunner` (which safe-stops every
robot on any fault or Ctrl-C), then print the runtime's report and what each simulated robot
received.

    python examples/dry_run_api.py [ROUTINE.yaml] [--real-time] [--start SECONDS]

By default the run is fast (no waiting between frames; every frame still reaches the robots).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show
from xgo_show.errors import XgoShowError
from xgo_show.runtime import ShowProgress, ShowRunner, format_report
from xgo_show.sim import create_robot
from xgo_show.transports.base import Transport
from xgo_show.transports.sim import SimTransport

DEFAULT_ROUTINE = (
    Path(__file__).resolve().parent.parent / "choreographies" / "duet_mini_lite_mirror.yaml"
)


def main(path: Path = DEFAULT_ROUTINE, *, real_time: bool = False, start: float = 0.0) -> int:
    """Play ``path`` on simulated robots; 0 if every performer finished its part."""
    schedule = compile_show(load_show(path))
    # One fresh simulated robot per performer, behind the same interface a serial port has.
    robots = {p.name: SimTransport(create_robot(p.model)) for p in schedule.performers}
    transports: dict[str, Transport] = dict(robots)

    last = [-1]

    def progress(snapshot: ShowProgress) -> None:
        second = int(snapshot.show_time)
        if real_time and second != last[0] and second % 5 == 0:
            last[0] = second
            print(f"  {snapshot.show_time:6.1f} / {snapshot.duration:.1f} s", flush=True)

    with contextlib.ExitStack() as stack:
        for link in transports.values():
            stack.enter_context(link)  # transports are context managers: open now, close after
        runner = ShowRunner(
            schedule,
            transports,
            fast=not real_time,
            telemetry=real_time,  # battery/status polls need real time to be answered
            progress=progress,
        )
        print(
            f"playing {schedule.name!r} ({schedule.duration:.1f} s) on "
            f"{', '.join(f'{p.name} ({p.model})' for p in schedule.performers)}"
        )
        result = runner.run(offset=start)

    print(format_report(result))
    for name, link in robots.items():
        received = link.robot.received
        refused = sum(1 for f in received if not f.accepted)
        print(
            f"{name}: {len(received)} frames received, {refused} refused; "
            f"{_doing(link, real_time=real_time)}"
        )
    return 0 if result.completed else 1


def _doing(link: SimTransport, *, real_time: bool) -> str:
    """What a simulated robot did: preset actions run (XGO) or servo moves (xArm)."""
    snap = link.robot.snapshot()
    if "actions" in snap:
        names = []
        for action in snap["actions"]:
            name = str(action.get("name", action.get("id")))
            # In a fast run every action is "cut" by the next frame; in real time a cut
            # means the routine moved the robot before the action had finished.
            if real_time and action.get("interrupted_by"):
                name += f" (cut by {action['interrupted_by']})"
            names.append(name)
        return f"actions run: {', '.join(names) or 'none'}"
    return f"servo moves: {len(snap.get('moves', []))}"


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
