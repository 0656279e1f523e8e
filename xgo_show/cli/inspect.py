"""``xgo-show inspect FILE``: totals per performer, and with ``--frames`` every frame.

FILE is a routine (``.yaml``/``.yml``, compiled on the fly) or a compiled schedule. The
``--frames`` transcript (time, performer, register values, hex bytes) is deterministic, so it
can be kept next to a show and diffed in review.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

from xgo_show.compiler import compile_show, load_schedule
from xgo_show.compiler.report import totals_table, transcript
from xgo_show.compiler.schedule import Schedule

__all__ = ["add_parser", "load_any", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``inspect`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "inspect",
        help="show what a schedule sends: totals, or every frame",
        description=(
            "Print per-performer totals of a routine or compiled schedule: frames, bytes, link "
            "use (wire time / duration), duration and warnings. With --frames, also one line "
            "per frame: time, performer, register values and hex bytes."
        ),
        epilog="example:\n  xgo-show inspect hello.xshow.json --frames",
    )
    parser.add_argument("file", metavar="FILE", help="routine (.yaml) or schedule (.xshow.json)")
    parser.add_argument("--frames", action="store_true", help="list every frame")
    parser.add_argument("--plot", metavar="PNG", help="also draw the schedule into a PNG")
    parser.set_defaults(func=run)


def load_any(path: Path) -> Schedule:
    """A schedule from a routine (compiled now) or from a schedule file (by its content when
    it is JSON with the schedule format tag, whatever its name)."""
    if path.suffix.lower() in (".yaml", ".yml") and not _is_schedule(path):
        from xgo_show.choreo import load_show

        return compile_show(load_show(path))
    return load_schedule(path)


def _is_schedule(path: Path) -> bool:
    try:
        with path.open(encoding="utf-8", errors="replace") as f:
            head = f.read(4096)
    except OSError:
        return False  # the routine loader says what is wrong with the file
    return head.lstrip().startswith("{") and re.search(
        r'"format"\s*:\s*"xgo-show-schedule"', head) is not None


def run(args: argparse.Namespace) -> int:
    schedule = load_any(Path(args.file))
    out = sys.stdout
    out.write(f"{schedule.name}: {len(schedule.performers)} performer(s), "
              f"{schedule.duration:.3f} s at {schedule.control_rate:g} Hz\n")
    out.write(totals_table(schedule))
    for d in schedule.warnings:
        out.write(d.format() + "\n")
    if args.frames:
        out.write(transcript(schedule))
    if args.plot:
        from xgo_show.compiler import plot_schedule

        plot_schedule(schedule, args.plot)
    return 0
