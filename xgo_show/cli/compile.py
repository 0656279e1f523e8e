"""``xgo-show compile SHOW.yaml -o OUT.xshow.json``: compile a routine into a schedule file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import xgo_show.choreo as choreo  # its loader is imported on first use
from xgo_show.compiler import compile_show, save_schedule
from xgo_show.compiler.artifact import SCHEDULE_HINT, is_schedule_file
from xgo_show.compiler.report import totals_table
from xgo_show.errors import UsageError

__all__ = ["add_parser", "default_output", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``compile`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "compile",
        help="compile a routine into a paced frame schedule (.xshow.json)",
        description=(
            "Load and check the routine SHOW.yaml, compute its trajectories, convert them to "
            "register frames paced to each robot's serial link, and write the schedule file "
            "(versioned and compact; 'xgo-show inspect --frames' prints it as text). Every "
            "error is listed as file:line:col. Prints per-performer totals (frames, bytes, "
            "link use) unless --quiet."
        ),
        epilog="example:\n  xgo-show compile choreographies/hello_mini.yaml -o hello.xshow.json",
    )
    parser.add_argument("show", metavar="SHOW.yaml", help="routine file")
    parser.add_argument(
        "-o", "--output", metavar="OUT.xshow.json",
        help="schedule file to write (default: SHOW.xshow.json next to the routine)",
    )
    parser.add_argument(
        "--plot", metavar="FILE.png|FILE.html",
        help="also draw the schedule: a PNG, or an interactive HTML timeline (zoom; hover for "
        "each cue and its line)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    parser.set_defaults(func=run, quick_exit=True)


def default_output(show: Path) -> Path:
    """``dance.yaml`` -> ``dance.xshow.json`` in the same folder."""
    name = show.name
    for suffix in (".yaml", ".yml"):
        if name.endswith(suffix):
            name = name[: -len(suffix)]
    return show.with_name(name + ".xshow.json")


def run(args: argparse.Namespace) -> int:
    source = Path(args.show)
    if is_schedule_file(source):
        raise UsageError(f"{source}: {SCHEDULE_HINT}")
    schedule = compile_show(choreo.load_show(source))
    out = Path(args.output) if args.output else default_output(source)
    save_schedule(schedule, out)
    if args.plot:
        from xgo_show.compiler import plot_schedule

        plot_schedule(schedule, args.plot)
    if not args.quiet:
        for d in schedule.warnings:
            print(d.format(), file=sys.stderr)
        sys.stdout.write(totals_table(schedule))
        print(f"wrote {out}")
    return 0
