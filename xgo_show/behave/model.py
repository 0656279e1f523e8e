"""The behaviour file as pydantic models: performers, routines, rules (triggers, conditions,
actions).

A behaviour file names the robots, the routines they may play, and rules. Each rule has
triggers (``when``: any one fires it), optional conditions (``if``: all must hold when it
fires), and actions (``do``, run in order). Triggers, conditions and actions are each a
mapping with exactly one kind key, as cues are in a routine::

    rules:
      - name: greet
        when: [{trigger: visitor}]
        if: {performer: rex, is: idle}
        do: [{play: greet}]
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StringConstraints

from xgo_show.choreo.unions import tagged_union
from xgo_show.choreo.unit import Unit

__all__ = [
    "ACTION_KINDS",
    "CONDITION_KINDS",
    "TRIGGER_KINDS",
    "ActionModel",
    "BehaviourFile",
    "ConditionModel",
    "RuleModel",
    "TriggerModel",
]

Name = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_-]*$")]
Seconds = Annotated[float, Field(gt=0, allow_inf_nan=False), Unit("s")]
Percent = Annotated[float, Field(ge=0, le=100, allow_inf_nan=False), Unit("%")]
Degrees = Annotated[float, Field(gt=0, le=180, allow_inf_nan=False), Unit("deg")]
ClockTime = Annotated[
    str, StringConstraints(pattern=r"^([01][0-9]|2[0-3]):[0-5][0-9](:[0-5][0-9])?$")
]
Performers = Annotated[list[Name], Field(min_length=1)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


def _kind_of(kinds: tuple[str, ...]) -> Any:
    def tag(value: object) -> str | None:
        if isinstance(value, BaseModel):
            value = value.model_dump(by_alias=True)
        if not isinstance(value, dict):
            return None
        present = [k for k in kinds if k in value]
        return f"{present[0]}-kind" if len(present) == 1 else None

    return tag


def _tagged_union(table: dict[str, type[_Model]], noun: str, article: str = "a") -> Any:
    """The union of a kind table's models ("a trigger needs exactly one kind key: ...")."""
    return tagged_union(
        table, _kind_of(tuple(table)), suffix="-kind", error_type=f"{noun}_kind",
        message=f"{article} {noun} needs exactly one kind key: " + ", ".join(table))


# -- triggers ---------------------------------------------------------------------------------


class RemoteTrigger(_Model):
    """A named trigger from the control API (or a rehearsal script)."""

    trigger: Name


class BatteryBelow(_Model):
    """Battery (percent) drops below a level; re-armed once it reads ``clear`` or more."""

    battery_below: Percent
    clear: Percent | None = Field(None, description="Default: 5 points above the level.")
    performers: Performers | None = None


class TiltBeyond(_Model):
    """Roll or pitch beyond an angle (a fall: ~90); re-armed below ``clear`` degrees."""

    tilt_beyond: Degrees
    clear: Degrees | None = Field(None, description="Default: half the angle.")
    performers: Performers | None = None


class Offline(_Model):
    """No telemetry from a robot for this many seconds."""

    offline: Seconds
    performers: Performers | None = None


class Online(_Model):
    """A robot that was offline answers again."""

    online: Literal[True]
    performers: Performers | None = None


class RoutineEnded(_Model):
    """A routine played by any rule ran to its end (not cut) on a performer."""

    routine_ended: Name
    performers: Performers | None = None


class After(_Model):
    """Once, this many seconds after start-up (or after switching into the rule's set)."""

    after: Seconds


class Every(_Model):
    """Every this many seconds from start-up (or from switching into the rule's set)."""

    every: Seconds


class AtTime(_Model):
    """Each day at this local wall-clock time (``HH:MM`` or ``HH:MM:SS``)."""

    at: ClockTime


class Startup(_Model):
    """When the behaviour starts (and when switching into the rule's set)."""

    startup: Literal[True]


_TRIGGERS: dict[str, type[_Model]] = {
    "trigger": RemoteTrigger,
    "battery_below": BatteryBelow,
    "tilt_beyond": TiltBeyond,
    "offline": Offline,
    "online": Online,
    "routine_ended": RoutineEnded,
    "after": After,
    "every": Every,
    "at": AtTime,
    "startup": Startup,
}
TRIGGER_KINDS: tuple[str, ...] = tuple(_TRIGGERS)

if TYPE_CHECKING:  # what the checker sees; pydantic gets the union built from the table
    TriggerModel = _Model
else:
    TriggerModel = _tagged_union(_TRIGGERS, "trigger")

# -- conditions -------------------------------------------------------------------------------


class PerformerIs(_Model):
    """A performer is idle, or playing (any routine, or the one named)."""

    performer: Name
    is_: Literal["idle", "playing"] = Field(alias="is")
    routine: Name | None = None


class TelemetryTest(_Model):
    performer: Name
    name: Literal["battery", "imu_roll", "imu_pitch", "tilt"]
    below: float | None = None
    above: float | None = None


class TelemetryCondition(_Model):
    """A telemetry reading below and/or above a threshold."""

    telemetry: TelemetryTest


class TimeWindow(_Model):
    after: ClockTime | None = None
    before: ClockTime | None = None


