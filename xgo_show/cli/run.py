"""``xgo-show run``: play a show on robots (or, with ``--sim``, on simulators over real ptys).

Stages, in order; nothing moves before the last one: load (YAML -> compile, or a compiled
``.xshow.json``) -> refuse unsafe registers -> open every port -> pre-flight (firmware model,
battery) -> countdown -> run. Ctrl-C, SIGTERM or any fault ends in a safe stop of every robot.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from xgo_show.compiler.artifact import is_schedule_file
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import RuntimeFault, XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.preflight import (
    PreflightError,
    countdown,
    open_ports,
    preflight,
    request_realtime,
)
from xgo_show.runtime.report import ProgressPrinter, format_report
from xgo_show.runtime.runlog import RunLog
from xgo_show.runtime.safety import check_unsafe
from xgo_show.runtime.show_runner import ShowRunner
from xgo_show.sim import PtyServer, create_robot

__all__ = [
    "PlayOptions",
    "SimBench",
    "add_common_arguments",
    "add_parser",
    "check_options",
    "load_schedule_file",
    "play",
    "play_options",
    "run",
    "start_offset",
]

SIGNAL_REASONS = ("SIGINT", "SIGTERM")


def add_parser(sub: Any) -> None:
    """Register the ``run`` subcommand."""
    parser = sub.add_parser(
        "run",
        help="run a show on robots (or simulators with --sim)",
        description=(
            "Run a show: compile SHOW.yaml (or load a compiled SCHEDULE.xshow.json), check "
            "every robot (port, firmware model, battery), count down, then send every frame "
            "on time. Ctrl-C, SIGTERM or any fault safe-stops every robot."
        ),
        epilog=(
            "While the show runs, Ctrl-Z pauses it (robots held at rest) and a second Ctrl-Z "
            "resumes it. Exit status: 0 the show completed; 2 an error, a failed pre-flight or "
            "a fault (every robot was safe-stopped); 130 interrupted by Ctrl-C or SIGTERM.\n\n"
            "example:\n"
            "  xgo-show run choreographies/hello_mini.yaml --map rex=/dev/ttyUSB0\n"
            "  xgo-show run choreographies/mixed_five.yaml --sim --start-bar 40"
        ),
    )
    parser.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="NAME=PORT",
        help="port or URL of a performer (repeatable); overrides the show file and --sim",
    )
    parser.add_argument(
        "--sim",
        action="store_true",
        help="run every performer on a simulated robot served on its own pseudo-terminal",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="start even if firmware or battery checks fail (a port that does not open still "
        "stops the run)",
    )
    parser.add_argument(
        "--countdown",
        type=float,
        default=3.0,
        metavar="S",
        help="seconds of countdown before the start (default 3)",
    )
    parser.add_argument(
        "--realtime",
        action="store_true",
        help=(
            "run the show's threads under SCHED_FIFO priority 10 where permitted (root or "
            "CAP_SYS_NICE), else at nice -10: frames then leave on time although other "
            "programs keep the CPUs busy; helps most with USB serial adapters (a pty's bytes "
            "are moved by a kernel worker that real-time threads do not speed up)"
        ),
    )
    add_common_arguments(parser)
    parser.set_defaults(func=run)


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments shared by ``run`` and ``dry-run`` (:func:`play_options` reads them)."""
    parser.add_argument("show", metavar="SHOW", help="SHOW.yaml or SCHEDULE.xshow.json")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--start", type=float, metavar="SECONDS", help="start mid-show at this show time"
    )
    where.add_argument(
        "--start-bar", type=int, metavar="N", help="start mid-show at bar N (needs the show's bpm)"
    )
    parser.add_argument(
        "--battery-floor",
        type=float,
        metavar="PCT",
        help="lowest battery level allowed, in percent (default: the show's)",
    )
    parser.add_argument("--log", metavar="FILE", help="write the run log (JSON lines) to FILE")
    parser.add_argument(
        "--allow-unsafe",
        action="store_true",
        help="allow frames that write unsafe registers (firmware, calibration, zeroing, ...)",
    )
    parser.add_argument(
        "--no-telemetry",
        action="store_true",
        help="do not poll battery, status and attitude during the show",
    )


