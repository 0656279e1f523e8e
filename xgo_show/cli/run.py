"""``xgo-show run``: play a show on robots (or, with ``--sim``, on simulators over real ptys).

Stages, in order; nothing moves before the last one: load (YAML -> compile, or a compiled
``.xshow.json``) -> refuse unsafe registers -> open every port -> pre-flight (firmware model,
battery) -> countdown -> run. Ctrl-C, SIGTERM or any fault ends in a safe stop of every robot.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from xgo_show.audio.soundtrack import parse_latency
from xgo_show.audio.soundtrack import prepare as prepare_music
from xgo_show.cli.live import LiveView
from xgo_show.compiler.artifact import is_schedule_file
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.rehearsal import check_triggers, directed
from xgo_show.errors import FileAccessError, RuntimeFault, UsageError
from xgo_show.files import file_problem
from xgo_show.relay.options import (
    ConductorOptions,
    close_session,
    conductor_options,
    guard_local_ports,
    use_relays,
)
from xgo_show.runtime.clock import FakeClock, MonotonicClock
from xgo_show.runtime.events import ProgressTick
from xgo_show.runtime.launch import Launch
from xgo_show.runtime.preflight import countdown
from xgo_show.runtime.realtime import add_realtime_arguments, decide
from xgo_show.runtime.report import ProgressPrinter, format_report
from xgo_show.runtime.runlog import RunLog
from xgo_show.sim.bench import SimBench, format_summaries
from xgo_show.timecode.follow import Follow, parse_timecode

__all__ = [
    "PlayOptions",
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
        "--in-process",
        action="store_true",
        help="drive local ports from this process instead of a relay child: starts about a "
        "second sooner, but kill -9 of this process (or the OOM killer) then leaves robots "
        "moving",
    )
    add_common_arguments(parser)
    parser.set_defaults(func=run)


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments shared by ``run`` and ``dry-run`` (:func:`play_options` reads them)."""
    parser.add_argument("show", metavar="SHOW", help="SHOW.yaml or SCHEDULE.xshow.json")
    add_realtime_arguments(parser)
    parser.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="NAME=PORT",
        help="port or URL of a performer (repeatable); overrides the show file and --sim; "
        "zenoh:RELAY/ROBOT plays it on a robot behind an xgo-show relay",
    )
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
    parser.add_argument(
        "--no-music", action="store_true", help="do not play the show's music (music: in SHOW)"
    )
    parser.add_argument(
        "--audio-device",
        choices=("default", "null"),
        default="default",
        help="where the music plays: the default output, or the null device (on time, no sound)",
    )
    parser.add_argument(
        "--latency",
        action="append",
        default=[],
        metavar="NAME=MS",
        help="an output's own delay in ms (repeatable): that performer, or the music (music=40), "
        "acts so much earlier",
    )
    parser.add_argument(
        "--follow",
        metavar="SOURCE",
        help="let the sound desk drive the show: osc:[HOST:]PORT (OSC cues /go /pause /resume "
        "/seek /bar /stop) or mtc:MIDI-PORT (chase MIDI timecode; needs python-rtmidi)",
    )
    parser.add_argument(
        "--chase-policy",
        choices=("hold", "stop"),
        default="hold",
        help="on a timecode jump or dropout: hold the robots and follow again, or stop the show",
    )
    parser.add_argument(
        "--timecode-origin",
        default="0",
        metavar="TC",
        help="the timecode of show time 0, HH:MM:SS:FF or seconds (default 0)",
    )
    parser.add_argument(
        "--triggers",
        metavar="SCRIPT",
        help="fire the show's triggers from this script (a timed list, see "
        "docs/choreography.md): rehearse a show whose sections wait for triggers",
    )
    from xgo_show.relay.options import add_conductor_arguments

    add_conductor_arguments(parser)


def check_options(args: argparse.Namespace) -> None:
    """Refuse option values that make no sense (a negative countdown, a floor above 100 %)."""
    countdown = getattr(args, "countdown", None)
    if countdown is not None and not (math.isfinite(countdown) and 0 <= countdown <= 3600):
        raise UsageError(f"--countdown {countdown:g}: give 0 to 3600 seconds")
    floor = args.battery_floor
    if floor is not None and not 0 <= floor <= 100:
        raise UsageError(f"--battery-floor {floor:g}: give a percentage from 0 to 100")


