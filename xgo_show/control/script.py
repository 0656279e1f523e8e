"""Trigger scripts: a triggered show rehearsed (and tested) without an operator.

A script is a YAML file listing triggers in the order they are fired::

    # yaml-language-server: $schema=../schemas/trigger-script.schema.json
    triggers:
      - {trigger: go, after: 1.5}     # 1.5 s after the show starts waiting for 'go'
      - {trigger: encore, at: 14}     # 14 s after the show's start, waiting or not

``after: S`` fires S seconds after the show begins holding at a wait for that trigger (or, if
it already holds there when the entry's turn comes, S seconds after the previous entry fired);
``at: S`` fires S seconds (of the clock, holds
included) after the show's start, whether the show waits for it or not, so early and unwanted
triggers can be rehearsed too. Entries fire one after another, each once.

In virtual time (``dry-run --fast``) nothing waits, but the script keeps its timing: as the
show starts holding at a wait, the entries due by then fire (early, or refused, as they would
have in real time), then the entry for that wait fires at its time if that comes before the
wait's timeout; otherwise the timeout is taken when it runs out (without a timeout, the show
ends with a safe stop that says which trigger was missing). Each trigger, hold and release
happens at the same show clock time as in a real-time run of the same script.
"""

from __future__ import annotations

import json
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, model_validator
from pydantic_core import PydanticCustomError

from xgo_show.choreo.source import read_yaml
from xgo_show.choreo.validation import validate
from xgo_show.closing import WorkerClosing
from xgo_show.control.director import ControlError, Director, WaitStarted
from xgo_show.errors import ChoreographyError
from xgo_show.runtime.events import Event, ShowEnded, ShowStarted

__all__ = [
    "SCRIPT_SCHEMA_ID",
    "ScriptCue",
    "ScriptPlayer",
    "TriggerScript",
    "load_script",
    "trigger_script_json_schema",
]

SCRIPT_SCHEMA_ID = "https://xgo-show.invalid/schemas/trigger-script.schema.json"

Name = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_-]*$")]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class ScriptCue(BaseModel):
    """One trigger of a script: its name and when it fires."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    trigger: Name = Field(description="The trigger to fire.")
    at: NonNegative | None = Field(
        None, description="Seconds after the show's start (holds included)."
    )
    after: NonNegative | None = Field(
        None, description="Seconds after the show begins waiting for this trigger."
    )

    @model_validator(mode="after")
    def _one_time(self) -> ScriptCue:
        if (self.at is None) == (self.after is None):
            raise PydanticCustomError(
                "timing", "give one of 'at' (seconds after the start) or 'after' (seconds "
                "after the show begins waiting for this trigger)", {}
            )
        return self


class TriggerScript(BaseModel):
    """A trigger script file."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    triggers: Annotated[list[ScriptCue], Field(min_length=1)]