def check_options(args: argparse.Namespace) -> None:
    """Refuse option values that make no sense (a negative countdown, a floor above 100 %)."""
    countdown = getattr(args, "countdown", None)
    if countdown is not None and not (math.isfinite(countdown) and countdown >= 0):
        raise XgoShowError(f"--countdown {countdown:g}: give a number of seconds >= 0")
    floor = args.battery_floor
    if floor is not None and not 0 <= floor <= 100:
        raise XgoShowError(f"--battery-floor {floor:g}: give a percentage from 0 to 100")


def load_schedule_file(path: str | Path) -> Schedule:
    """A schedule file, or a routine compiled now (``run``, ``dry-run`` and ``inspect``).

    A schedule is a ``.json`` file, or JSON with the schedule format tag whatever its name (a
    schedule saved as ``.yaml``); anything else is read as a routine.
    """
    path = Path(path)
    if not path.is_file():
        raise XgoShowError(f"{path}: {'is a directory' if path.is_dir() else 'no such file'}")
    if path.suffix.lower() == ".json" or is_schedule_file(path):
        from xgo_show.compiler import load_schedule

        return load_schedule(path)
    from xgo_show.choreo import load_show
    from xgo_show.compiler import compile_show

    return compile_show(load_show(path))


def start_offset(schedule: Schedule, seconds: float | None, bar: int | None) -> float:
    """The show time to start at, from ``--start`` or ``--start-bar``."""
    if bar is not None:
        tempo = schedule.tempo()
        if tempo is None:
            raise XgoShowError("--start-bar needs a show with a tempo (bpm); use --start SECONDS")
        if bar < 1:
            raise XgoShowError(f"--start-bar {bar}: bars count from 1")
        seconds = tempo.position(bar)  # the tempo map: right across tempo changes
    if seconds is None:
        return 0.0
    if not 0.0 <= seconds < schedule.duration:
        raise XgoShowError(
            f"start time {seconds:g} s is outside the show (0 to {schedule.duration:g} s)"
        )
    return seconds


def parse_maps(schedule: Schedule, maps: Sequence[str]) -> dict[str, str]:
    """``NAME=PORT`` options -> {performer: port}, names checked against the show."""
    names = [p.name for p in schedule.performers]
    out: dict[str, str] = {}
    for item in maps:
        name, eq, port = item.partition("=")
        if not eq or not name or not port:
            raise XgoShowError(f"--map {item!r}: write NAME=PORT, e.g. rex=/dev/ttyUSB0")
        if name not in names:
            raise XgoShowError(
                f"--map {item!r}: no performer {name!r}; performers: {', '.join(names)}"
            )
        if name in out:
            raise XgoShowError(
                f"--map {item!r}: {name} is already mapped to {out[name]}; map each performer once"
            )
        out[name] = port
    return out


class SimBench:
    """One simulated robot per performer, each served on its own real pseudo-terminal."""

    def __init__(self, schedule: Schedule, names: Sequence[str], **robot_options: Any) -> None:
        self.servers: dict[str, PtyServer] = {}
        self.initial: dict[str, dict[str, Any]] = {}
        models = {p.name: p.model for p in schedule.performers}
        try:
            for name in names:
                robot = create_robot(models[name], **robot_options)
                self.initial[name] = robot.snapshot()
                self.servers[name] = PtyServer(robot).start()
        except BaseException:
            self.close()
            raise

    @property
    def urls(self) -> dict[str, str]:
        return {name: s.path for name, s in self.servers.items()}

    def summaries(self) -> dict[str, dict[str, Any]]:
        """What each robot ended up doing (JSON-able)."""
        out = {}
        for name, server in self.servers.items():
            snap = server.snapshot()
            with server.lock:
                rejected = [
                    {"hex": f.data.hex(), "reason": f.reason}
                    for f in server.robot.received
                    if not f.accepted
                ]
            out[name] = summarize_sim(snap, self.initial[name], rejected)
        return out

    def close(self) -> None:
        for server in self.servers.values():
            server.close()


