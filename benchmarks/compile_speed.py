"""Compile time of a long, busy show: 10 performers, 10 minutes, 50 Hz trajectories.

The show is generated (no YAML): each performer moves several registers continuously, one
jerk-limited move after another with targets from a fixed pseudo-random sequence (seeded, so
every run compiles the same show). Dogs (Mini) move body_z, roll, pitch and yaw; Riders move
body_z and roll and fade two LEDs. Prints figures only (no asserts). Usage::

    python benchmarks/compile_speed.py [--minutes 10] [--performers 10] [--rate 50]
"""

from __future__ import annotations

import argparse
import os
import random
import time

from xgo_show.choreo.resolved import Cue, FadeCue, MotionCue, ResolvedShow, ResolvedTrack
from xgo_show.compiler import compile_show
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile

MOVE = 2.0  # seconds per move: every register is in motion all the time
DOG_REGISTERS = ("body_z", "roll", "pitch", "yaw")
RIDER_REGISTERS = ("body_z", "roll")


def build_show(minutes: float = 10.0, performers: int = 10, rate: float = 50.0) -> ResolvedShow:
    """The benchmark show: 8 Minis and 2 Riders (for 10 performers), all moving all the time."""
    rng = random.Random(1234)
    tracks = []
    for i in range(performers):
        model = "rider" if i % 5 == 4 else "mini"
        profile = get_profile(model)
        names = RIDER_REGISTERS if model == "rider" else DOG_REGISTERS
        cues: list[Cue] = []
        t, n = 0.0, 0
        while t + MOVE <= minutes * 60:
            targets = {}
            for name in names:
                reg = profile.register(name)
                assert reg.minimum is not None and reg.maximum is not None
                span = reg.maximum - reg.minimum
                targets[name] = round(reg.minimum + span * (0.15 + 0.7 * rng.random()), 1)
            origin = Origin("bench.yaml", n + 1, 5, f"p{i}: move {n}")
            cues.append(MotionCue(t, origin, targets, duration=MOVE))
            if model == "rider":
                colour = (rng.randrange(256), rng.randrange(256), rng.randrange(256))
                cues.append(FadeCue(t, origin, "led1", colour, MOVE))
                cues.append(FadeCue(t, origin, "led2", colour[::-1], MOVE))
            t += MOVE
            n += 1
        tracks.append(ResolvedTrack(f"p{i}", model, tuple(cues)))
    return ResolvedShow("benchmark", "bench.yaml", tuple(tracks), control_rate=rate)


def show_arguments(doc: str, minutes: float) -> argparse.Namespace:
    """The benchmark show's size from the command line (also wire_bytes.py's)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=minutes)
    parser.add_argument("--performers", type=int, default=10)
    parser.add_argument("--rate", type=float, default=50.0)
    return parser.parse_args()


def main() -> None:
    args = show_arguments(__doc__, 10.0)
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
