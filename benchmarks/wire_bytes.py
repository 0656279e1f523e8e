"""Bytes on the wire: the compiler's merged, de-duplicated frames vs one register per frame.

The vendor library writes every register as its own frame (8 bytes of framing + data) each
time it is set, and a script animating a pose sets every moving register every tick. For the
benchmark show of ``compile_speed.py`` (continuous moves on several registers, Rider LED fades)
this counts what that costs (each moving register / LED: one frame per control tick for the
length of its cue) and what the compiled schedule sends. A second, stricter baseline keeps one
register per frame but sends a register only when its byte changed (a careful script on the
vendor library): the ratio to it is what merging adjacent registers alone saves. Prints
figures only (no asserts).
Usage::

    python benchmarks/wire_bytes.py [--minutes 2] [--performers 10] [--rate 50]
"""

from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compile_speed import build_show, show_arguments

from xgo_show.choreo.resolved import FadeCue, MotionCue, ResolvedShow
from xgo_show.compiler import compile_show
from xgo_show.compiler.schedule import Schedule
from xgo_show.compiler.state import layout_of
from xgo_show.profiles import get_profile
from xgo_show.wire.xgo import MIN_LENGTH, decode_one


def one_register_per_frame(show: ResolvedShow) -> int:
    """Bytes when each moving register goes out in its own frame on every tick of its cue."""
    total = 0
    for track in show.tracks:
        profile = get_profile(track.model)
        for cue in track.cues:
            if isinstance(cue, MotionCue):
                assert cue.duration is not None
                ticks = math.ceil(cue.duration * show.control_rate) + 1
                total += ticks * sum(
                    MIN_LENGTH + profile.register(name).size for name in cue.targets
                )
            elif isinstance(cue, FadeCue):
                ticks = math.ceil(cue.duration * show.control_rate) + 1
                total += ticks * (MIN_LENGTH + profile.register(cue.register).size)
    return total


def one_changed_register_per_frame(schedule: Schedule) -> int:
    """Bytes when each register whose byte changed goes out in its own frame.

    Walks the compiled frames register by register and counts a frame of its own for every
    value that differs from the one last sent (fillers the compiler re-sends are not counted).
    """
    total = 0
    for perf in schedule.performers:
        layout = layout_of(get_profile(perf.model))
        last: dict[int, bytes] = {}
        for f in perf.frames:
            _, frame = decode_one(f.data)
            assert frame is not None
            regs = layout.walk(frame.address, len(frame.data))
            assert regs is not None
            offset = 0
            for reg in regs:
                raw = frame.data[offset:offset + reg.size]
                offset += reg.size
                if last.get(reg.address) != raw:
                    last[reg.address] = raw
                    total += MIN_LENGTH + reg.size
    return total


def main() -> None:
    args = show_arguments(__doc__, 2.0)
    show = build_show(args.minutes, args.performers, args.rate)
    schedule = compile_show(show)
    ours = sum(p.total_bytes for p in schedule.performers)
    frames = sum(len(p.frames) for p in schedule.performers)
    vendor = one_register_per_frame(show)
    print(f"show: {args.performers} performers, {args.minutes:g} min, {args.rate:g} Hz")
    print(f"one register per frame, every tick:   {vendor:,} bytes")
    print(f"compiled schedule:                    {ours:,} bytes in {frames:,} frames")
    changed = one_changed_register_per_frame(schedule)
    print(f"one register per frame, when changed: {changed:,} bytes")
    print(f"ratio to every tick:   {ours / vendor:.3f}  (target <= 0.6)")
    print(f"ratio to when changed: {ours / changed:.3f}  (merging adjacent registers alone)")


if __name__ == "__main__":
    main()
