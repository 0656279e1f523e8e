"""``xgo-show dry-run``: play a show on simulated robots over real pseudo-terminals.

The whole real path runs (compile -> pyserial -> pty -> simulator); at the end each simulated
robot's final state is printed: registers that changed, actions run, frames received and any
frame it rejected. ``--fast`` skips the waiting (every frame still reaches the simulators).
"""

from __future__ import annotations

import argparse
from typing import Any

from xgo_show.cli.run import (
    add_common_arguments,
    check_options,
    load_schedule_file,
    parse_maps,
    play,
    play_options,
)
from xgo_show.cli.watch import add_watch_option

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``dry-run`` subcommand."""
    parser = sub.add_parser(
        "dry-run",
        help="run a show on simulated robots (real ptys, no hardware)",
        description=(
            "Compile SHOW.yaml and run it on one simulated robot per performer, each on its "
            "own pseudo-terminal, in real time (or --fast); then print what every simulated "
            "robot ended up doing."
        ),
        epilog=(
            "example:\n"
            "  xgo-show dry-run choreographies/hello_mini.yaml\n"
            "  xgo-show dry-run choreographies/mixed_five.yaml --fast --start-bar 40\n"
            "  xgo-show dry-run choreographies/curtain_call.yaml --triggers "
            "rehearsals/curtain_call.yaml\n"
            "  xgo-show dry-run --watch --fast my_routine.yaml     # again on every save"
        ),
    )
    parser.add_argument(
        "--fast",
        action="store_true",
        help="do not wait between frames (every frame still reaches the simulators)",
    )
    parser.add_argument(
        "--plot", metavar="FILE.png|FILE.html",
        help="also draw the compiled schedule: a PNG, or an interactive HTML timeline (zoom; "
        "hover for each cue and its line)",
    )
    add_common_arguments(parser)
    add_watch_option(parser, "show")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show dry-run``."""
    check_options(args)
    schedule = load_schedule_file(args.show)
    if args.plot:
        from xgo_show.compiler import plot_schedule

        print(f"schedule plot written to {plot_schedule(schedule, args.plot)}")
    maps = parse_maps(schedule, args.map)
    return play(schedule, play_options(args, schedule, maps=maps, sim=True, fast=args.fast))
