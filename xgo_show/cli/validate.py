"""``xgo-show validate FILE...``: check routines and print every problem found.

Each problem is one line, ``file:line:col: error: path: message`` (warnings likewise), then a
summary line per file. Exit status 1 when any file has an error, 0 otherwise (warnings do not
fail). The compiler runs too, so an infeasible trajectory or a schedule that does not fit the
link is reported here, before any robot moves.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, TextIO

import xgo_show.choreo as choreo
from xgo_show.cli.watch import add_watch_option
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.files import file_problem, read_head
from xgo_show.text import printable

__all__ = ["add_parser", "report", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``validate`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "validate",
        help="check routine files and list every problem",
        description=(
            "Load, check and compile each routine FILE and print every problem found as "
            "file:line:col: severity: path: message, then a summary per file. Exits 1 when "
            "any file has an error, 0 otherwise (warnings are shown but do not fail)."
        ),
        epilog="example:\n  xgo-show validate choreographies/*.yaml\n"
        "  xgo-show validate --watch my_routine.yaml     # again on every save",
    )
    parser.add_argument("files", nargs="+", metavar="FILE", help="routine YAML file(s)")
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="print only errors and the summaries"
    )
    add_watch_option(parser, "files")
    parser.set_defaults(func=run, quick_exit=True)


def report(path: str, diags: list[Diagnostic], out: TextIO, *, quiet: bool = False) -> bool:
    """Print ``diags`` for ``path`` and its summary line; True when there is no error."""
    errors = sum(d.count for d in diags if d.is_error)
    warnings = sum(d.count for d in diags) - errors
    for d in diags:
        if d.is_error or not quiet:
            print(d.format(), file=out)
    status = "ok" if errors == 0 else "FAILED"
    print(printable(f"{path}: {status}: {errors} error(s), {warnings} warning(s)"), file=out)
    return errors == 0


def _schedule_file(path: Path) -> bool:
    """Whether ``path`` is a compiled schedule. Only a file starting as JSON may be one: the
    schedule file's reader (a sixth of validate's start-up) is imported for those alone."""
    if not read_head(path, 4096).lstrip().startswith(b"{"):
        return False
    from xgo_show.compiler.artifact import is_schedule_file

    return is_schedule_file(path)


def run(args: argparse.Namespace) -> int:
    ok = True
    for name in args.files:
        path = Path(name)
        # A file that cannot be read is a diagnostic at its start like any other, so that
        # every line is file:line:col: severity: ... or a summary (editors and scripts parse it).
        reason = file_problem(path)
        if reason is None and _schedule_file(path):
            from xgo_show.compiler.artifact import SCHEDULE_HINT

            reason = SCHEDULE_HINT
        diags = ([Diagnostic("error", reason, Origin(name, 1, 1))] if reason is not None
                 else choreo.validate_file(path))
        ok = report(name, diags, sys.stdout, quiet=args.quiet) and ok
    return 0 if ok else 1