class TimeCondition(_Model):
    """Local time of day within a window (``after`` inclusive, ``before`` exclusive)."""

    time: TimeWindow


class InSet(_Model):
    """The behaviour set now active."""

    in_set: Name


class AllOf(_Model):
    and_: Annotated[list[ConditionModel], Field(min_length=1)] = Field(alias="and")


class AnyOf(_Model):
    or_: Annotated[list[ConditionModel], Field(min_length=1)] = Field(alias="or")


class NotC(_Model):
    not_: ConditionModel = Field(alias="not")


_CONDITIONS: dict[str, type[_Model]] = {
    "performer": PerformerIs,
    "telemetry": TelemetryCondition,
    "time": TimeCondition,
    "in_set": InSet,
    "and": AllOf,
    "or": AnyOf,
    "not": NotC,
}
CONDITION_KINDS: tuple[str, ...] = tuple(_CONDITIONS)

if TYPE_CHECKING:
    ConditionModel = _Model
else:
    ConditionModel = _tagged_union(_CONDITIONS, "condition")

# -- actions ----------------------------------------------------------------------------------


class Play(_Model):
    """Play a routine on performers (default: every performer the routine has) and wait for
    its end; with ``phrase``, only that phrase of the routine (its ``phrases:``)."""

    play: Name
    phrase: Name | None = Field(None, description="Play only this phrase of the routine.")
    with_: dict[Name, Any] | None = Field(
        None, alias="with", description="The phrase's parameter values (name -> value)."
    )
    performers: Performers | None = None


class Loop(_Model):
    """Play a routine again and again (does not wait) until another action takes the
    performers."""

    loop: Name
    performers: Performers | None = None


class Stop(_Model):
    """Bring performers to rest (the routine they play ends through the rest posture)."""

    stop: Performers | Literal["all"]


class SafeStop(_Model):
    """The full safe stop on performers (rest, then the default posture)."""

    safe_stop: Performers | Literal["all"]


class Wait(_Model):
    wait: Seconds


class SetCue(_Model):
    """Write settings at once (as a routine's ``set:`` cue: ``{gait: walk}``) on performers
    (default: all), beside whatever they play: nobody's routine is cut."""

    set: Annotated[dict[Name, Any], Field(min_length=1)]
    performers: Performers | None = None


class LedCue(_Model):
    """Set LED colours at once (as a routine's ``led:`` cue: ``{all: red}``) on performers
    (default: all), beside whatever they play."""

    led: Annotated[dict[Name, Any], Field(min_length=1)]
    performers: Performers | None = None


class Publish(_Model):
    """Publish a named event (printed in the trace, published on the event bus)."""

    publish: Name


class Switch(_Model):
    """Make another behaviour set the active one."""

    switch: Name


_ACTIONS: dict[str, type[_Model]] = {
    "play": Play,
    "loop": Loop,
    "stop": Stop,
    "safe_stop": SafeStop,
    "wait": Wait,
    "set": SetCue,
    "led": LedCue,
    "publish": Publish,
    "switch": Switch,
}
ACTION_KINDS: tuple[str, ...] = tuple(_ACTIONS)

if TYPE_CHECKING:
    ActionModel = _Model
else:
    ActionModel = _tagged_union(_ACTIONS, "action", "an")

# -- file -------------------------------------------------------------------------------------


class PerformerRef(_Model):
    model: Annotated[str, Field(min_length=1)]
    port: Annotated[str, Field(min_length=1)] | None = None


class RuleModel(_Model):
    """One rule: when any trigger fires and every condition holds, run the actions."""

    name: Name
    when: Annotated[list[TriggerModel], Field(min_length=1)]
    if_: ConditionModel | None = Field(None, alias="if")
    do: Annotated[list[ActionModel], Field(min_length=1)]
    mode: Literal["single", "restart", "queued", "parallel"] = "single"
    priority: Annotated[int, Field(ge=0, le=99)] = 0
    safety: bool = Field(False, description="Pre-empts every non-safety rule.")
    sets: Annotated[list[Name], Field(min_length=1)] | None = Field(
        None, description="Behaviour sets the rule is active in (default: all)."
    )


class BehaviourFile(_Model):
    """A behaviour file."""

    behaviour: Annotated[str, Field(min_length=1)] = Field(description="The behaviour's name.")
    performers: Annotated[dict[Name, PerformerRef], Field(min_length=1)]
    routines: Annotated[dict[Name, Annotated[str, Field(min_length=1)]], Field(min_length=1)] = (
        Field(description="Routine files by name, relative to this file.")
    )
    triggers: list[Name] = Field(
        default_factory=list, description="Remote triggers the rules may wait for."
    )
    sets: list[Name] = Field(default_factory=list, description="Behaviour sets (states).")
    initial: Name | None = Field(None, description="The set active at start-up.")
    offline_after: Seconds = Field(
        1.0, description="Seconds without telemetry before a robot counts as offline."
    )
    rules: Annotated[list[RuleModel], Field(min_length=1)]


AllOf.model_rebuild()
AnyOf.model_rebuild()
NotC.model_rebuild()
RuleModel.model_rebuild()
BehaviourFile.model_rebuild()
