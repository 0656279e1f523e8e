"""``xgo-show trigger NAME``: fire a trigger at the running show (docs/zenoh-api.md).

By default a query: the server answers whether a wait took it (exit 0) or why not (exit 2).
``--no-reply`` publishes it instead (fire and forget, as a sensor or a microcontroller would).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from xgo_show.cli.control_client import add_client_arguments, control_client

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``trigger`` subcommand."""
    parser = sub.add_parser(
        "trigger",
        help="fire a trigger at the show an xgo-show serve is running",
        description="Fire trigger NAME: the show holding at a wait for it plays on (or keeps "
        "it for the wait it is coming to). Prints what it released, or why it was refused.",
        epilog="example:\n  xgo-show trigger go\n  xgo-show trigger encore --source desk",
    )
    parser.add_argument("name", metavar="NAME", help="the trigger's name")
    parser.add_argument("--source", metavar="WHO", help="who fires it (shown in events)")
    parser.add_argument("--data", metavar="JSON", help="a JSON value to attach (echoed)")
    parser.add_argument("--no-reply", action="store_true",
                        help="publish it and return (no answer from the server)")
    add_client_arguments(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show trigger``."""
    from xgo_show.control.keys import check_trigger_name
    from xgo_show.errors import UsageError

    name = check_trigger_name(args.name)
    data = None
    if args.data is not None:
        try:
            data = json.loads(args.data)
        except ValueError as exc:
            raise UsageError(f"--data {args.data!r}: not JSON ({exc})") from exc
    with control_client(args) as client:
        reply = client.trigger(name, source=args.source, data=data, reply=not args.no_reply)
    if args.no_reply:
        print(f"trigger {name!r} published")
    else:
        how = "released" if reply.get("held") else "kept for"
        print(f"trigger {name!r}: {how} section {reply.get('section')!r}")
    return 0