def trigger_script_json_schema() -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of a trigger script, for editors (see the modeline)."""
    schema = TriggerScript.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = SCRIPT_SCHEMA_ID
    schema["title"] = "xgo-show trigger script"
    return schema


def load_script(path: str | Path) -> TriggerScript:
    """Read a trigger script; :class:`ChoreographyError` with every problem at file:line:col."""
    doc, diags = read_yaml(Path(path), str(path))
    if not diags:
        script, diags = validate(TriggerScript, doc, doc.data)
        if script is not None:
            return script
    lines = "\n".join(d.format() for d in diags)
    raise ChoreographyError(f"{path}: not a trigger script:\n{lines}", tuple(diags))


@dataclass(frozen=True)
class Fired:
    """One trigger the player fired: when (seconds after the start), and what came of it."""

    trigger: str
    t: float
    result: str  # "released bow", "kept for bow", or the refusal


class ScriptPlayer(WorkerClosing):
    """Fires a script's triggers at ``director``'s show; reports each through ``say``."""

    def __init__(
        self, script: TriggerScript, director: Director, *, say: Callable[[str], None] = print
    ) -> None:
        self.cues = list(script.triggers)
        self.director = director
        self.clock = director.clock
        self.say = say
        self.fired: list[Fired] = []
        self._cond = threading.Condition()
        self._start: float | None = None
        self._turn = float("-inf")  # clock time the current entry's turn came
        self._waits: list[tuple[str, float]] = []  # (trigger, clock time) holds not yet used
        self._ended = False
        self._closed = False
        self._sub = director.events.subscribe(self._on_event, ShowStarted, WaitStarted, ShowEnded)
        self._thread: threading.Thread | None = None
        if not director.virtual:
            self._thread = threading.Thread(target=self._loop, name="xgo-show triggers",
                                            daemon=True)
            self._thread.start()

    def _on_event(self, event: Event) -> None:
        if self.director.virtual and isinstance(event, (ShowStarted, WaitStarted)):
            # Called with the director's lock held: no other thread plays this script.
            if isinstance(event, ShowStarted):
                self._start = event.start_at
                self._virtual_early()
            else:
                self._virtual_wait(event)
            return
        with self._cond:
            if isinstance(event, ShowStarted):
                self._start = event.start_at
            elif isinstance(event, WaitStarted):
                self._waits.append((event.trigger, event.t))
            elif isinstance(event, ShowEnded):
                self._ended = True
            self._cond.notify_all()

    def _fire(self, name: str, at: float | None = None) -> bool:
        """Fire ``name`` (in virtual time, at clock time ``at``); True if it released or was
        kept for a wait."""
        start = self._start if self._start is not None else self.clock.now()
        when = at if at is not None else self.clock.now()
        try:
            outcome = self.director.trigger(name, at=at)
        except ControlError as exc:
            result, ok = str(exc), False
        else:
            result = f"{'released' if outcome.held else 'kept for'} section {outcome.section!r}"
            ok = True
        t = when - start
        self.fired.append(Fired(name, t, result))
        self.say(f"trigger {name!r} at {t:.3f} s: {result}")
        return ok

    def _virtual_wait(self, event: WaitStarted) -> None:
        """The show holds at a wait (virtual time): play the script up to its release."""
        hold = event.t
        start = self._start if self._start is not None else hold
        expiry = None if event.timeout is None else hold + event.timeout
        turn = max(self._turn, start)
        while self.cues:
            cue = self.cues[0]
            if cue.at is not None:
                due = max(turn, start + cue.at)
            elif cue.trigger == event.trigger:
                assert cue.after is not None
                due = max(hold, turn) + cue.after
            else:
                break  # it waits for a hold of its own trigger: this wait times out
            if expiry is not None and due > expiry:
                break
            self.cues.pop(0)
            turn = self._turn = due
            if self._fire(cue.trigger, at=due) and cue.trigger == event.trigger:
                self._virtual_early()
                return
        self.director.expire(at=expiry)
        self._virtual_early()

    def _virtual_early(self) -> None:
        """Fire the entries due before the show comes to the wait ahead (virtual time), as
        they would fire while it plays: kept for that wait, or refused."""
        start = self._start if self._start is not None else self.clock.now()
        while self.cues and self.cues[0].at is not None:
            hold = self.director.hold_ahead()
            cue = self.cues[0]
            assert cue.at is not None
            due = max(self._turn, start + cue.at)
            if hold is None or due >= hold or self.director.phase != "playing":
                return
            self.cues.pop(0)
            self._turn = due
            self._fire(cue.trigger, at=due)

    def _loop(self) -> None:
        with self._cond:
            while not self._closed and not self._ended and self.cues:
                cue = self.cues[0]
                due = self._due(cue)
                now = self.clock.now()
                if due is None or due > now:
                    self._cond.wait(None if due is None else due - now)
                    continue
                self.cues.pop(0)
                if cue.after is not None:
                    self._waits.pop(0)
                self._cond.release()
                try:
                    self._fire(cue.trigger)
                finally:
                    self._cond.acquire()
                self._turn = self.clock.now()

    def _due(self, cue: ScriptCue) -> float | None:
        if self._start is None:
            return None
        if cue.at is not None:
            return self._start + cue.at
        # Holds for other triggers are not this entry's: drop them.
        while self._waits and self._waits[0][0] != cue.trigger:
            self._waits.pop(0)
        if not self._waits:
            return None
        assert cue.after is not None
        return max(self._waits[0][1], self._turn) + cue.after


if __name__ == "__main__":  # regenerate: python -m xgo_show.control.script > schemas/...
    json.dump(trigger_script_json_schema(), sys.stdout, indent=2)
    sys.stdout.write("\n")
