"""``xgo-show simulate``: serve a simulated robot on a new pseudo-terminal.

The first line on stdout is the terminal's path (flushed at once, so scripts can read it and
connect); the command then serves until SIGINT or SIGTERM, exits 0 and prints a one-line summary
to stderr.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from types import FrameType
from typing import Any

from xgo_show.errors import SimulatorError
from xgo_show.families import get_family
from xgo_show.profiles import MODELS, get_profile
from xgo_show.sim import PtyServer, create_robot

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``simulate`` subcommand on the CLI's subparsers."""
    parser = sub.add_parser(
        "simulate",
        help="serve a simulated robot on a pseudo-terminal",
        description=(
            "Serve one simulated robot on a new pseudo-terminal that any serial client "
            "(xgo-show itself, the vendor's xgolib) can open. Prints the terminal path as the "
            "first line of output and runs until interrupted (Ctrl-C)."
        ),
        epilog=(
            "example:\n"
            "  xgo-show simulate --model lite    # prints its path, e.g. /dev/pts/3\n"
            "  xgo-show probe /dev/pts/3         # in another terminal"
        ),
    )
    parser.add_argument(
        "--model", required=True, choices=sorted(MODELS), help="robot model to simulate"
    )
    parser.add_argument(
        "--pty",
        action="store_true",
        help="serve on a new pseudo-terminal (the default and, so far, the only way)",
    )
    parser.add_argument(
        "--record",
        metavar="FILE",
        help="write every frame received as a JSON line {t, hex, accepted, reason} to FILE",
    )
    parser.add_argument(
        "--battery",
        metavar="PCT",
        type=float,
        help="starting battery level in percent (XGO models only, 0..100; default 100)",
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed for the simulated IMU noise (XGO; default 0)"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Serve until SIGINT/SIGTERM; 0 on a clean stop."""
    family = get_family(get_profile(args.model))
    options = family.simulate_options(seed=args.seed, battery=args.battery)
    robot = create_robot(args.model, **options)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    started = time.monotonic()
    try:
        with PtyServer(robot, record=args.record) as server:
            print(server.path, flush=True)
            while not stop.wait(0.2):
                if not server.running:
                    raise SimulatorError(f"the simulator stopped: {server.error}")
            snap = server.snapshot()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    print(_summary(args.model, server.path, time.monotonic() - started, snap), file=sys.stderr)
    return 0


def _summary(model: str, path: str, seconds: float, snap: dict[str, Any]) -> str:
    parts = [
        f"{snap['frames_received']} frames received ({snap['frames_rejected']} rejected)",
        f"{snap['discarded_bytes']} bytes discarded",
    ]
    if "battery" in snap:
        parts.append(f"battery {snap['battery']:.1f} %")
    if "battery_mv" in snap:
        parts.append(f"battery {snap['battery_mv']} mV")
    return f"xgo-show simulate: {model} on {path} for {seconds:.1f} s: " + ", ".join(parts)
