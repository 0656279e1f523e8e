"""``xgo-show new FILE.yaml``: write a commented starter routine that validates as it is.

The routine is a short phrase-based show on a tempo grid for one robot of the chosen model,
with a comment on every line that introduces something (tempo, bar/beat times, phrases,
smooth moves, preset actions, LEDs, xArm poses), so a new user edits rather than starts from
an empty file. It never overwrites a file.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from xgo_show.errors import FileAccessError, UsageError
from xgo_show.profiles import MODELS, get_profile

__all__ = ["add_parser", "run", "starter_routine"]


def add_parser(sub: Any) -> None:
    """Register the ``new`` subcommand."""
    parser = sub.add_parser(
        "new",
        help="write a commented starter routine (validates as it is)",
        description=(
            "Write FILE, a short commented routine for one robot of --model on a --bpm grid: "
            "it validates and dry-runs as it is, and every line says what it does. An "
            "existing FILE is never overwritten."
        ),
        epilog=(
            "example:\n  xgo-show new my_show.yaml\n"
            "  xgo-show new arm_show.yaml --model xarm --bpm 90\n"
            "  xgo-show dry-run my_show.yaml"
        ),
    )
    parser.add_argument("file", metavar="FILE.yaml", help="the routine to write")
    parser.add_argument("--model", default="mini", help=f"one of: {', '.join(MODELS)} "
                        "(default: mini)")
    parser.add_argument("--bpm", type=float, default=120.0, help="tempo (default: 120)")
    parser.set_defaults(func=run)


_HEAD = """\
# {title}: a starter routine written by 'xgo-show new'. Edit it, then:
#   xgo-show validate --watch {file}     # every problem, again on each save
#   xgo-show dry-run {file}              # run it on a simulated robot
#   xgo-show compile {file} -o /tmp/{stem}.xshow.json --plot {stem}.html   # see the timeline
#   xgo-show info {model}                  # what this robot can do (actions, registers, ranges)
# Completion in an editor: 'xgo-show schema --write .' then put this as the first line:
#   # yaml-language-server: $schema=choreography.schema.json

show: {title}
# The music's grid: times are "BAR.BEAT" and lengths are beats or bars.
tempo: {{bpm: {bpm:g}, beats_per_bar: 4}}

performers:
  # One robot; add 'port: /dev/ttyUSB0' (or pass --map {name}=PORT to 'xgo-show run').
  {name}: {{model: {model}}}

# Named parts of the show, listed by 'xgo-show inspect' and shown on the timeline.
sections:
  - {{name: intro}}
  - {{name: groove, at: "3.1"}}

# Phrases are reusable groups of cues; params make them variations.
phrases:
{phrases}
tracks:
  {name}:
{track}"""

_DOG_PHRASES = """\
  nod:
    params: {depth: 10}
    cues:
      - {move: {pitch: $depth}, beats: 2}   # a smooth, jerk-limited move to the target
      - {move: {pitch: 0}, beats: 2}
"""

_DOG_TRACK = """\
    - {at: "1.1", phrase: nod}                        # bar 1, beat 1
    - {phrase: nod, with: {depth: -10}}              # then straight after: look up
    - {at: "3.1", move: {body_z: [110, 90, 100]}, bars: 2}   # a path: three points in 2 bars
    - {at: "5.1", action: {action}, bars: {bars}}     # a preset action of the robot
"""

_RIDER_PHRASES = """\
  flash:
    params: {colour: blue}
    cues:
      - {led: {all: $colour}, beats: 1}         # every LED at once
      - {led: {all: black}, fade: {beats: 1}}   # fade out over one beat
"""

_RIDER_TRACK = """\
    - {at: "1.1", phrase: flash}
    - {phrase: flash, with: {colour: "#ff8800"}}   # quote '#' colours: '#' starts a comment
    - {at: "3.1", move: {body_z: [110, 90, 100]}, bars: 2}   # a path: three points in 2 bars
    - {at: "5.1", move: {roll: 10}, beats: 2}
    - {move: {roll: 0}, beats: 2}
"""

_ARM_PHRASES = """\
  wave:
    params: {angle: 20}
    cues:
      - {pose_deg: {3: $angle}, beats: 1}    # servo 3 (the wrist) to an angle in degrees
      - {pose_deg: {3: -$angle}, beats: 1}
"""

_ARM_TRACK = """\
    - {at: "1.1", pose_deg: {4: 30, 5: -20}, bars: 1}   # elbow and shoulder, in one bar
    - {at: "2.1", phrase: wave}
    - {at: "3.1", phrase: wave, with: {angle: 35}}
    - {at: "4.1", pose_deg: {1: 40}, beats: 1}          # open the gripper (servo 1)
    - {pose_deg: {1: 0, 3: 0, 4: 0, 5: 0}, bars: 1}     # back to the centre
"""


def starter_routine(path: Path, model: str, bpm: float) -> str:
    """The text of a starter routine for ``model`` at ``bpm``, to be written at ``path``."""
    profile = get_profile(model)
    if profile.family == "xarm":
        name, phrases, track = "arm", _ARM_PHRASES, _ARM_TRACK
    elif profile.supports("led"):
        name, phrases, track = "rio", _RIDER_PHRASES, _RIDER_TRACK
    else:
        # A wave if the robot has one, else the shortest documented action but the reset, in
        # whole bars that hold it.
        bar = 4 * 60.0 / bpm
        action = min((a for a in profile.actions if a.duration is not None),
                     key=lambda a: (a.name != "wave", a.name == "reset", a.duration or 0.0))
        bars = max(1, math.ceil((action.duration or 0.0) / bar - 1e-9))
        name, phrases = "rex", _DOG_PHRASES
        track = _DOG_TRACK.replace("{action}", action.name).replace("{bars}", str(bars))
    title = path.stem.replace("_", " ").replace("-", " ").strip().capitalize() or "My show"
    return _HEAD.format(title=title, file=path, stem=path.stem, model=profile.model, bpm=bpm,
                        name=name, phrases=phrases, track=track)


def run(args: argparse.Namespace) -> int:
    path = Path(args.file)
    if path.suffix not in (".yaml", ".yml"):
        raise UsageError(f"{path}: a routine file ends in .yaml")
    if not 20 <= args.bpm <= 400:
        raise UsageError(f"--bpm {args.bpm:g}: give a tempo between 20 and 400")
    text = starter_routine(path, args.model, args.bpm)
    try:
        with path.open("x", encoding="utf-8") as out:
            out.write(text)
    except FileExistsError:
        raise UsageError(f"{path} exists: 'new' never overwrites a file") from None
    except OSError as exc:
        raise FileAccessError(f"cannot write {path}: {exc.strerror or exc}") from exc
    print(f"wrote {path}: a starter routine for one {get_profile(args.model).title}; next: "
          f"xgo-show validate --watch {path}")
    return 0
