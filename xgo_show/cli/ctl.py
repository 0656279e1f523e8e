"""``xgo-show ctl COMMAND``: a thin client of a running ``xgo-show serve`` (docs/zenoh-api.md).

Each command is one query; the server's reply is printed (``--json``: as received). A refusal
prints the server's message and exits 2; so does a server that does not answer.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

from xgo_show.cli.control_client import add_client_arguments, control_client

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``ctl`` subcommand."""
    parser = sub.add_parser(
        "ctl",
        help="control a running xgo-show serve (start, stop, pause, status, ...)",
        description="Send one command to the xgo-show serve of the namespace and print its "
        "reply: load, start, stop, pause, resume, seek, panic, status, or watch (print the "
        "show's events as they come).",
        epilog=(
            "example:\n"
            "  xgo-show ctl load choreographies/curtain_call.yaml\n"
            "  xgo-show ctl start --in 2\n"
            "  xgo-show ctl seek --section finale\n"
            "  xgo-show ctl status"
        ),
    )
    cmds = parser.add_subparsers(dest="ctl", metavar="COMMAND")
    cmds.required = True
    load = cmds.add_parser("load", help="load a routine or schedule (a path on the server)")
    load.add_argument("path", metavar="SHOW")
    start = cmds.add_parser("start", help="start the loaded show (now, --in S or --at TIME)")
    when = start.add_mutually_exclusive_group()
    when.add_argument("--in", dest="in_", type=float, metavar="S", help="start in S seconds")
    when.add_argument("--at", type=float, metavar="UNIX", help="start at this Unix time")
    start.add_argument("--force", action="store_true", help="start even if pre-flight fails")
    _place(start, required=False)
    stop = cmds.add_parser("stop", help="stop the show (every robot safe-stopped)")
    stop.add_argument("--reason", default="stop requested by xgo-show ctl")
    cmds.add_parser("pause", help="pause (robots held at rest)")
    cmds.add_parser("resume", help="resume a paused show")
    seek = cmds.add_parser("seek", help="jump to a time, bar or section")
    _place(seek, required=True)
    cmds.add_parser("panic", help="safe-stop everything now (always accepted)")
    cmds.add_parser("status", help="what is loaded, where the show is, every robot")
    watch = cmds.add_parser("watch", help="print the show's events until Ctrl-C")
    watch.add_argument("--for", dest="for_", type=float, metavar="S",
                       help="stop after S seconds")
    for command in cmds.choices.values():
        command.add_argument("--json", action="store_true", help="print the reply as JSON")
        add_client_arguments(command)
    parser.set_defaults(func=run)


def _place(parser: argparse.ArgumentParser, *, required: bool) -> None:
    where = parser.add_mutually_exclusive_group(required=required)
    where.add_argument("--time", type=float, metavar="S", help="show time in seconds")
    where.add_argument("--bar", type=int, metavar="N", help="bar N (from 1)")
    where.add_argument("--section", metavar="NAME", help="a section's start")


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show ctl``."""
    with control_client(args) as client:
        if args.ctl == "watch":
            return _watch(client.session, client.ns, args.for_)
        if args.ctl == "status":
            reply = client.status()
        else:
            fields: dict[str, Any] = {}
            if args.ctl == "load":
                fields["path"] = args.path
            elif args.ctl == "stop":
                fields["reason"] = args.reason
            if args.ctl in ("start", "seek"):
                fields.update(time=args.time, bar=args.bar, section=args.section)
            if args.ctl == "start":
                fields.update({"in": args.in_, "at": args.at, "force": args.force or None})
            reply = client.command(args.ctl, **fields)
    print(json.dumps(reply, indent=1) if args.json else describe(args.ctl, reply))
    return 0


def describe(command: str, reply: dict[str, Any]) -> str:
    """A reply in a few lines for people."""
    if command == "status":
        return _status_text(reply)
    rest = {k: v for k, v in reply.items() if k not in ("v", "ok", "command")}
    if command == "load":
        show = rest.get("show", {})
        trig = ", ".join(show.get("triggers", [])) or "none"
        return (f"loaded {show.get('name')!r}: {show.get('duration', 0):.1f} s, "
                f"{len(show.get('performers', []))} performer(s), triggers: {trig}")
    if command == "start":
        start = time.strftime("%H:%M:%S", time.localtime(rest.get("start_time", 0)))
        return f"starting {rest.get('show')!r} from {rest.get('offset', 0):g} s at {start}"
    return f"{command}: ok" + (f" ({json.dumps(rest)})" if rest else "")


def _status_text(s: dict[str, Any]) -> str:
    show = s.get("show") or {}
    lines = [f"state: {s.get('state')}" + (f", show {show.get('name')!r}" if show else "")]
    if "show_time" in s:
        where = f"{s['show_time']:.2f} / {s.get('duration', 0):.2f} s"
        if "bar" in s:
            where += f", bar {s['bar']} beat {s['beat']:g}"
        if s.get("section"):
            where += f", section {s['section']}"
        lines.append(where)
    if s.get("waiting_for"):
        w = s["waiting_for"]
        lines.append(f"waiting for trigger {w['trigger']!r} (section {w['section']})")
    for name, r in (s.get("robots") or {}).items():
        battery = "" if r.get("battery") is None else f", battery {r['battery']:g}"
        fault = f", FAULT {r['fault']}" if r.get("fault") else ""
        lines.append(f"  {name}: {r['state']}, cue {r.get('cue') or '-'}{battery}{fault}")
    last = s.get("last_result")
    if last and s.get("state") in ("idle", "loaded"):
        lines.append(f"last show: {last.get('show')!r} {last.get('reason')}")
    return "\n".join(lines)


def _watch(session: Any, ns: str, seconds: float | None) -> int:
    import threading

    from xgo_show.control.keys import event_key

    done = threading.Event()

    def show(sample: Any) -> None:
        print(f"{sample.key_expr}: {sample.payload.to_string()}", flush=True)

    sub = session.declare_subscriber(event_key(ns), show)
    try:
        done.wait(seconds)
    except KeyboardInterrupt:
        pass
    finally:
        sub.undeclare()
    return 0
