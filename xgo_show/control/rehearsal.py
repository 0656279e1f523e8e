"""Sections in ``run`` and ``dry-run``: a director beside the runner, triggers from a script.

:func:`check_triggers` decides before anything opens whether a show can be played the way the
user asked (a show that waits for triggers needs a trigger script, or ``xgo-show serve``);
:func:`directed` runs a :class:`~xgo_show.control.director.Director` (and the script's player)
for the length of a run.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path

from xgo_show.choreo.sections import trigger_names
from xgo_show.compiler.schedule import Schedule
from xgo_show.control.director import Director
from xgo_show.control.script import ScriptPlayer, TriggerScript, load_script
from xgo_show.errors import UsageError
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.show_runner import ShowRunner

__all__ = ["check_triggers", "directed"]


def check_triggers(
    schedule: Schedule, script: str | Path | None, *, follow: str | None = None
) -> TriggerScript | None:
    """The trigger script to play (None: none needed), or an error saying what is missing.

    A script's triggers must all be ones the show waits for: a typo would otherwise only show
    as a wait that times out. A show that waits cannot chase MIDI timecode (``follow``):
    the timecode sets the show time every frame, so a hold at a wait would be taken for a
    timecode jump and undone.
    """
    names = trigger_names(schedule.sections)
    if names and follow is not None and follow.startswith("mtc"):
        raise UsageError(
            f"--follow {follow}: this show waits for trigger(s) {', '.join(names)}, but MIDI "
            "timecode sets the show time every frame, so a hold at a wait would be taken for "
            "a timecode jump; follow the desk's OSC cues instead (--follow osc:PORT, waits "
            "released by --triggers SCRIPT.yaml), or serve the show ('xgo-show serve') and "
            "fire its triggers with 'xgo-show trigger NAME'"
        )
    if script is None:
        if names:
            raise UsageError(
                f"this show waits for trigger(s) {', '.join(names)}: rehearse it with "
                "--triggers SCRIPT.yaml (see docs/choreography.md), or serve it with "
                "'xgo-show serve' and fire them with 'xgo-show trigger NAME'"
            )
        return None
    loaded = load_script(script)
    if not names:
        raise UsageError(f"--triggers {script}: no section of this show waits for a trigger")
    unknown = sorted({c.trigger for c in loaded.triggers} - set(names))
    if unknown:
        raise UsageError(
            f"--triggers {script}: the show waits for no trigger named {', '.join(unknown)}; "
            f"its triggers: {', '.join(names)}"
        )
    return loaded


@contextlib.contextmanager
def directed(
    runner: ShowRunner,
    clock: Clock,
    script: TriggerScript | None,
    *,
    say: Callable[[str], None] = print,
) -> Iterator[Director | None]:
    """A director (and the script's player) for the run of ``runner``; None for a show
    without sections that wait."""
    if not trigger_names(runner.schedule.sections):
        yield None
        return
    director = Director(runner, clock=clock)
    player = ScriptPlayer(script, director, say=say) if script is not None else None
    try:
        yield director
    finally:
        if player is not None:
            player.close()
        director.close()
