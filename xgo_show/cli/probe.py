"""``xgo-show probe PORT``: read a robot's identity and health and print them as a table.

For XGO robots: firmware, model, battery and status; for the xArm: battery voltage and servo
positions. Works on any port or URL (``/dev/ttyUSB0``, ``sim:mini``, the pty path printed by
``xgo-show simulate``). Errors (unopenable port, no reply, garbage) are one line, exit 2.
"""

from __future__ import annotations

import argparse
from typing import Any

from xgo_show.client import DEFAULT_TIMEOUT, open_client
from xgo_show.errors import UsageError
from xgo_show.families import get_family
from xgo_show.net.session import add_session_arguments, session_options
from xgo_show.profiles import MODELS

__all__ = ["add_parser", "format_table", "probe", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``probe`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "probe",
        help="read firmware, model, battery and status from a robot",
        description=(
            "Read a robot's firmware, model, battery and status (xArm: battery voltage and "
            "servo positions) and print them as a table. PORT is a serial device "
            "(/dev/ttyUSB0, COM3), a pyserial URL (socket://host:port), a simulator "
            "(sim:mini, sim:lite, sim:rider, sim:xarm) or the pty path `xgo-show simulate` "
            "prints, or zenoh:RELAY/ROBOT for a robot behind an xgo-show relay; prefix hex+ to "
            "log the traffic."
        ),
        epilog=(
            "example:\n  xgo-show probe /dev/ttyUSB0\n  xgo-show probe sim:rider --timeout 2\n"
            "  xgo-show probe zenoh:stage-left/rex --connect tcp/192.168.1.20:7447"
        ),
    )
    parser.add_argument(
        "port", metavar="PORT", help="serial device, URL, sim:<model> or zenoh:RELAY/ROBOT"
    )
    parser.add_argument(
        "--model",
        choices=sorted(MODELS),
        help="robot model (default: from a sim: URL, else from the firmware string)",
    )
    parser.add_argument(
        "--timeout",
        metavar="S",
        type=float,
        default=DEFAULT_TIMEOUT,
        help=f"seconds to wait for each reply (default {DEFAULT_TIMEOUT:g})",
    )
    add_session_arguments(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not args.timeout > 0:
        raise UsageError(f"--timeout must be a positive number of seconds, not {args.timeout:g}")
    if args.port.lower().startswith("zenoh:"):
        from xgo_show.relay.conductor import probe_relayed

        rows = probe_relayed(args.port, session_options(args), timeout=args.timeout)
    else:
        rows = probe(args.port, model=args.model, timeout=args.timeout)
    print(format_table(rows))
    return 0


def probe(
    url: str, *, model: str | None = None, timeout: float = DEFAULT_TIMEOUT
) -> list[tuple[str, str]]:
    """Read the robot on ``url``; return ``(label, value)`` rows for :func:`format_table`.

    What is read is the robot family's (:meth:`RobotFamily.probe
    <xgo_show.families.RobotFamily.probe>`).
    """
    with open_client(url, model, timeout=timeout) as client:
        return get_family(client.profile).probe(client, given=model)


def format_table(rows: list[tuple[str, str]]) -> str:
    """Two aligned columns, labels left."""
    width = max((len(label) for label, _ in rows), default=0)
    return "\n".join(f"{label.ljust(width)}  {value}" for label, value in rows)