def summarize_sim(
    snap: dict[str, Any], initial: dict[str, Any], rejected: list[dict[str, str]]
) -> dict[str, Any]:
    """Final writable registers that differ from the start, actions, frames, rejections."""
    profile = get_profile(snap["model"])
    writable = {r.name for r in profile.registers if r.access.writable and not r.unsafe}
    changed = {
        name: value
        for name, value in snap.get("registers", {}).items()
        if name in writable and initial.get("registers", {}).get(name) != value
    }
    # xArm: servo positions instead of registers.
    for servo, state in snap.get("servos", {}).items():
        before = initial.get("servos", {}).get(servo, {}).get("position")
        if state.get("position") != before:
            changed[f"servo_{servo}"] = state.get("position")
    return {
        "model": snap["model"],
        "changed": changed,
        "raw": {name: snap.get("raw", {}).get(name) for name in changed},
        "actions": [a.get("id") for a in snap.get("actions", [])],
        # For people: "wave (13)", and where an action did not run its course, what cut it.
        "action_names": [_action_text(a) for a in snap.get("actions", [])],
        "frames_received": snap.get("frames_received"),
        "frames_rejected": snap.get("frames_rejected"),
        "rejected": rejected,
        "battery": snap.get("battery", snap.get("battery_mv")),
        "stops": len(snap.get("stops", [])),
        "fallen": snap.get("fallen"),
    }


def format_sim_summaries(summaries: dict[str, dict[str, Any]], *, fast: bool = False) -> str:
    """The dry-run's closing lines: what each simulated robot received and ended up doing."""
    lines = ["simulated robots at the end:"]
    for name, s in summaries.items():
        changed = ", ".join(f"{k}={_short(v)}" for k, v in s["changed"].items()) or "none"
        actions = ", ".join(s["action_names"]) or "none"
        lines.append(
            f"  {name} ({s['model']}): {s['frames_received']} frames received, "
            f"{s['frames_rejected']} rejected; actions run: {actions}"
        )
        lines.append(f"    registers changed: {changed}")
        for r in s["rejected"]:
            lines.append(f"    rejected {r['hex']}: {r['reason']}")
    if fast and any("cut after" in a for s in summaries.values() for a in s["action_names"]):
        lines.append("  (--fast sends frames without waiting, so the simulators see preset actions "
                     "cut short; run without --fast to see them run their course)")
    return "\n".join(lines)


def _action_text(action: dict[str, Any]) -> str:
    text = f"{action.get('name') or 'action'} ({action.get('id')})"
    cut, start = action.get("interrupted_at"), action.get("start")
    if cut is not None and start is not None:
        text += f" cut after {cut - start:.2f} of {action.get('duration', 0.0):.2f} s"
        if action.get("interrupted_by"):
            text += f" by {action['interrupted_by']}"
    return text


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


@dataclass
class PlayOptions:
    """Everything ``run`` and ``dry-run`` decide before playing."""

    maps: dict[str, str] = field(default_factory=dict)
    sim: bool = False
    fast: bool = False
    force: bool = False
    countdown: float = 0.0
    offset: float = 0.0
    battery_floor: float | None = None
    log: str | None = None
    realtime: bool = False
    allow_unsafe: bool = False
    telemetry: bool = True


def play_options(args: argparse.Namespace, schedule: Schedule, **own: Any) -> PlayOptions:
    """The options :func:`add_common_arguments` added, plus the command's ``own`` fields."""
    return PlayOptions(
        offset=start_offset(schedule, args.start, args.start_bar),
        battery_floor=args.battery_floor,
        log=args.log,
        allow_unsafe=args.allow_unsafe,
        telemetry=not args.no_telemetry,
        **own,
    )


@contextlib.contextmanager
def _opened(sims: SimBench | None) -> Iterator[None]:
    try:
        yield
    finally:
        if sims is not None:
            sims.close()


