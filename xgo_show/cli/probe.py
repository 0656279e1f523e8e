"""``xgo-show probe PORT``: read a robot's identity and health and print them as a table.

For XGO robots: firmware, model, battery and status; for the xArm: battery voltage and servo
positions. Works on any port or URL (``/dev/ttyUSB0``, ``sim:mini``, the pty path printed by
``xgo-show simulate``). Errors (unopenable port, no reply, garbage) are one line, exit 2.
"""

from __future__ import annotations

import argparse
from typing import Any

from xgo_show.client import DEFAULT_TIMEOUT, XarmClient, XgoClient, open_client
from xgo_show.errors import XgoShowError
from xgo_show.profiles import MODELS, get_profile, model_from_firmware
from xgo_show.profiles.xarm import position_to_degrees

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
            "prints; prefix hex+ to log the traffic."
        ),
        epilog="example:\n  xgo-show probe /dev/ttyUSB0\n  xgo-show probe sim:rider --timeout 2",
    )
    parser.add_argument("port", metavar="PORT", help="serial device, URL or sim:<model>")
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
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not args.timeout > 0:
        raise XgoShowError(f"--timeout must be a positive number of seconds, not {args.timeout:g}")
    rows = probe(args.port, model=args.model, timeout=args.timeout)
    print(format_table(rows))
    return 0


def probe(
    url: str, *, model: str | None = None, timeout: float = DEFAULT_TIMEOUT
) -> list[tuple[str, str]]:
    """Read the robot on ``url``; return ``(label, value)`` rows for :func:`format_table`."""
    with open_client(url, model, timeout=timeout) as client:
        if isinstance(client, XarmClient):
            return _probe_xarm(client, given=model)
        if isinstance(client, XgoClient):
            return _probe_xgo(client, given=model)
        raise XgoShowError(f"probe cannot read a {client.model} yet (no probe for its family)")


def _probe_xgo(client: XgoClient, *, given: str | None) -> list[tuple[str, str]]:
    firmware = client.firmware()
    named = model_from_firmware(firmware)
    if given is None:
        how = "from the URL" if named is None or named != client.model else "from firmware"
        model = f"{client.model} ({how})"
    elif named is not None and named != given:
        model = f"{given} (given; the firmware names a {named})"
        # Read the rest with the robot's own table: the given model's may not match its
        # registers (a Rider has no Mini status register), and a probe should still report.
        client = XgoClient(client.transport, get_profile(named), timeout=client.timeout)
    else:
        model = given
    status_reg = client.profile.register("status")
    status_raw = client.read("status")
    status = status_reg.decode_value(status_raw)
    status_text = f"0x{status_raw[0]:02X}"
    if isinstance(status, str):
        status_text = f"{status} ({status_text})"
    return [
        ("port", client.transport.url),
        ("model", model),
        ("firmware", firmware),
        ("battery", f"{client.battery()} %"),
        ("status", status_text),
    ]


def _probe_xarm(client: XarmClient, *, given: str | None) -> list[tuple[str, str]]:
    millivolts = client.battery_mv()
    rows = [
        ("port", client.transport.url),
        ("model", "xarm" if given else "xarm (from the URL)"),
        ("battery", f"{millivolts / 1000:.2f} V"),
    ]
    for servo, position in client.positions().items():
        rows.append(
            (f"servo {servo}", f"{position:4d}  ({position_to_degrees(position):+.1f} deg)")
        )
    return rows


def format_table(rows: list[tuple[str, str]]) -> str:
    """Two aligned columns, labels left."""
    width = max((len(label) for label, _ in rows), default=0)
    return "\n".join(f"{label.ljust(width)}  {value}" for label, value in rows)
