"""``xgo-show serve``: hold the robots and take show control and triggers from Zenoh clients.

Runs until Ctrl-C or SIGTERM (a running show is safe-stopped first). The API it serves is in
docs/zenoh-api.md; ``xgo-show ctl`` and ``xgo-show trigger`` are clients of it.
"""

from __future__ import annotations

import argparse
import signal
import threading
from pathlib import Path
from typing import Any

from xgo_show.errors import UsageError
from xgo_show.runtime.realtime import add_realtime_arguments, decide

__all__ = ["add_parser", "parse_robot_maps", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``serve`` subcommand."""
    from xgo_show.relay.options import add_conductor_arguments

    parser = sub.add_parser(
        "serve",
        help="take show control and triggers from any Zenoh client",
        description=(
            "Serve the show-control API on Zenoh (docs/zenoh-api.md): load a show, start, "
            "stop, pause, resume, seek, panic and status as queries under NS/control and "
            "NS/status, triggers on NS/trigger/NAME, events on NS/event. Robots are given "
            "with --map (or simulated with --sim); every show goes through pre-flight, and "
            "every fault, stop or panic ends in a safe stop. Runs until Ctrl-C."
        ),
        epilog=(
            "example:\n"
            "  xgo-show serve --map rex=/dev/ttyUSB0 --map ivy=/dev/ttyUSB1\n"
            "  xgo-show serve --sim --load choreographies/curtain_call.yaml\n"
            "  xgo-show serve --map rex=zenoh:stage-left/dog1 --connect tcp/10.0.0.5:7447\n"
            "  xgo-show serve --sim --load show.yaml --follow osc:0.0.0.0:9000"
        ),
    )
    parser.add_argument("--map", action="append", default=[], metavar="NAME=PORT",
                        help="port or URL of a performer (repeatable)")
    parser.add_argument("--sim", action="store_true",
                        help="performers without --map play on simulated robots (real ptys)")
    parser.add_argument("--load", metavar="SHOW",
                        help="load this routine or schedule at once (as the load command)")
    parser.add_argument("--no-telemetry", action="store_true",
                        help="do not poll battery, status and attitude during shows")
    parser.add_argument("--allow-unsafe", action="store_true",
                        help="allow schedules that write unsafe registers")
    parser.add_argument("--log", metavar="FILE",
                        help="write the run log (JSON lines) of every show played to FILE, with "
                        "each trigger's times (received, decided, released, first frame)")
    parser.add_argument("--follow", metavar="osc:[HOST:]PORT",
                        help="also take the sound desk's OSC cues on this UDP port: /go starts "
                        "the loaded show (or goes on), /stop, /pause, /resume, /seek SECONDS, "
                        "/bar N, and /trigger NAME fires a trigger as NS/trigger/NAME does")
    add_conductor_arguments(parser)
    add_realtime_arguments(parser)
    parser.set_defaults(func=run)


def parse_robot_maps(items: list[str]) -> dict[str, str]:
    """``NAME=PORT`` options -> {name: port} (any performer name: shows are loaded later)."""
    out: dict[str, str] = {}
    for item in items:
        name, eq, port = item.partition("=")
        if not eq or not name or not port:
            raise UsageError(f"--map {item!r}: write NAME=PORT, e.g. rex=/dev/ttyUSB0")
        if name in out:
            raise UsageError(f"--map {item!r}: {name} is already mapped to {out[name]}")
        out[name] = port
    return out


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show serve``."""
    from xgo_show.control.protocol import LoadRequest
    from xgo_show.control.server import ServeOptions, ShowServer
    from xgo_show.net.session import open_session
    from xgo_show.relay.options import conductor_options

    decide(args.realtime)  # the writer threads of every show it plays raise themselves
    conductor = conductor_options(args)
    sopts = conductor.session
    opts = ServeOptions(
        namespace=sopts.namespace,
        maps=parse_robot_maps(args.map),
        conductor=conductor,
        sim=args.sim,
        telemetry=not args.no_telemetry,
        allow_unsafe=args.allow_unsafe,
        log=Path(args.log) if args.log else None,
        follow=args.follow,
    )
    if not opts.maps and not opts.sim:
        raise UsageError("serve needs robots: give --map NAME=PORT (repeatable) or --sim")
    if args.follow is not None:
        from xgo_show.timecode.osc import parse_spec

        parse_spec(args.follow)  # a mistake is said before anything opens
    done = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        done.set()

    old = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    session = open_session(sopts)
    try:
        load = LoadRequest.model_validate({"path": args.load}) if args.load else None
        server = ShowServer(session, opts, say=lambda line: print(line, flush=True), load=load)
        try:
            print(f"serving on {sopts.namespace}/control, {sopts.namespace}/status and "
                  f"{sopts.namespace}/trigger/* (Ctrl-C to stop)", flush=True)
            if server.osc is not None:
                print(f"listening for OSC cues on {server.osc.host}:{server.osc.port} "
                      "(/go /stop /pause /resume /seek /bar /trigger NAME)", flush=True)
            while not done.wait(0.5):
                pass
        finally:
            server.close()
    finally:
        session.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type
        for sig, handler in old.items():
            signal.signal(sig, handler)
    print("serve stopped", flush=True)
    return 0
