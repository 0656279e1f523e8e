"""The ``xgo-show`` command: a thin layer over the Python API.

Each subcommand lives in its own module exposing ``add_parser(subparsers)`` (which sets
``func``) and ``run(args) -> int``. User mistakes (:class:`XgoShowError`) print one clear line
and exit 2; they never show a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from xgo_show import __version__
from xgo_show.errors import XgoShowError

__all__ = ["COMMANDS", "build_parser", "main"]

# Module names under xgo_show.cli, in the order --help lists them.
COMMANDS: tuple[str, ...] = (
    "probe",
    "simulate",
    "validate",
    "compile",
    "inspect",
    "run",
    "dry_run",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="xgo-show",
        description="Choreograph, compile and run shows for XGO robot dogs and the xArm.",
    )
    parser.add_argument("--version", action="version", version=f"xgo-show {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module(f"xgo_show.cli.{name}")
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except XgoShowError as exc:
        print(f"xgo-show: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("xgo-show: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 141


if __name__ == "__main__":
    sys.exit(main())