def load_schedule_file(path: str | Path) -> Schedule:
    """A schedule file, or a routine compiled now (``run``, ``dry-run`` and ``inspect``).

    A schedule is a ``.json`` file, or JSON with the schedule format tag whatever its name (a
    schedule saved as ``.yaml``); anything else is read as a routine.
    """
    path = Path(path)
    problem = file_problem(path)
    if problem is not None:
        raise FileAccessError(f"{path}: {problem}")
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
            raise UsageError("--start-bar needs a show with a tempo (bpm); use --start SECONDS")
        if bar < 1:
            raise UsageError(f"--start-bar {bar}: bars count from 1")
        seconds = tempo.position(bar)  # the tempo map: right across tempo changes
    if seconds is None:
        return 0.0
    if not 0.0 <= seconds < schedule.duration:
        raise UsageError(
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
            raise UsageError(f"--map {item!r}: write NAME=PORT, e.g. rex=/dev/ttyUSB0")
        if name not in names:
            raise UsageError(
                f"--map {item!r}: no performer {name!r}; performers: {', '.join(names)}"
            )
        if name in out:
            raise UsageError(
                f"--map {item!r}: {name} is already mapped to {out[name]}; map each performer once"
            )
        out[name] = port
    return out


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
    realtime: str | None = None  # --realtime / --no-realtime (None: auto, or XGO_SHOW_REALTIME)
    allow_unsafe: bool = False
    telemetry: bool = True
    music: bool = True
    audio_device: str = "default"
    follow: str | None = None  # --follow SOURCE
    chase_policy: str = "hold"
    timecode_origin: float = 0.0
    latency: list[str] = field(default_factory=list)  # NAME=MS, checked by play()
    relays: ConductorOptions | None = None  # how to reach relays (zenoh: performers)
    guard: bool = False  # local ports owned by a relay child (run, unless --in-process)
    triggers: str | None = None  # a trigger script (shows whose sections wait for triggers)


def play_options(args: argparse.Namespace, schedule: Schedule, **own: Any) -> PlayOptions:
    """The options :func:`add_common_arguments` added, plus the command's ``own`` fields."""
    return PlayOptions(
        offset=start_offset(schedule, args.start, args.start_bar),
        battery_floor=args.battery_floor,
        log=args.log,
        allow_unsafe=args.allow_unsafe,
        triggers=args.triggers,
        telemetry=not args.no_telemetry,
        music=not args.no_music,
        audio_device=args.audio_device,
        follow=args.follow,
        chase_policy=args.chase_policy,
        timecode_origin=parse_timecode(args.timecode_origin),
        latency=args.latency,
        relays=conductor_options(args),
        realtime=args.realtime,
        **own,
    )


def play(schedule: Schedule, opts: PlayOptions) -> int:
    """Run ``schedule`` with ``opts``: the launch stages, printing pre-flight, progress and
    the report (and, on simulators, what each robot did)."""
    out = sys.stdout
    script = check_triggers(schedule, opts.triggers, follow=opts.follow)  # before any open
    decide(opts.realtime, virtual=opts.fast)  # the writer threads raise themselves
    sim_names = [p.name for p in schedule.performers if p.name not in opts.maps] if opts.sim else []
    music = prepare_music(schedule, enabled=opts.music, fast=opts.fast, device=opts.audio_device)
    outputs = [p.name for p in schedule.performers] + ([music.name] if music.build else [])
    latency = parse_latency(opts.latency, outputs)
    # run: a relay child owns the local ports, so that kill -9 of this process stops the robots.
    maps, relay_opts, child = (
        guard_local_ports(schedule, opts.maps, opts.relays, sim_names, opts)
        if opts.guard and not opts.fast
        else (opts.maps, opts.relays, None)
    )
    relayed = use_relays(maps, relay_opts, fast=opts.fast, schedule=schedule, simulated=sim_names)
    # The launch refuses unsafe writes before anything opens (no log, no simulator, no port).
    launch = Launch(
        schedule,
        maps,
        clock=FakeClock(time.monotonic(), keep_waits=False) if opts.fast else MonotonicClock(),
        battery_floor=opts.battery_floor,
        allow_unsafe=opts.allow_unsafe,
        telemetry=opts.telemetry and not opts.fast,
        extra_performers=[music.build] if music.build else [],
        latency=latency,
        **relayed,
    )
    with contextlib.ExitStack() as stack:
        if relayed:
            stack.callback(close_session)
        if child is not None:
            stack.enter_context(child)  # started now: unsafe writes were refused above
        log = stack.enter_context(RunLog(opts.log, keep=False))  # memory: nothing kept
        sims = stack.enter_context(SimBench(schedule, sim_names)) if sim_names else None
        if sims is not None:
            launch.map(sims.urls)
        stack.enter_context(launch)
        stack.callback(music.close)
        follow = None
        if opts.follow:
            if opts.fast:
                raise UsageError("--follow needs real time: leave out --fast")
            follow = Follow(opts.follow, schedule, clock=launch.clock, out=out,
                            offset=opts.offset,
                            policy="stop" if opts.chase_policy == "stop" else "hold",
                            origin=opts.timecode_origin)
            stack.callback(follow.close)
        log.attach(launch.events)
        if launch.unsafe:
            print(f"warning: {len(launch.unsafe)} unsafe write(s) allowed by --allow-unsafe",
                  file=out)
            log.event("unsafe_allowed", writes=launch.unsafe)
        if music.note:
            print(music.note, file=out)
        launch.open()
        report = launch.preflight()  # its table says what real-time scheduling was decided
        print(report.table(), file=out, flush=True)
        runner = launch.arm(force=opts.force)
        if not report.ok:
            print("warning: pre-flight failed; starting anyway because of --force", file=out)
        offset, start_at = opts.offset, None
        if follow is not None:
            print(follow.note, file=out, flush=True)
            follow.runner = launch.runner
            offset, start_at = follow.wait_for_start()
        else:
            countdown(opts.countdown, out=out)
        live = LiveView(schedule, out) if out.isatty() else None
        printer = ProgressPrinter(tempo=schedule.tempo(), out=out)
        launch.events.subscribe(live.on_event if live else printer.on_event, ProgressTick)
        where = f" from {offset:g} s" if offset else ""
        print(
            f"running {schedule.name!r}{where}: {len(schedule.performers)} performer(s), "
            f"{schedule.duration:.1f} s",
            file=out,
            flush=True,
        )
        say = lambda line: print(line, file=out, flush=True)  # noqa: E731
        with directed(runner, launch.clock, script, say=say) as director:
            if follow is not None:
                follow.director = director  # the desk's cues keep the waits (None: none)
            result = launch.run(offset=offset, start_at=start_at)
        if live is not None:
            live.finish(runner.snapshot(), completed=result.completed)
        printer.finish()
        print(format_report(result), file=out, flush=True)
        if sims is not None:
            sims.settle()
            summaries = sims.summaries()
            for name, summary in summaries.items():
                log.write("sim", flush=True, performer=name, **dataclasses.asdict(summary))
            print(format_summaries(summaries, fast=opts.fast), file=out, flush=True)
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
        guard=not args.in_process,
    )
    return play(schedule, opts)