def play(schedule: Schedule, opts: PlayOptions) -> int:
    """Run ``schedule`` with ``opts``; print pre-flight, progress and the report."""
    out = sys.stdout
    profiles = {p.name: get_profile(p.model) for p in schedule.performers}
    unsafe = check_unsafe(schedule, profiles, allow_unsafe=opts.allow_unsafe)
    urls = {p.name: p.port for p in schedule.performers if p.port}
    sim_names = [p.name for p in schedule.performers if p.name not in opts.maps] if opts.sim else []
    sims = SimBench(schedule, sim_names) if sim_names else None
    if sims is not None:
        urls.update(sims.urls)
    urls.update(opts.maps)
    log = RunLog(opts.log)
    transports: dict[str, Any] = {}
    with _opened(sims), log:
        try:
            return _play(schedule, opts, urls, sims, log, transports, unsafe, out)
        finally:
            for t in transports.values():
                t.close()


def _play(
    schedule: Schedule,
    opts: PlayOptions,
    urls: dict[str, str],
    sims: SimBench | None,
    log: RunLog,
    transports: dict[str, Any],
    unsafe: list[str],
    out: Any,
) -> int:
    if unsafe:
        print(f"warning: {len(unsafe)} unsafe write(s) allowed by --allow-unsafe", file=out)
        log.event("unsafe_allowed", writes=unsafe)
    realtime = request_realtime() if opts.realtime else "not requested"
    opened, errors = open_ports(schedule, urls)
    transports.update(opened)
    report = preflight(
        schedule, opened, urls=urls, open_errors=errors, battery_floor=opts.battery_floor
    )
    report.realtime = realtime
    print(report.table(), file=out, flush=True)
    log.event(
        "preflight",
        ok=report.ok,
        forced=opts.force,
        realtime=realtime,
        rows=[
            {
                "performer": r.performer,
                "port": r.port,
                "firmware": r.firmware,
                "battery": r.battery,
                "voltage": r.voltage,
                "low_latency": r.low_latency,
                "problems": r.problems,
            }
            for r in report.rows
        ],
    )
    if not report.ports_ok:
        raise PreflightError("pre-flight failed: a port did not open; nothing was moved")
    if not report.ok:
        if not opts.force:
            raise PreflightError("pre-flight failed; nothing was moved (--force to start anyway)")
        print("warning: pre-flight failed; starting anyway because of --force", file=out)
    countdown(opts.countdown, out=out)
    printer = ProgressPrinter(tempo=schedule.tempo(), out=out)
    runner = ShowRunner(
        schedule,
        opened,
        clock=MonotonicClock(),
        fast=opts.fast,
        telemetry=opts.telemetry,
        battery_floor=opts.battery_floor,
        allow_unsafe=opts.allow_unsafe,
        log=log,
        progress=printer,
    )
    where = f" from {opts.offset:g} s" if opts.offset else ""
    print(
        f"running {schedule.name!r}{where}: {len(schedule.performers)} performer(s), "
        f"{schedule.duration:.1f} s",
        file=out,
        flush=True,
    )
    result = runner.run(offset=opts.offset)
    printer.finish()
    print(format_report(result), file=out, flush=True)
    if sims is not None:
        # Let the pty servers take in the last bytes written before reading their state.
        time.sleep(0.05)
        summaries = sims.summaries()
        for name, summary in summaries.items():
            log.write("sim", flush=True, performer=name, **summary)
        print(format_sim_summaries(summaries, fast=opts.fast), file=out, flush=True)
    if result.completed:
        return 0
    if result.reason in SIGNAL_REASONS:
        print(f"interrupted ({result.reason}): every robot was safe-stopped", file=out)
        return 130
    raise RuntimeFault(f"show stopped: {result.reason}; every robot was safe-stopped")


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show run``."""
    check_options(args)
    schedule = load_schedule_file(args.show)
    opts = play_options(
        args,
        schedule,
        maps=parse_maps(schedule, args.map),
        sim=args.sim,
        force=args.force,
        countdown=args.countdown,
        realtime=args.realtime,
    )
    return play(schedule, opts)
