"""``xgo-show behave``: run a behaviour on robots, on simulators, or rehearse it from a script.

``xgo-show behave FILE --check`` loads the behaviour (every routine compiled, every name
checked) and lists its rules. ``--sim`` runs it on one simulated robot per performer, each on
its own pseudo-terminal; without it, on the performers' ports (``port:`` in the file, or
``--map NAME=PORT``). ``--script EVENTS.yaml`` plays timed triggers and things happening to the
simulated robots (falls, battery levels, going offline) and ends after the script's duration;
``--fast`` rehearses the script on virtual robots and virtual time, without waiting. Each
decision is printed with its time: what fired, and what each robot did. A performer whose port
is ``zenoh:RELAY/ROBOT`` plays on a robot behind an ``xgo-show relay``
(:mod:`xgo_show.behave.relayed`): its telemetry comes back with the relay's heartbeats, and a
relay silent for ``--watchdog-ms`` makes its robots offline.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import threading
import time
from collections.abc import Iterator
from typing import Any

from xgo_show.errors import SetupError, UsageError
from xgo_show.net.keys import is_relay_url
from xgo_show.runtime.events import EventBus
from xgo_show.runtime.realtime import add_realtime_arguments, decide

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register the ``behave`` subcommand."""
    parser = sub.add_parser(
        "behave",
        help="run rules that react to triggers and telemetry (or check or rehearse them)",
        description=(
            "Run BEHAVIOUR.yaml: rules that play routines when triggers fire, telemetry "
            "crosses a threshold or a timer is due. Every routine it may play is compiled and "
            "every name checked first. Runs on the performers' ports, on simulators (--sim), "
            "or rehearses a script on virtual time (--script with --fast)."
        ),
        epilog=(
            "example:\n"
            "  xgo-show behave behaviours/exhibition/exhibition.yaml --check\n"
            "  xgo-show behave behaviours/exhibition/exhibition.yaml --sim --fast "
            "--script behaviours/exhibition/rehearsal.yaml\n"
            "  xgo-show behave behaviours/exhibition/exhibition.yaml --map rex=/dev/ttyAMA0"
        ),
    )
    parser.add_argument("behaviour", metavar="BEHAVIOUR.yaml", help="the behaviour file")
    parser.add_argument("--check", action="store_true",
                        help="load and check the file, list its rules, and exit")
    parser.add_argument(
        "--script", metavar="EVENTS.yaml",
        help="a rehearsal script: timed triggers, falls, battery levels, robots going offline",
    )
    parser.add_argument("--sim", action="store_true",
                        help="on simulated robots (one pseudo-terminal each)")
    parser.add_argument("--fast", action="store_true",
                        help="rehearse the script on virtual time, without waiting")
    add_realtime_arguments(parser)
    parser.add_argument("--log", metavar="FILE",
                        help="write the run log (JSON lines) to FILE: every rule decision, "
                             "frame, telemetry reading and state change")
    parser.add_argument("--serve", action="store_true",
                        help="take triggers from any Zenoh client on NS/trigger/NAME (as "
                             "xgo-show serve does) and publish each rule decision on "
                             "NS/event/rule")
    parser.add_argument("--map", action="append", default=[], metavar="NAME=PORT",
                        help="a performer's port (repeatable; default: port: in the file)")
    parser.add_argument("--watchdog-ms", type=int, default=500, metavar="MS",
                        help="robots behind relays (port zenoh:RELAY/ROBOT): silence after "
                             "which a relay counts as lost (its robots offline) and safe-stops "
                             "them (default 500)")
    from xgo_show.net.session import add_session_arguments

    add_session_arguments(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show behave``."""
    from xgo_show.behave import load_behaviour

    behaviour = load_behaviour(args.behaviour)
    model = behaviour.model
    if args.check:
        print(f"{args.behaviour}: behaviour {model.behaviour!r}: {len(model.rules)} rules, "
              f"{len(behaviour.routines)} routines compiled, performers "
              f"{', '.join(model.performers)}")
        for rule in model.rules:
            rank = ("safety, " if rule.safety else "") + f"priority {rule.priority}"
            print(f"  {rule.name}: {len(rule.when)} trigger(s), {len(rule.do)} action(s), "
                  f"{rule.mode}, {rank}")
        return 0
    script = None
    if args.script is not None:
        from xgo_show.behave.rehearsal import load_rehearsal

        script = load_rehearsal(args.script, behaviour)
        if not args.sim and not args.fast:
            raise UsageError("a script happens to simulated robots: add --sim (or --fast)")
    elif args.fast:
        raise UsageError("--fast rehearses a script: give --script EVENTS.yaml")
    if args.fast and args.serve:
        raise UsageError("--serve takes triggers in real time: leave out --fast")
    if script is not None and args.fast:
        from xgo_show.behave.rehearsal import rehearse

        print(f"rehearsing {model.behaviour!r} for {script.duration:g} s from {script.start} "
              f"(virtual time)")
        with _run_log(args.log) as bus:
            rehearse(behaviour, script, lambda t, line: print(f"{t:9.2f}  {line}"), bus)
        return 0
    decide(args.realtime)  # the writer threads raise themselves (docs/realtime.md)
    return _run_live(args, behaviour, script)


@contextlib.contextmanager
def _run_log(path: str | None) -> Iterator[EventBus]:
    """An event bus whose events go to the run log at ``path`` (if given) while it is open."""
    bus = EventBus()
    if path is None:
        yield bus
        return
    from xgo_show.behave.runlog import attach_behaviour_log
    from xgo_show.runtime.runlog import RunLog

    with RunLog(path, keep=False) as log:
        subs = attach_behaviour_log(log, bus)
        try:
            yield bus
        finally:
            for sub in subs:
                sub.close()


def _run_live(args: argparse.Namespace, behaviour: Any, script: Any) -> int:
    with _run_log(args.log) as bus:
        return _run_ports(args, behaviour, script, bus)


def _run_ports(args: argparse.Namespace, behaviour: Any, script: Any, bus: EventBus) -> int:
    from xgo_show.behave.ports import BehaviourRunner
    from xgo_show.sim import create_robot
    from xgo_show.sim.pty_server import PtyServer
    from xgo_show.transports import open_transport

    model = behaviour.model
    servers: dict[str, PtyServer] = {}
    transports = {}
    stack = contextlib.ExitStack()
    try:
        if args.sim:
            battery = script.battery if script is not None else 100.0
            for name, ref in model.performers.items():
                servers[name] = PtyServer(create_robot(ref.model, battery=battery)).start()
            ports = {name: s.path for name, s in servers.items()}
        else:
            ports = {n: r.port for n, r in model.performers.items() if r.port}
            for item in args.map:
                name, sep, port = item.partition("=")
                if not sep or name not in model.performers:
                    raise UsageError(f"--map {item}: give NAME=PORT for a performer of the "
                                       f"behaviour ({', '.join(model.performers)})")
                ports[name] = port
            missing = [n for n in model.performers if n not in ports]
            if missing:
                raise SetupError(f"no port for {', '.join(missing)}: give --map NAME=PORT "
                                   "(or --sim)")
        relayed = {n: p for n, p in ports.items() if is_relay_url(p)}
        session: Any = None
        if relayed or args.serve:
            session = stack.enter_context(_session(args))
        for name, port in ports.items():
            if name in relayed:
                continue
            transport = open_transport(port)
            transport.open()
            transports[name] = transport
        start = time.monotonic()
        relays = None
        if relayed:
            from xgo_show.behave.relayed import RelayAccess
            from xgo_show.relay.client import new_conductor

            if not 50 <= args.watchdog_ms <= 60_000:
                raise UsageError(f"--watchdog-ms {args.watchdog_ms}: give 50 to 60000")
            relays = RelayAccess(relayed, session, new_conductor(), namespace=args.namespace,
                                 watchdog=args.watchdog_ms / 1000)
        runner = BehaviourRunner(
            behaviour, transports, events=bus, relays=relays,
            say=lambda t, line: print(f"{t - start:9.2f}  {line}"),
        )
        if args.serve:
            stack.enter_context(_serve(session, args.namespace, runner, model.triggers))
        if script is not None:
            feeder = threading.Thread(target=_play_script, args=(script, runner, servers, start),
                                      daemon=True)
            feeder.start()
        where = "simulated robots" if args.sim else "robots on " + ", ".join(ports.values())
        print(f"behaviour {model.behaviour!r} on {where}" +
              (f" for {script.duration:g} s" if script else " (Ctrl-C ends it with a safe stop)"))
        with _stopped_by_signals(runner) as stopped:
            runner.run(None if script is None else script.duration)
        if stopped:
            print("stopped: every robot was safe-stopped")
        return 0
    finally:
        stack.close()
        for transport in transports.values():
            transport.close()
        for server in servers.values():
            server.close()


@contextlib.contextmanager
def _stopped_by_signals(runner: Any) -> Iterator[list[int]]:
    """Ctrl-C and SIGTERM end ``runner`` (safe-stopping the robots) while the context is open;
    the list it gives holds the signals received.

    A handler, not a KeyboardInterrupt: an exception raised between any two bytecodes of the
    engine's thread could leave a hand-over half done, and the safe stop waiting on it.
    """
    got: list[int] = []

    def on_signal(signum: int, frame: Any) -> None:
        got.append(signum)
        runner.stop()

    saved = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield got
    finally:
        for sig, old in saved.items():
            signal.signal(sig, old)


@contextlib.contextmanager
def _session(args: argparse.Namespace) -> Iterator[Any]:
    """One Zenoh session (for --serve and the relays) while the context is open."""
    from xgo_show.net.session import open_session, session_options

    session = open_session(session_options(args))
    try:
        yield session
    finally:
        session.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type


@contextlib.contextmanager
def _serve(session: Any, namespace: str, runner: Any, triggers: list[str]) -> Iterator[None]:
    """Take the behaviour's triggers over Zenoh while the context is open."""
    from xgo_show.behave.remote import BehaviourService
    from xgo_show.control.keys import event_key, trigger_key

    service = BehaviourService(session, namespace, runner, triggers)
    print(f"serving triggers on {trigger_key(namespace)}; rule decisions on "
          f"{event_key(namespace, 'rule')}")
    try:
        yield
    finally:
        service.close()


def _play_script(script: Any, runner: Any, servers: dict[str, Any], start: float) -> None:
    """Apply the script's cues at their times (seconds from ``start``)."""
    for ev in sorted(script.events, key=lambda e: e.at):
        delay = start + ev.at - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        print(f"{time.monotonic() - start:9.2f}  script: {_describe(ev)}")
        if ev.trigger is not None:
            runner.trigger(ev.trigger)
            continue
        server = servers[ev.performer]
        if ev.offline or ev.online:
            server.offline = bool(ev.offline)
            continue
        with server.lock:
            robot = server.robot
            if ev.fall:
                robot.fall()
            elif ev.recover:
                robot.recover()
            elif ev.battery is not None:
                robot.set_battery(ev.battery)


def _describe(ev: Any) -> str:
    if ev.trigger is not None:
        return f"trigger {ev.trigger}"
    what = next(k for k in ("fall", "recover", "battery", "offline", "online")
                if getattr(ev, k) is not None)
    value = f" {ev.battery:g}%" if what == "battery" else ""
    return f"{ev.performer} {what}{value}"
