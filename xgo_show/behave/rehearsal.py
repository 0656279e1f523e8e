"""Rehearsing a behaviour from a timed script, on virtual time.

A script lists what happens to the robots and when (seconds from start-up)::

    start: "18:59:30"          # local wall-clock time at start-up (for at: triggers)
    duration: 60               # seconds to rehearse
    events:
      - {at: 5, trigger: visitor}
      - {at: 20, performer: rex, fall: true}
      - {at: 30, performer: rex, recover: true}
      - {at: 40, performer: rex, battery: 15}
      - {at: 50, performer: rex, offline: true}

:func:`rehearse` runs the :class:`~xgo_show.behave.engine.Engine` against a
:class:`VirtualStage`: each performer is a virtual robot that plays a routine for the
routine's compiled length, reports telemetry (battery, imu_roll, imu_pitch) every
:data:`TELEMETRY_INTERVAL` seconds while online, and falls, recovers, drains or goes offline on
cue. Nothing waits and nothing is random: the same script gives the same trace.
"""

from __future__ import annotations

import datetime as dt
import functools
import heapq
import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from xgo_show.behave.engine import BehaviourNote, Engine
from xgo_show.behave.loader import Behaviour
from xgo_show.behave.model import ClockTime, Name
from xgo_show.choreo.source import read_yaml
from xgo_show.choreo.validation import validate
from xgo_show.errors import ChoreographyError
from xgo_show.runtime.events import Event, EventBus, TelemetryRead

__all__ = ["TELEMETRY_INTERVAL", "RehearsalScript", "VirtualStage", "load_rehearsal", "rehearse"]

TELEMETRY_INTERVAL = 0.25  # the executor's default poll interval
_CUES = ("trigger", "fall", "recover", "battery", "offline", "online")


class ScriptEvent(BaseModel):
    """One cue: a remote trigger, or something that happens to a performer."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    at: Annotated[float, Field(ge=0, allow_inf_nan=False)]
    trigger: Name | None = None
    performer: Name | None = None
    fall: bool | None = None
    recover: bool | None = None
    battery: Annotated[float, Field(ge=0, le=100)] | None = None
    offline: bool | None = None
    online: bool | None = None

    @model_validator(mode="after")
    def _one_cue(self) -> ScriptEvent:
        given = [k for k in _CUES if getattr(self, k) is not None]
        if len(given) != 1:
            raise PydanticCustomError(
                "cue", "give exactly one of " + ", ".join(_CUES), {}
            )
        if given[0] != "trigger" and self.performer is None:
            raise PydanticCustomError("cue", f"{given[0]}: needs performer:", {})
        return self


class RehearsalScript(BaseModel):
    """A rehearsal script file."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    start: ClockTime = "12:00"
    duration: Annotated[float, Field(gt=0, le=86400)]
    battery: Annotated[float, Field(ge=0, le=100)] = 80.0
    events: list[ScriptEvent] = Field(default_factory=list)


def load_rehearsal(path: str | Path, behaviour: Behaviour) -> RehearsalScript:
    """Read a script; :class:`ChoreographyError` at file:line:col for bad cues or names."""
    doc, diags = read_yaml(Path(path), str(path))
    script = None
    if not diags:
        script, diags = validate(RehearsalScript, doc, doc.data)
    if script is not None:
        known = behaviour.model
        for i, ev in enumerate(script.events):
            if ev.performer is not None and ev.performer not in known.performers:
                diags.append(_error(doc, ("events", i, "performer"),
                                    f"no performer {ev.performer!r}"))
            if ev.trigger is not None and ev.trigger not in known.triggers:
                diags.append(_error(doc, ("events", i, "trigger"),
                                    f"no rule waits for trigger {ev.trigger!r}"))
    if script is None or diags:
        lines = "\n".join(d.format() for d in diags)
        raise ChoreographyError(f"{path}: not a rehearsal script:\n{lines}", tuple(diags))
    return script


def _error(doc: Any, loc: tuple[str | int, ...], message: str) -> Any:
    from xgo_show.diagnostics import Diagnostic

    return Diagnostic("error", message, doc.origin(loc), doc.path(loc))


@dataclass
class _Robot:
    battery: float
    fallen: bool = False
    online: bool = True
    routine: str | None = None
    play_id: int = 0
    started: float = 0.0


@dataclass(order=True)
class _Item:
    t: float
    seq: int
    run: Callable[[], None] = field(compare=False)


