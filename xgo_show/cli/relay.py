"""``xgo-show relay``: own this host's robots and play the shows a conductor uploads.

Runs until Ctrl-C or SIGTERM, which safe-stops every robot. See :mod:`xgo_show.relay.server`
for what it serves and docs/relays.md for set-ups across hosts.
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import socket
import sys
import threading
import time
from types import FrameType
from typing import Any

from xgo_show.net.keys import relay_name_chunk
from xgo_show.net.session import add_session_arguments, open_session, session_options
from xgo_show.net.testhooks import clock_from_env, delay_from_env, trace_from_env
from xgo_show.relay.robots import close_robots, open_robots, parse_pairs
from xgo_show.relay.server import Relay
from xgo_show.runtime.realtime import add_realtime_arguments, decide
from xgo_show.runtime.runlog import RunLog

__all__ = ["PARENT_DONE", "PARENT_GONE", "add_parser", "default_name", "run"]

PARENT_GONE = "conductor process gone"
PARENT_DONE = "conductor done"


def default_name() -> str:
    """This host's short name, made a valid relay name."""
    host = socket.gethostname().split(".")[0]
    return relay_name_chunk(host)[:64] or "relay"


def add_parser(sub: Any) -> None:
    """Register the ``relay`` subcommand."""
    parser = sub.add_parser(
        "relay",
        help="own this host's robots and play shows a conductor uploads over Zenoh",
        description=(
            "Open the robots' ports (the same ports and URLs as run: a device, a pyserial URL, "
            "sim:MODEL), announce them on Zenoh, and play the schedules a conductor "
            "(xgo-show run --map NAME=zenoh:RELAY/NAME) uploads. A conductor silent for its "
            "watchdog time (500 ms by default) gets the show's link-loss policy: safe stop, or "
            "finish the show. Ctrl-C or SIGTERM safe-stops every robot and exits."
        ),
        epilog=(
            "example:\n"
            "  xgo-show relay --name stage-left --map rex=/dev/ttyUSB0 --listen tcp/0.0.0.0:7447\n"
            "  xgo-show relay --name bench --map rex=sim:mini --map arm=sim:xarm"
        ),
    )
    parser.add_argument(
        "--name",
        default=None,
        help="the relay's name on Zenoh (default: this host's name)",
    )
    parser.add_argument(
        "--map",
        action="append",
        default=[],
        required=True,
        metavar="NAME=PORT",
        help="a robot this relay owns: its name and port or URL (repeatable)",
    )
    parser.add_argument(
        "--model",
        action="append",
        default=[],
        metavar="NAME=MODEL",
        help="the robot's model when the port cannot tell it (an xArm on a serial port: xarm)",
    )
    parser.add_argument(
        "--allow-unsafe",
        action="store_true",
        help="accept schedules that write unsafe registers (the conductor cannot ask for this)",
    )
    parser.add_argument("--log", metavar="FILE", help="write the relay's run log (JSON lines)")
    parser.add_argument(
        "--no-telemetry",
        action="store_true",
        help="do not poll battery, status and attitude during shows",
    )
    add_realtime_arguments(parser)
    # Set by xgo-show run for the relay child that owns its local ports.
    parser.add_argument("--parent-pid", type=int, help=argparse.SUPPRESS)
    add_session_arguments(parser)
    parser.set_defaults(func=run)


def _wait_for_signal(parent: int | None) -> str:
    """Block until SIGINT or SIGTERM (or the parent process is gone); return why.

    A relay started by a conductor (``parent``) also ends when the conductor writes ``done``
    to the relay's standard input (:data:`PARENT_DONE`), or dies (:data:`PARENT_GONE`: the
    pipe closes without it, and Linux sends SIGTERM). The handlers stay installed when this
    returns: a signal that arrives while the relay stops its robots must not kill it halfway.
    """
    got: list[str] = []
    if parent is not None:

        def watch_stdin() -> None:
            for line in sys.stdin.buffer:
                if line.strip() == b"done":
                    got.append(PARENT_DONE)  # seen within one select() timeout below
                    return
            got.append(PARENT_GONE)

        threading.Thread(target=watch_stdin, name="relay parent pipe", daemon=True).start()
    r, w = os.pipe()
    os.set_blocking(w, False)

    def on_signal(signum: int, frame: FrameType | None) -> None:
        got.append(signal.Signals(signum).name)

    old_fd = signal.set_wakeup_fd(w)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    try:
        while not got:
            select.select([r], [], [], 0.2)
            if parent is not None and os.getppid() != parent:
                return PARENT_GONE
        if parent is not None and got[0] in ("SIGTERM", "SIGINT"):
            # The parent's death sends SIGTERM, and its end of the pipe closes, but getppid()
            # may still name it for a moment: give it 0.1 s to show, so a conductor's death is
            # told from a plain SIGTERM (which safe-stops whatever the link-loss policy).
            deadline = time.monotonic() + 0.1
            while time.monotonic() < deadline and PARENT_GONE not in got:
                if os.getppid() != parent:
                    return PARENT_GONE
                time.sleep(0.005)
        if parent is not None and (PARENT_GONE in got or os.getppid() != parent):
            return PARENT_GONE
        return got[0]
    finally:
        signal.set_wakeup_fd(old_fd)
        os.close(r)
        os.close(w)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show relay``."""
    from xgo_show.relay.parent import watch_parent

    if args.parent_pid is not None:
        watch_parent(args.parent_pid)
    opts = session_options(args)
    name = args.name or default_name()
    ports = parse_pairs(args.map, "--map", "rex=/dev/ttyUSB0")
    models = parse_pairs(args.model, "--model", "arm=xarm")
    decide(args.realtime)  # before the ports open: --realtime refused leaves them untouched
    robots = open_robots(ports, models)
    try:
        session = open_session(opts)
        try:
            with RunLog(args.log, keep=False) as log:
                relay = Relay(
                    session,
                    name,
                    robots,
                    namespace=opts.namespace,
                    clock=clock_from_env(),  # this host's clock, unless a test skews it
                    allow_unsafe=args.allow_unsafe,
                    log=log,
                    telemetry=not args.no_telemetry,
                    sync_delay=delay_from_env(),
                    trace=trace_from_env(),
                )
                with relay:
                    rows = ", ".join(f"{r.name} ({r.model} on {r.url})" for r in robots.values())
                    print(
                        f"relay {name} ready in namespace {opts.namespace}: {rows}",
                        flush=True,
                    )
                    why = _wait_for_signal(args.parent_pid)
                    if why == PARENT_DONE:
                        relay.close(why, stop_idle=False)
                    elif why == PARENT_GONE:
                        relay.finish(why)
                    else:
                        relay.close(why)
                if args.parent_pid is None:
                    print(f"relay {name}: {why}; every robot was safe-stopped", flush=True)
        finally:
            session.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type
    finally:
        close_robots(robots)
    return 0
