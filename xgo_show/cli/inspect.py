"""``xgo-show inspect FILE``: totals per performer, and with ``--frames`` every frame.

FILE is a routine (compiled on the fly) or a compiled schedule, told apart as ``run`` does
(:func:`~xgo_show.cli.run.load_schedule_file`). The ``--frames`` transcript (time, performer,
register values, hex bytes) is deterministic, so it can be kept next to a show and diffed in
review.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from xgo_show.choreo.sections import format_sections
from xgo_show.cli.run import load_schedule_file
from xgo_show.compiler.report import totals_table, transcript

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``inspect`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "inspect",
        help="show what a schedule sends: totals, or every frame",
        description=(
            "Print per-performer totals of a routine or compiled schedule: frames, bytes, link "
            "use (wire time / duration), duration and warnings; the show's sections and the "
            "triggers they wait for. With --frames, also one line "
            "per frame: time, performer, register values and hex bytes."
        ),
        epilog="example:\n  xgo-show inspect hello.xshow.json --frames",
    )
    parser.add_argument("file", metavar="FILE", help="routine (.yaml) or schedule (.xshow.json)")
    parser.add_argument("--frames", action="store_true", help="list every frame")
    parser.add_argument(
        "--plot", metavar="FILE.png|FILE.html",
        help="also draw the schedule: a PNG, or an interactive HTML timeline (zoom; hover for "
        "each cue and its line)",
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    schedule = load_schedule_file(args.file)
    out = sys.stdout
    out.write(f"{schedule.name}: {len(schedule.performers)} performer(s), "
              f"{schedule.duration:.3f} s at {schedule.control_rate:g} Hz\n")
    out.write(totals_table(schedule))
    out.write(format_sections(schedule.sections, schedule.tempo(), end=schedule.duration))
    for d in schedule.warnings:
        out.write(d.format() + "\n")
    if args.frames:
        out.write(transcript(schedule))
    if args.plot:
        from xgo_show.compiler import plot_schedule

        plot_schedule(schedule, args.plot)
    return 0
