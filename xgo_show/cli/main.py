"""The ``xgo-show`` command: a thin layer over the Python API.

Each subcommand lives in its own module exposing ``add_parser(subparsers)`` (which sets
``func``) and ``run(args) -> int``. User mistakes (:class:`XgoShowError`) print one clear line
and exit 2; they never show a traceback. An error carrying diagnostics (a routine that does not
load or compile) prints every one of them as ``file:line:col``, then that line.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import logging
import os
import sys
import threading
from collections.abc import Sequence

from xgo_show import __version__
from xgo_show.errors import ChoreographyError, XgoShowError
from xgo_show.text import printable

__all__ = ["COMMANDS", "build_parser", "main", "program"]

# Module names under xgo_show.cli, in the order --help lists them.
COMMANDS: tuple[str, ...] = (
    "probe",
    "simulate",
    "validate",
    "behave",
    "compile",
    "inspect",
    "run",
    "dry_run",
    "info",
    "new",
    "beats",
    "schema",
    "relay",
    "relays",
    "serve",
    "ctl",
    "trigger",
)


class _HelpFormatter(argparse.HelpFormatter):
    """Wraps prose as usual, but keeps each line of an epilog as written where it is indented
    (the examples), so a command line is never rewrapped into the prose around it."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        fill = super()._fill_text
        return "\n".join(
            indent + line if line.startswith(" ") else fill(line, width, indent)
            for line in text.split("\n")
        )


def _named_command(argv: Sequence[str]) -> str | None:
    """The module of the command ``argv`` names (its first word that is not an option), if any."""
    first = next((w for w in argv if not w.startswith("-")), None)
    if first is None or "_" in first:  # 'dry_run' is no command: argparse lists the real ones
        return None
    module = first.replace("-", "_")
    return module if module in COMMANDS else None


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The command line parser. When ``argv`` names a command, only that command's module is
    imported and registered (its parser is the same): every other one's imports would cost
    ``compile`` or ``validate`` a third of a second of start-up for nothing. Otherwise (no
    command, a mistyped one, ``--help``) every command is registered, for the listing."""
    parser = argparse.ArgumentParser(
        prog="xgo-show",
        description="Choreograph, compile and run shows for XGO robot dogs and the xArm.",
    )
    parser.add_argument("--version", action="version", version=f"xgo-show {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    named = _named_command(argv) if argv is not None else None
    for name in COMMANDS if named is None else (named,):
        module = importlib.import_module(f"xgo_show.cli.{name}")
        module.add_parser(sub)
    for command in sub.choices.values():
        command.formatter_class = _HelpFormatter
    return parser


class _StderrHandler(logging.Handler):
    """Writes each record's message to the *current* ``sys.stderr`` (not the one at setup)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            print(self.format(record), file=sys.stderr, flush=True)
        except Exception:  # logging must never break the command
            self.handleError(record)


def _log_traffic() -> None:
    """Send the ``hex+`` transports' lines (logger ``xgo_show.traffic``, DEBUG) to stderr as
    they are: each line already says which port and which direction."""
    logger = logging.getLogger("xgo_show.traffic")
    logger.setLevel(logging.DEBUG)
    if not any(isinstance(h, _StderrHandler) for h in logger.handlers):
        logger.addHandler(_StderrHandler())


def _report(exc: XgoShowError) -> None:
    """Every diagnostic the error carries, one per line, then one summary line."""
    diags = list(exc.diagnostics) if isinstance(exc, ChoreographyError) else []
    if not diags:  # each line made printable: the message may quote a file's text
        text = "\n".join(printable(line) for line in str(exc).split("\n"))
        print(f"xgo-show: error: {text}", file=sys.stderr)
        return
    for d in diags:
        print(d.format(), file=sys.stderr)
    errors = [d for d in diags if d.is_error]
    first = next((d.origin.file for d in errors if d.origin), "")
    where = f"{first}: " if first else ""
    count = sum(d.count for d in errors)
    print(f"xgo-show: error: {printable(where)}{count} error(s)", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command ``argv`` names (default: the process's arguments); its exit status."""
    return _main(argv)[0]


def program() -> None:
    """The ``xgo-show`` program (its console script, and ``python -m xgo_show``): :func:`main`,
    then the process's exit.

    A command that says it leaves nothing behind (``quick_exit``: validate and compile, whose
    work is done when they return) ends the process at once, its output flushed: the
    interpreter's own teardown would free every module, schema and object one by one for
    nothing (for benchmarks/compile_cli.py's routine, validate ran 4.54 G instructions with
    it and 4.36 G without, by callgrind).
    """
    code, args = _main(None, program=True)
    if getattr(args, "quick_exit", False):
        _exit_now(code)
        gc.enable()  # not ended at once: the usual exit, with the collector as usual
    sys.exit(code)


def _exit_now(code: int) -> None:
    """End the process with ``code`` without the interpreter's teardown, when nothing is left
    that teardown would finish: no other thread running, the output written."""
    first = threading.main_thread()
    if any(t is not first and not t.daemon for t in threading.enumerate()):
        return  # a thread still running: the usual exit waits for it
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed pipe: the usual exit reports it as ever
        return
    logging.shutdown()
    os._exit(code)


def _main(argv: Sequence[str] | None, *, program: bool = False
          ) -> tuple[int, argparse.Namespace]:
    parser = build_parser(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    if program and getattr(args, "quick_exit", False) and not getattr(args, "watch", False):
        # A process that ends when the command returns: its imports (pydantic's thousands of
        # objects) make no garbage worth the collector's passes over them, and the loader and
        # the compiler pause it anyway.
        gc.disable()
    _log_traffic()
    if getattr(args, "watch", False):
        from xgo_show.cli.watch import watch

        return watch(args, lambda: _run(args)), args
    return _run(args), args


def _run(args: argparse.Namespace) -> int:
    try:
        return int(args.func(args))
    except XgoShowError as exc:
        _report(exc)
        return 2
    except KeyboardInterrupt:
        print("xgo-show: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 141


if __name__ == "__main__":
    program()