class VirtualStage:
    """Virtual robots on virtual time: what :func:`rehearse` drives (see the module doc)."""

    def __init__(self, behaviour: Behaviour, battery: float, say: Callable[[float, str], None]):
        self.behaviour = behaviour
        self.robots = {p: _Robot(battery) for p in behaviour.model.performers}
        self.say = say
        self.engine: Engine | None = None
        self._queue: list[_Item] = []
        self._seq = itertools.count()

    def at(self, t: float, run: Callable[[], None]) -> None:
        heapq.heappush(self._queue, _Item(t, next(self._seq), run))

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float) -> None:
        schedule = self.behaviour.routines[routine]
        for p in performers:
            self._cut(p, t, f"handed over to {routine} through the rest and default posture")
            robot = self.robots[p]
            robot.routine, robot.play_id, robot.started = routine, play_id, t
            end = t + next(s.end for s in schedule.performers if s.name == p)
            self.at(end, functools.partial(self._ended, p, play_id, end))

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        for p in performers:
            self._cut(p, t, "rest")

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        for p in performers:
            self._cut(p, t, f"safe stop ({reason})")

    def write(self, key: str, performers: tuple[str, ...], t: float) -> None:
        schedule = self.behaviour.writes[key]
        for part in schedule.performers:
            if part.name in performers:
                self.say(t, f"{part.name}: {len(part.frames)} frame(s) written beside "
                         f"{self.robots[part.name].routine or 'nothing'}")

    def _cut(self, p: str, t: float, how: str) -> None:
        robot = self.robots[p]
        if robot.routine is not None:
            self.say(t, f"{p}: {robot.routine} cut after {t - robot.started:.2f} s: {how}")
            robot.routine = None

    def _ended(self, p: str, play_id: int, t: float) -> None:
        robot = self.robots[p]
        if robot.routine is None or robot.play_id != play_id:
            return
        robot.routine = None
        assert self.engine is not None
        self.engine.routine_ended(p, play_id, t, True)

    def telemetry(self, t: float) -> list[Event]:
        out: list[Event] = []
        for p, robot in self.robots.items():
            if robot.online:
                roll = 90.0 if robot.fallen else 0.0
                out += [TelemetryRead(t, p, "battery", robot.battery),
                        TelemetryRead(t, p, "imu_roll", roll),
                        TelemetryRead(t, p, "imu_pitch", 0.0)]
        return out


def rehearse(
    behaviour: Behaviour, script: RehearsalScript, say: Callable[[float, str], None],
    events: EventBus | None = None,
) -> Engine:
    """Play ``script`` against ``behaviour`` on virtual time; ``say(t, line)`` gets the trace
    (what fired, what each robot did), ``events`` (if given) every decision as a
    :class:`BehaviourNote`. Returns the engine at the end, for inspection."""
    stage = VirtualStage(behaviour, script.battery, say)
    h, m, *s = (int(x) for x in script.start.split(":"))
    origin = dt.datetime(2026, 1, 1, h, m, s[0] if s else 0)

    def wall(t: float) -> dt.datetime:
        return origin + dt.timedelta(seconds=t)

    def emit(event: Event) -> None:
        if events is not None:
            events.publish(event)
        if isinstance(event, BehaviourNote):
            say(event.t, f"rule {event.rule}: {event.kind}: {event.text}")

    engine = Engine(behaviour, stage, emit=emit, wall=wall)
    stage.engine = engine
    for ev in script.events:
        stage.at(ev.at, functools.partial(_apply, ev, stage, engine, say))

    def tick(t: float) -> None:
        for event in stage.telemetry(t):
            engine.on_event(event)

    ticks = int(script.duration / TELEMETRY_INTERVAL)
    for i in range(1, ticks + 1):
        stage.at(i * TELEMETRY_INTERVAL, functools.partial(tick, i * TELEMETRY_INTERVAL))
    engine.start(0.0)
    while True:
        deadline = engine.next_deadline()
        nxt = stage._queue[0].t if stage._queue else None
        if deadline is not None and (nxt is None or deadline < nxt):
            if deadline > script.duration:
                break
            engine.advance(deadline)
            continue
        if nxt is None or nxt > script.duration:
            break
        heapq.heappop(stage._queue).run()
    return engine


def _apply(ev: ScriptEvent, stage: VirtualStage, engine: Engine,
           say: Callable[[float, str], None]) -> None:
    if ev.trigger is not None:
        say(ev.at, f"script: trigger {ev.trigger}")
        engine.trigger(ev.trigger, ev.at)
        return
    assert ev.performer is not None
    robot = stage.robots[ev.performer]
    if ev.fall:
        robot.fallen = True
        say(ev.at, f"script: {ev.performer} falls over")
    elif ev.recover:
        robot.fallen = False
        say(ev.at, f"script: {ev.performer} is back on its feet")
    elif ev.battery is not None:
        robot.battery = ev.battery
        say(ev.at, f"script: {ev.performer} battery {ev.battery:g}%")
    elif ev.offline:
        robot.online = False
        say(ev.at, f"script: {ev.performer} goes offline")
    elif ev.online:
        robot.online = True
        say(ev.at, f"script: {ev.performer} comes back online")
