"""Build a show in Python, without YAML, and compile it.

A :class:`~xgo_show.choreo.resolved.ResolvedShow` is what the YAML loader produces and what the
compiler takes: per performer, cues at absolute times (seconds) with physical values keyed by
register name. Writing it in Python suits generated movement: here a Mini draws circles with
its head (roll and pitch on a circle, one short move per point) and a Rider runs a colour
wheel round its four LEDs (hues computed per LED), then each ends with a preset action.

The YAML loader's checks (names, ranges, overlaps) do not run on a hand-built show; the
compiler still refuses moves that cannot make it in their time and values outside a range.

    python examples/build_show_in_python.py [--circles N] [--frames N] [--save FILE]
"""

from __future__ import annotations

import argparse
import colorsys
import math
import sys
from pathlib import Path

from xgo_show.choreo.resolved import (
    ActionCue,
    Cue,
    FadeCue,
    MotionCue,
    ResolvedShow,
    ResolvedTrack,
    SetCue,
)
from xgo_show.compiler import Schedule, compile_show, save_schedule
from xgo_show.compiler.report import totals_table, transcript
from xgo_show.diagnostics import Origin
from xgo_show.errors import XgoShowError
from xgo_show.profiles import get_profile

SOURCE = "examples/build_show_in_python.py"


def here(label: str) -> Origin:
    """Where a cue came from: shown in transcripts and error messages."""
    return Origin(SOURCE, 0, 0, label)


def head_circles(
    circles: int, *, radius: float = 10.0, points: int = 12, step: float = 0.5
) -> tuple[list[Cue], float]:
    """Mini: rise, draw ``circles`` circles with roll/pitch, wave, settle. (cues, end time)."""
    mini = get_profile("mini")
    cues: list[Cue] = [
        SetCue(0.0, here("settings"), {"gait": "trot", "pace": "normal"}),
        MotionCue(0.0, here("rise"), {"body_z": 105.0}, duration=1.0),
        # To the circle's first point: a longer move, it starts from rest at the centre.
        MotionCue(1.0, here("to the circle"), {"roll": radius, "pitch": 0.0}, duration=1.0),
    ]
    t = 2.0
    for k in range(1, circles * points + 1):
        angle = 2 * math.pi * k / points
        target = {
            "roll": round(radius * math.cos(angle), 2),
            "pitch": round(radius * math.sin(angle), 2),
        }
        cues.append(MotionCue(t, here(f"circle point {k}"), target, duration=step))
        t += step
    cues.append(MotionCue(t, here("centre"), {"roll": 0.0, "pitch": 0.0}, duration=1.0))
    t += 1.0
    wave = mini.action("wave")  # the profile knows its id and documented run time
    assert wave.duration is not None
    cues.append(ActionCue(t, here("wave"), wave.id, wave.name, wave.duration))
    t += wave.duration
    cues.append(MotionCue(t, here("settle"), {"body_z": 97.6}, duration=1.0))
    return cues, t + 1.0


def colour_wheel(length: float, *, step: float = 1.0) -> list[Cue]:
    """Rider: a colour wheel round the four LEDs, a periodic roll, an action, a fade out."""
    cues: list[Cue] = [MotionCue(0.0, here("rise"), {"body_z": 105.0}, duration=1.5)]
    leds = ("led1", "led2", "led3", "led4")
    steps = max(1, int((length - 7.0) // step))
    for s in range(steps):
        for i, led in enumerate(leds):
            hue = ((s * 30 + i * 90) % 360) / 360.0
            r, g, b = colorsys.hsv_to_rgb(hue, 1.0, 1.0)
            rgb = (round(r * 255), round(g * 255), round(b * 255))
            cues.append(FadeCue(s * step, here(f"wheel step {s} {led}"), led, rgb, step))
    cues.append(SetCue(2.0, here("wobble on"), {"periodic_roll": 1.5}))
    cues.append(SetCue(8.0, here("wobble off"), {"periodic_roll": 0.0}))
    # The documents give no run time for Rider actions: give it (duration_given=True).
    swinging = get_profile("rider").action("swinging")
    cues.append(
        ActionCue(9.0, here("swinging"), swinging.id, swinging.name, 4.0, duration_given=True)
    )
    end_wheel = steps * step
    for led in leds:
        cues.append(FadeCue(end_wheel, here(f"fade out {led}"), led, (0, 0, 0), 2.0))
    cues.append(MotionCue(end_wheel, here("settle"), {"body_z": 90.0}, duration=1.5))
    return cues


def build(circles: int = 2) -> ResolvedShow:
    """The show: a Mini and a Rider side by side."""
    mini_cues, end = head_circles(circles)
    rider_cues = colour_wheel(end)
    return ResolvedShow(
        name="Circles and colours (built in Python)",
        source=SOURCE,
        tracks=(
            ResolvedTrack("rex", "mini", tuple(sorted(mini_cues, key=lambda c: c.start))),
            ResolvedTrack("rio", "rider", tuple(sorted(rider_cues, key=lambda c: c.start))),
        ),
        control_rate=50.0,
    )


def main(circles: int = 2, *, frames: int = 10, save: Path | None = None) -> int:
    """Build, compile and summarise the show; optionally save the schedule."""
    show = build(circles)
    schedule: Schedule = compile_show(show)  # CompileError names the cue that cannot be done
    print(f"{schedule.name}: {schedule.duration:.2f} s")
    print(totals_table(schedule), end="")
    lines = transcript(schedule).splitlines()
    print(f"\nfirst {min(frames, len(lines))} of {len(lines)} frames:")
    for line in lines[:frames]:
        print(f"  {line}")
    if save is not None:
        print(f"\nschedule saved to {save_schedule(schedule, save)}")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--circles", type=int, default=2, help="head circles (default 2)")
    parser.add_argument(
        "--frames", type=int, default=10, help="transcript lines to print (default 10)"
    )
    parser.add_argument("--save", type=Path, default=None, help="save the schedule here")
    args = parser.parse_args()
    try:
        sys.exit(main(args.circles, frames=args.frames, save=args.save))
    except XgoShowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
