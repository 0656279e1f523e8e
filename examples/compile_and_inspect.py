"""Compile a routine, print what each robot's serial link will carry, and save the schedule.

The compiler is a pure function from a loaded show to a schedule: per performer, the exact
bytes of every frame and the time its first byte goes out, paced to fit the link. This prints
per-performer totals, the first frames of the transcript (time, performer, values, bytes),
saves the schedule file (versioned, compact, with a digest) and reads it back.

    python examples/compile_and_inspect.py [ROUTINE.yaml] [--frames N] [--out FILE.xshow.json]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from xgo_show.choreo import load_show
from xgo_show.compiler import compile_show, load_schedule, save_schedule
from xgo_show.compiler.report import totals, transcript
from xgo_show.errors import XgoShowError

DEFAULT_ROUTINE = Path(__file__).resolve().parent.parent / "choreographies" / "hello_mini.yaml"


def main(path: Path = DEFAULT_ROUTINE, *, frames: int = 12, out: Path | None = None) -> int:
    """Compile ``path``; print totals and ``frames`` transcript lines; save to ``out``."""
    show = load_show(path)  # ChoreographyError lists every problem
    schedule = compile_show(show)  # CompileError lists every infeasible cue

    print(f"{schedule.name}: {schedule.duration:.2f} s, {schedule.control_rate:g} Hz sampling")
    for t in totals(schedule):
        print(
            f"  {t.name:<10} {t.model:<6} {t.frames:6d} frames {t.bytes:7d} bytes  "
            f"link busy {t.link_use * 100:4.1f} %  {t.duration:7.2f} s  "
            f"{t.warnings} warning(s)"
        )
    for warning in schedule.warnings:
        print(f"  {warning.format()}")

    lines = transcript(schedule).splitlines()
    print(f"\nfirst {min(frames, len(lines))} of {len(lines)} frames:")
    for line in lines[:frames]:
        print(f"  {line}")

    target = out or Path(tempfile.gettempdir()) / f"{path.stem}.xshow.json"
    saved = save_schedule(schedule, target)
    again = load_schedule(saved)
    same = all(
        a.frames == b.frames for a, b in zip(schedule.performers, again.performers, strict=True)
    )
    print(
        f"\nschedule saved to {saved} ({saved.stat().st_size} bytes); "
        f"read back {'identical' if same else 'DIFFERENT'}"
    )
    print(f"run it later with: xgo-show run {saved} --sim")
    return 0 if same else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "routine",
        nargs="?",
        type=Path,
        default=DEFAULT_ROUTINE,
        help="routine file (default: choreographies/hello_mini.yaml)",
    )
    parser.add_argument(
        "--frames", type=int, default=12, help="transcript lines to print (default 12)"
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help="where to save the schedule (default: a temporary directory)",
    )
    args = parser.parse_args()
    try:
        sys.exit(main(args.routine, frames=args.frames, out=args.out))
    except XgoShowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
