"""``xgo-show behave``: check a behaviour file, or rehearse it from a timed script.

``xgo-show behave FILE`` loads the behaviour (every routine compiled, every name checked) and
lists its rules; with ``--script EVENTS.yaml --fast`` it rehearses the behaviour on virtual
robots and virtual time and prints a trace: what fired, and what each robot did.
"""

from __future__ import annotations

import argparse
from typing import Any

from xgo_show.errors import XgoShowError

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``behave`` subcommand."""
    parser = sub.add_parser(
        "behave",
        help="check a behaviour file (rules reacting to triggers and telemetry), or rehearse it",
        description=(
            "Load BEHAVIOUR.yaml (every routine it may play is compiled, every routine, "
            "performer, trigger and set it names is checked) and list its rules; with --script "
            "and --fast, rehearse it on virtual robots and print what fired and what each robot "
            "did."
        ),
        epilog=(
            "example:\n"
            "  xgo-show behave behaviours/exhibition/exhibition.yaml\n"
            "  xgo-show behave behaviours/exhibition/exhibition.yaml --sim --fast "
            "--script behaviours/exhibition/rehearsal.yaml"
        ),
    )
    parser.add_argument("behaviour", metavar="BEHAVIOUR.yaml", help="the behaviour file")
    parser.add_argument(
        "--script", metavar="EVENTS.yaml",
        help="a rehearsal script: timed triggers, falls, battery levels, robots going offline",
    )
    parser.add_argument("--sim", action="store_true", help="on simulated robots (the default "
                        "for a rehearsal: robots on ports are not driven by this version)")
    parser.add_argument("--fast", action="store_true",
                        help="rehearse on virtual time, without waiting (needed with --script)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show behave``."""
    from xgo_show.behave import load_behaviour

    behaviour = load_behaviour(args.behaviour)
    model = behaviour.model
    if args.script is None:
        if args.fast:
            raise XgoShowError("--fast rehearses a script: give --script EVENTS.yaml")
        print(f"{args.behaviour}: behaviour {model.behaviour!r}: {len(model.rules)} rules, "
              f"{len(behaviour.routines)} routines compiled, performers "
              f"{', '.join(model.performers)}")
        for rule in model.rules:
            rank = ("safety, " if rule.safety else "") + f"priority {rule.priority}"
            print(f"  {rule.name}: {len(rule.when)} trigger(s), {len(rule.do)} action(s), "
                  f"{rule.mode}, {rank}")
        return 0
    if not args.fast:
        raise XgoShowError("a rehearsal runs on virtual time in this version: add --fast "
                           "(real-time rehearsal on ptys and robots on ports are not built yet)")
    from xgo_show.behave.rehearsal import load_rehearsal, rehearse

    script = load_rehearsal(args.script, behaviour)
    print(f"rehearsing {model.behaviour!r} for {script.duration:g} s from {script.start} "
          f"(virtual time)")
    rehearse(behaviour, script, lambda t, line: print(f"{t:9.2f}  {line}"))
    return 0
