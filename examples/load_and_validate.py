"""Load a routine and print every problem found in it, as ``xgo-show validate`` does.

:func:`xgo_show.choreo.validate_file` never raises for a mistake in the routine: it returns
every diagnostic (errors and warnings, compiler findings included). :func:`load_show` gives the
expanded show (absolute times, physical values) or raises :class:`ChoreographyError` listing
every error.

    python examples/load_and_validate.py [ROUTINE.yaml]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from xgo_show.choreo import load_show, validate_file
from xgo_show.choreo.resolved import ActionCue, ArmCue, FadeCue, MotionCue, SetCue
from xgo_show.diagnostics import Diagnostic
from xgo_show.errors import ChoreographyError

DEFAULT_ROUTINE = Path(__file__).resolve().parent.parent / "choreographies" / "hello_mini.yaml"


def main(path: Path = DEFAULT_ROUTINE) -> int:
    """Print the diagnostics of ``path`` and, if it loads, a summary; 1 if it has errors."""
    diagnostics = validate_file(path)
    for diag in diagnostics:
        print(diag.format())
    errors = sum(1 for d in diagnostics if d.is_error)
    print(f"{path}: {errors} error(s), {len(diagnostics) - errors} warning(s)")
    if errors:
        return 1

    try:
        show = load_show(path)
    except ChoreographyError as exc:  # not expected after a clean validation; shown for the API
        for problem in exc.diagnostics:
            print(problem.format() if isinstance(problem, Diagnostic) else problem)
        return 1
    tempo = f"{show.bpm:g} bpm" if show.bpm else "no tempo (seconds)"
    print(f"\nshow {show.name!r}, {tempo}, {len(show.tracks)} performer(s)")
    for track in show.tracks:
        kinds = {"action": 0, "move": 0, "set": 0, "fade": 0, "pose": 0}
        for cue in track.cues:
            if isinstance(cue, ActionCue):
                kinds["action"] += 1
            elif isinstance(cue, MotionCue):
                kinds["move"] += 1
            elif isinstance(cue, SetCue):
                kinds["set"] += 1
            elif isinstance(cue, FadeCue):
                kinds["fade"] += 1
            elif isinstance(cue, ArmCue):
                kinds["pose"] += 1
        counts = ", ".join(f"{n} {k}" for k, n in kinds.items() if n)
        first = track.cues[0].start if track.cues else 0.0
        last = track.cues[-1].start if track.cues else 0.0
        print(
            f"  {track.performer} ({track.model}): {len(track.cues)} cues ({counts}), "
            f"first at {first:.2f} s, last at {last:.2f} s"
        )
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "routine",
        nargs="?",
        type=Path,
        default=DEFAULT_ROUTINE,
        help="routine file (default: choreographies/hello_mini.yaml)",
    )
    args = parser.parse_args()
    sys.exit(main(args.routine))
