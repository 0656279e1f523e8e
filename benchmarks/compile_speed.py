"""Compile time of a long, busy show: 10 performers, 10 minutes, 50 Hz trajectories.

The show is generated: each performer moves several registers continuously, one jerk-limited
move after another with targets from a fixed pseudo-random sequence (seeded, so every run
compiles the same show). Dogs (Mini) move body_z, roll, pitch and yaw; Riders move body_z and
roll and fade two LEDs. :func:`build_show` makes it in memory (what this script times: the
compiler alone); :func:`show_yaml` writes the same show as a routine, for what a user meets
(``compile_cli.py`` times ``xgo-show compile`` of it). Prints figures only (no asserts). Usage::

    python benchmarks/compile_speed.py [--minutes 10] [--performers 10] [--rate 50]
    python benchmarks/compile_speed.py --yaml show.yaml     # write the routine instead
"""

from __future__ import annotations

import argparse
import os
import random
import time
from collections.abc import Callable
from typing import NamedTuple

from xgo_show.choreo.resolved import Cue, FadeCue, MotionCue, ResolvedShow, ResolvedTrack
from xgo_show.compiler import compile_show
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile

MOVE = 2.0  # seconds per move: every register is in motion all the time
DOG_REGISTERS = ("body_z", "roll", "pitch", "yaw")
RIDER_REGISTERS = ("body_z", "roll")


class _Move(NamedTuple):
    start: float
    targets: dict[str, float]
    colour: tuple[int, int, int] | None  # Riders: led1 fades to it, led2 to its reverse


def _moves(minutes: float, performers: int) -> list[tuple[str, list[_Move]]]:
    """Each performer's model and moves, from the seeded sequence (both forms share it)."""
    rng = random.Random(1234)
    out = []
    for i in range(performers):
        model = "rider" if i % 5 == 4 else "mini"
        profile = get_profile(model)
        names = RIDER_REGISTERS if model == "rider" else DOG_REGISTERS
        moves: list[_Move] = []
        t = 0.0
        while t + MOVE <= minutes * 60:
            targets = {}
            for name in names:
                reg = profile.register(name)
                assert reg.minimum is not None and reg.maximum is not None
                span = reg.maximum - reg.minimum
                targets[name] = round(reg.minimum + span * (0.15 + 0.7 * rng.random()), 1)
            colour = None
            if model == "rider":
                colour = (rng.randrange(256), rng.randrange(256), rng.randrange(256))
            moves.append(_Move(t, targets, colour))
            t += MOVE
        out.append((model, moves))
    return out


def build_show(minutes: float = 10.0, performers: int = 10, rate: float = 50.0) -> ResolvedShow:
    """The benchmark show: 8 Minis and 2 Riders (for 10 performers), all moving all the time."""
    tracks = []
    for i, (model, moves) in enumerate(_moves(minutes, performers)):
        cues: list[Cue] = []
        for n, move in enumerate(moves):
            origin = Origin("bench.yaml", n + 1, 5, f"p{i}: move {n}")
            cues.append(MotionCue(move.start, origin, move.targets, duration=MOVE))
            if move.colour is not None:
                cues.append(FadeCue(move.start, origin, "led1", move.colour, MOVE))
                cues.append(FadeCue(move.start, origin, "led2", move.colour[::-1], MOVE))
        tracks.append(ResolvedTrack(f"p{i}", model, tuple(cues)))
    return ResolvedShow("benchmark", "bench.yaml", tuple(tracks), control_rate=rate)


def show_yaml(minutes: float = 10.0, performers: int = 10, rate: float = 50.0) -> str:
    """The same show as a routine (YAML): it compiles to the very frames of :func:`build_show`."""
    moves = _moves(minutes, performers)
    lines = [
        "# The compile_speed benchmark show (benchmarks/compile_speed.py --yaml writes it).",
        "show: benchmark",
        f"settings: {{control_rate: {rate:g}}}",
        "performers:",
        *(f"  p{i}: {{model: {model}}}" for i, (model, _) in enumerate(moves)),
        "tracks:",
    ]
    for i, (_, track) in enumerate(moves):
        lines.append(f"  p{i}:")
        for move in track:
            targets = ", ".join(f"{k}: {v:g}" for k, v in move.targets.items())
            lines.append(f"    - {{at: {move.start:g}, move: {{{targets}}}, duration: {MOVE:g}}}")
            if move.colour is not None:
                r, g, b = move.colour
                lines.append(f"    - {{at: {move.start:g}, led: {{led1: [{r}, {g}, {b}], "
                             f"led2: [{b}, {g}, {r}]}}, fade: {MOVE:g}}}")
    return "\n".join(lines) + "\n"


def show_arguments(doc: str, minutes: float,
                   more: Callable[[argparse.ArgumentParser], object] | None = None
                   ) -> argparse.Namespace:
    """The benchmark show's size from the command line (also wire_bytes.py's); ``more`` adds
    a script's own options."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    if more is not None:
        more(parser)
    parser.add_argument("--minutes", type=float, default=minutes)
    parser.add_argument("--performers", type=int, default=10)
    parser.add_argument("--rate", type=float, default=50.0)
    parser.add_argument("--yaml", metavar="PATH", help="write the show as a routine and exit")
    return parser.parse_args()


def main() -> None:
    args = show_arguments(__doc__, 10.0)
    if args.yaml:
        with open(args.yaml, "w", encoding="utf-8") as fh:
            fh.write(show_yaml(args.minutes, args.performers, args.rate))
        print(f"wrote {args.yaml}")
        return
    show = build_show(args.minutes, args.performers, args.rate)
    cues = sum(len(t.cues) for t in show.tracks)
    t0, c0 = time.perf_counter(), time.process_time()
    schedule = compile_show(show)
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    frames = sum(len(p.frames) for p in schedule.performers)
    nbytes = sum(p.total_bytes for p in schedule.performers)
    print(f"show: {args.performers} performers, {args.minutes:g} min, {args.rate:g} Hz, "
          f"{cues} cues")
    print(f"compile time: {elapsed:.2f} s wall, {cpu:.2f} s CPU  (target < 2 s); "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(f"frames: {frames}  bytes: {nbytes}  ({frames / elapsed:,.0f} frames/s)")


if __name__ == "__main__":
    main()
