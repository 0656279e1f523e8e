"""``xgo-show relays``: list the live relays and, for each robot they own, model, firmware,
battery and state (and which conductor holds each relay)."""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

from xgo_show.errors import UsageError
from xgo_show.net.session import add_session_arguments, open_session, session_options

__all__ = ["add_parser", "format_relays", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``relays`` subcommand."""
    parser = sub.add_parser(
        "relays",
        help="list the live relays and their robots (model, firmware, battery, state)",
        description=(
            "Ask every live xgo-show relay in the namespace for its description and print one "
            "line per robot: relay, state, holder, robot, model, firmware, battery, state."
        ),
        epilog=(
            "example:\n"
            "  xgo-show relays --wait 2\n"
            "  xgo-show relays --connect tcp/192.168.1.20:7447 --json"
        ),
    )
    parser.add_argument(
        "--wait",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds to collect answers (default 1; relays found through others need time)",
    )
    parser.add_argument("--json", action="store_true", help="print the descriptions as JSON")
    add_session_arguments(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show relays``."""
    if not 0 < args.wait <= 60:
        raise UsageError(f"--wait {args.wait:g}: give 0 to 60 seconds")
    from xgo_show.relay.client import list_relays

    opts = session_options(args)
    session = open_session(opts)
    try:
        found: dict[str, dict[str, Any]] = {}
        deadline = time.monotonic() + args.wait
        while True:  # the session learns of relays beyond its first peers by gossip
            left = deadline - time.monotonic()
            for relay in list_relays(session, opts.namespace, timeout=max(0.1, min(left, 0.5))):
                if found.get(relay["relay"], {}).get("state") in (None, "not answering"):
                    found[relay["relay"]] = relay
            if time.monotonic() >= deadline:
                break
            time.sleep(min(0.1, max(0.0, deadline - time.monotonic())))
    finally:
        session.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type
    relays = [found[name] for name in sorted(found)]
    if args.json:
        print(json.dumps(relays, indent=1, sort_keys=True))
    else:
        print(format_relays(relays, opts.namespace))
    return 0


def _battery(robot: dict[str, Any]) -> str:
    if robot.get("voltage") is not None:
        return f"{robot['voltage']:.2f} V"
    if robot.get("battery") is not None:
        return f"{robot['battery']:.0f}%"
    return "-"


def format_relays(relays: list[dict[str, Any]], namespace: str) -> str:
    """One line per robot of every relay (a relay without robots gets one line too)."""
    if not relays:
        return f"no relay found in namespace {namespace}"
    head = ("relay", "state", "holder", "robot", "model", "firmware", "battery", "robot state")
    lines = [head]
    for relay in relays:
        holder = relay.get("holder") or {}
        who = str(holder.get("name", "-")) if holder else "-"
        robots = relay.get("robots") or [{}]
        for robot in robots:
            problems = "; ".join(robot.get("problems") or [])
            lines.append(
                (
                    str(relay.get("relay")),
                    str(relay.get("state", "-")),
                    who,
                    str(robot.get("name", "-")),
                    str(robot.get("model", "-")),
                    str(robot.get("firmware") or "-"),
                    _battery(robot) if robot else "-",
                    str(robot.get("state", "-")) + (f" ({problems})" if problems else ""),
                )
            )
    widths = [max(len(row[i]) for row in lines) for i in range(len(head) - 1)]
    return "\n".join(
        "  ".join([*(c.ljust(w) for c, w in zip(row, widths, strict=False)), row[-1]]).rstrip()
        for row in lines
    )
