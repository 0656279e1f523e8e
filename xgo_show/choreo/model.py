"""The choreography language as pydantic models: what a routine file may contain.

These models check the *shape* of a file (fields, types, simple bounds). What depends on the
robot (register names, ranges, actions, capabilities) and on time (overlaps) is checked after
resolution, in :mod:`xgo_show.choreo.resolve` and :mod:`xgo_show.choreo.checks`.

A cue is a mapping with exactly one *kind* key (``action``, ``move``, ``set``, ...) plus timing
fields. See docs/choreography.md for the language reference.
"""



import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Annotated, Any, Literal, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    PlainValidator,
    StringConstraints,
    Tag,
    ValidationInfo,
    WithJsonSchema,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from xgo_show.choreo.source import Refused
from xgo_show.choreo.unions import tagged_union
from xgo_show.choreo.unit import Unit
from xgo_show.errors import NetworkError
from xgo_show.limits import (
    MAX_BARS,
    MAX_BEATS,
    MAX_BEATS_PER_BAR,
    MAX_BPM,
    MAX_CONTROL_RATE,
    MAX_GAP_MS,
    MAX_LIMIT,
    MAX_MUSIC_OFFSET,
    MAX_REPEAT,
    MAX_SHOW_SECONDS,
    MIN_BPM,
    MIN_CONTROL_RATE,
    MIN_GAP_MS,
    MIN_LIMIT,
    MIN_MUSIC_OFFSET,
)
from xgo_show.net.keys import is_relay_url, parse_relay_url

__all__ = [
    "BLOCK_KINDS",
    "CUE_KINDS",
    "ActionCueModel",
    "ArmCueModel",
    "ArmTarget",
    "CueList",
    "CueModel",
    "GripperCueModel",
    "IncludeCueModel",
    "LedCueModel",
    "Length",
    "LengthField",
    "LimitsOverride",
    "MoveCueModel",
    "ParamPartMapping",
    "ParamValue",
    "PartMapping",
    "PerformerModel",
    "PeriodicCueModel",
    "PhraseCueModel",
    "PhraseModel",
    "PoseCueModel",
    "PoseDegCueModel",
    "Position",
    "PositionField",
    "RepeatCueModel",
    "RestCueModel",
    "SectionModel",
    "SetCueModel",
    "SettingsModel",
    "ShowFile",
    "TempoConstant",
    "TempoEntry",
    "WaitModel",
    "WalkCueModel",
    "cue_kind",
]

# A value for a register, servo or axis: its own range is the robot's, checked once the
# performer's model is known; here only what any number must be (the YAML loader already
# refuses magnitudes past 2^53, which the bounds restate for the schema).
Number = Annotated[float, Field(ge=-(2.0**53), le=2.0**53, allow_inf_nan=False)]
# Every time and length in seconds lies within one show (xgo_show.limits).
Seconds = Annotated[float, Field(ge=0, le=MAX_SHOW_SECONDS, allow_inf_nan=False), Unit("s")]
Beats = Annotated[float, Field(ge=0, le=MAX_BEATS, allow_inf_nan=False)]
Bars = Annotated[float, Field(ge=0, le=MAX_BARS, allow_inf_nan=False)]
Bpm = Annotated[float, Field(ge=MIN_BPM, le=MAX_BPM, allow_inf_nan=False)]
BeatsPerBar = Annotated[int, Field(ge=1, le=MAX_BEATS_PER_BAR)]
# A trajectory limit: what the planner handles (xgo_show.profiles.model.LIMIT_RANGE).
LimitValue = Annotated[float, Field(ge=MIN_LIMIT, le=MAX_LIMIT, allow_inf_nan=False)]
Name = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_-]*$")]
Scalar = Union[Number, str, bool]  # noqa: UP007  (a runtime union for pydantic)


def _param_value(value: object) -> object:
    # Any YAML value keeps its own type (an int stays an int): the place of use checks it.
    if value is None:
        raise PydanticCustomError(
            "param", "a parameter value cannot be null (null in params: means 'must be given')",
            {},
        )
    return value


ParamValue = Annotated[
    Any,
    PlainValidator(_param_value),
    WithJsonSchema({
        "description": "A parameter's value: any YAML value (number, string, list, mapping); "
        "it keeps its type and is checked where the cues use it.",
        "not": {"type": "null"},
    }),
]
ParamDefault = Annotated[
    Any,
    WithJsonSchema({
        "description": "The parameter's default value (any YAML value); null = must be given."
    }),
]

# ASCII digits only: int() would read other scripts' digits ("٥.٣") as a bar and beat.
_BAR_BEAT = re.compile(r"^\s*(\d+)\s*\.\s*(\d+)\s*$", re.ASCII)
_SECONDS = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*s\s*$", re.ASCII)  # "12.5s": seconds, on purpose


class _Model(BaseModel):
    # defer_build: each model's validator is made when it is first used, not when the module
    # is imported; a routine is validated as a whole (ShowFile's one validator), so most of
    # the thirty-odd models never need one of their own.
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, defer_build=True)

    @field_validator("*", mode="before")
    @classmethod
    def _not_null(cls, value: object, info: ValidationInfo) -> object:
        # "duration:" with nothing after it is null: taken as "not given", the move would
        # silently run as fast as it can. An optional field is left out, never written empty.
        if value is None:
            raise PydanticCustomError(
                "null", "{field} is empty (null): give a value, or leave {field} out",
                {"field": info.field_name})
        return value


# -- time -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Position:
    """A point in time: ``seconds`` from the start of the enclosing block, or a bar/beat."""

    seconds: float | None = None
    bar: int | None = None
    beat: float = 1.0
    # Seconds written as a bare number: in a show with a tempo the resolver asks whether a bar
    # was meant ("12.5s" says seconds on purpose).
    bare: bool = field(default=False, compare=False)

    def describe(self) -> str:
        if self.seconds is not None:
            return f"{self.seconds:g} s"
        return f"bar {self.bar} beat {self.beat:g}"


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _no_refused(value: dict[Any, Any]) -> None:
    """A mapping holding a value the YAML reader refused (and reported at its own place) is
    refused as such: the loader drops the complaint, which is about that value again."""
    for item in value.values():
        if isinstance(item, Refused):
            raise PydanticCustomError("refused", "holds {value}", {"value": repr(item)})


def _g(value: float) -> str:
    """``1e9``, ``0.001``, ``60000``: a number as a person writes it (an int too)."""
    value = float(value)
    text = f"{value:g}" if abs(value) < 1e6 or not value.is_integer() else f"{value:.6g}"
    return text.replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")


def _finite(value: float) -> bool:
    return value == value and value not in (float("inf"), float("-inf"))


def _parse_position(value: object) -> Position:
    if _is_number(value):
        return Position(seconds=_seconds(float(value)), bare=True)  # type: ignore[arg-type]
    if isinstance(value, str):
        seconds_match = _SECONDS.match(value)
        if seconds_match:
            return Position(seconds=_seconds(float(seconds_match[1])))
        match = _BAR_BEAT.match(value)
        if not match:
            # A parameter is a whole value, never a piece of a string.
            hint = " (a parameter goes in whole: {bar: $bar, beat: 1})" if "$" in value else ""
            raise PydanticCustomError(
                "position",
                "{value!r} is not a time: write seconds (12.5 or \"12.5s\"), \"BAR.BEAT\" "
                "(\"5.3\") or "
                "{bar: 5, beat: 3.5}{hint}",
                {"value": value, "value!r": repr(value), "hint": hint},
            )
        bar, beat = int(match[1]), int(match[2])
        return _bar_beat(bar, beat)
    if isinstance(value, dict):
        _no_refused(value)
        unknown = set(value) - {"bar", "beat"}
        if unknown or "bar" not in value:
            raise PydanticCustomError(
                "position",
                "a bar/beat time is {bar: N, beat: B} (beat optional, from 1); got keys {keys}",
                {"keys": ", ".join(map(str, value)) or "none"},
            )
        bar, beat = value["bar"], value.get("beat", 1)
        if not isinstance(bar, int) or isinstance(bar, bool) or not _is_number(beat):
            raise PydanticCustomError(
                "position", "bar must be a whole number and beat a number", {}
            )
        return _bar_beat(bar, float(beat))
    raise PydanticCustomError(
        "position",
        "a time is seconds (12.5), \"BAR.BEAT\" (\"5.3\") or {bar: 5, beat: 3}, not {kind}",
        {"kind": type(value).__name__},
    )


def _seconds(seconds: float) -> float:
    if not _finite(seconds) or not 0 <= seconds <= MAX_SHOW_SECONDS:
        which = "too large" if seconds > MAX_SHOW_SECONDS else "too small"
        raise PydanticCustomError(
            "position", "{value} s is {which}: a time is 0 to {most} s from the start",
            {"value": _g(seconds), "which": which, "most": _g(MAX_SHOW_SECONDS)},
        )
    return seconds


def _bar_beat(bar: int, beat: float) -> Position:
    if bar < 1 or not _finite(beat) or beat < 1:
        raise PydanticCustomError(
            "position", "bars and beats count from 1 (bar {bar}, beat {beat})",
            {"bar": bar if abs(bar) < 10**9 else _g(bar), "beat": _g(beat)},
        )
    if bar > MAX_BARS or beat >= MAX_BEATS_PER_BAR + 1:
        raise PydanticCustomError(
            "position", "bar {bar} beat {beat} is too late: bars go up to {bars} and a bar "
            "has at most {beats} beats",
            {"bar": bar if bar < 10**9 else _g(bar), "beat": _g(beat),
             "bars": f"{MAX_BARS:,}", "beats": MAX_BEATS_PER_BAR},
        )
    return Position(bar=bar, beat=beat)


_POSITION_SCHEMA: dict[str, Any] = {
    "description": "Seconds from the start of the block (number, or \"12.5s\"), \"BAR.BEAT\" "
    "(string) or {bar, beat}; bars and beats count from 1.",
    "anyOf": [
        {"type": "number", "minimum": 0, "maximum": MAX_SHOW_SECONDS},
        {"type": "string", "pattern": r"^\s*\d+\s*\.\s*\d+\s*$"},
        {"type": "string", "pattern": r"^\s*\d+(\.\d+)?\s*s\s*$"},
        {
            "type": "object",
            "properties": {
                "bar": {"type": "integer", "minimum": 1, "maximum": MAX_BARS},
                "beat": {"type": "number", "minimum": 1,
                         "exclusiveMaximum": MAX_BEATS_PER_BAR + 1},
            },
            "required": ["bar"],
            "additionalProperties": False,
        },
    ],
}

PositionField = Annotated[
    Position, PlainValidator(_parse_position), WithJsonSchema(_POSITION_SCHEMA)
]


@dataclass(frozen=True)
class Length:
    """A span of time: ``amount`` of ``unit`` (seconds, beats or bars)."""

    amount: float
    unit: Literal["seconds", "beats", "bars"] = "seconds"

    def describe(self) -> str:
        return f"{self.amount:g} {self.unit}"


_LENGTH_UNITS = ("seconds", "beats", "bars")
_LENGTH_MOST = {"seconds": MAX_SHOW_SECONDS, "beats": float(MAX_BEATS), "bars": float(MAX_BARS)}


def _parse_length(value: object) -> Length:
    if _is_number(value):
        amount = float(value)  # type: ignore[arg-type]
        unit = "seconds"
    elif isinstance(value, dict) and len(value) == 1 and next(iter(value)) in _LENGTH_UNITS:
        _no_refused(value)
        unit, raw = next(iter(value.items()))
        if not _is_number(raw):
            raise PydanticCustomError(
                "length", "{unit} must be a number, not {value!r}", {"unit": unit, "value": raw,
                                                                      "value!r": repr(raw)}
            )
        amount = float(raw)
    else:
        raise PydanticCustomError(
            "length",
            "a length is seconds (1.5) or one of {beats: N}, {bars: N}, {seconds: N}",
            {},
        )
    most = _LENGTH_MOST[unit]
    if not _finite(amount) or not 0 <= amount <= most:
        symbol = "s" if unit == "seconds" else unit
        raise PydanticCustomError(
            "length", "{amount} {unit} is {which}: a length is 0 to {most} {unit}",
            {"amount": _g(amount), "unit": symbol, "most": _g(most),
             "which": "too large" if amount > most else "too small"},
        )
    return Length(amount, unit)  # type: ignore[arg-type]


_LENGTH_SCHEMA: dict[str, Any] = {
    "description": "Seconds (number) or {beats: N} / {bars: N} / {seconds: N}.",
    "anyOf": [
        {"type": "number", "minimum": 0, "maximum": MAX_SHOW_SECONDS},
        *(
            {
                "type": "object",
                "properties": {u: {"type": "number", "minimum": 0, "maximum": _LENGTH_MOST[u]}},
                "required": [u],
                "additionalProperties": False,
            }
            for u in _LENGTH_UNITS
        ),
    ],
}

LengthField = Annotated[Length, PlainValidator(_parse_length), WithJsonSchema(_LENGTH_SCHEMA)]


# -- colours ----------------------------------------------------------------------------------

Color = Annotated[
    Union[str, list[int], bool],  # noqa: UP007  (bool: false is off, as YAML 1.1 read it)
    WithJsonSchema(
        {
            "description": "A colour name (red, warm_white, off...), \"#rrggbb\" or [r, g, b].",
            "anyOf": [
                {"type": "string"},
                {"const": False, "description": "YAML reads an unquoted off as false"},
                {
                    "type": "array",
                    "items": {"type": "integer", "minimum": 0, "maximum": 255},
                    "minItems": 3,
                    "maxItems": 3,
                },
            ],
        }
    ),
]


# -- cues -------------------------------------------------------------------------------------


class _Timing(_Model):
    """When a cue starts and how long its slot lasts."""

    at: PositionField | None = Field(
        None, description="Start time from the start of the enclosing block (track, phrase...)."
    )
    after: LengthField | None = Field(
        None, description="Gap after the previous cue's end (default 0)."
    )
    duration: Seconds | None = Field(None, description="Length in seconds.")
    beats: Beats | None = Field(None, description="Length in beats (needs a tempo).")
    bars: Bars | None = Field(None, description="Length in bars (needs a tempo).")
    interrupt: bool = Field(
        False, description="May cut a preset action that is still running (on purpose)."
    )

    @model_validator(mode="after")
    def _one_timing(self) -> "_Timing":
        if self.at is not None and self.after is not None:
            raise PydanticCustomError(
                "timing", "give either 'at' or 'after', not both", {}
            )
        if self.beats is None and self.bars is None:
            return self  # one length at most (most cues: a duration or none)
        given = [n for n in ("duration", "beats", "bars") if getattr(self, n) is not None]
        if len(given) > 1:
            raise PydanticCustomError(
                "timing", "give one length, not {given}", {"given": " and ".join(given)}
            )
        return self


class _BlockTiming(_Model):
    """Blocks (phrase, repeat, include, rest) are placed like cues but last as long as they do."""

    at: PositionField | None = Field(None, description="Start time within the enclosing block.")
    after: LengthField | None = Field(None, description="Gap after the previous cue's end.")

    @model_validator(mode="after")
    def _one_timing(self) -> "_BlockTiming":
        if self.at is not None and self.after is not None:
            raise PydanticCustomError("timing", "give either 'at' or 'after', not both", {})
        return self


class ActionCueModel(_Timing):
    """Run a preset action, by name or number."""

    action: Annotated[str, Field(min_length=1)] | Annotated[int, Field(ge=0, le=255)]


class LimitsOverride(_Model):
    """Per-register trajectory limits that replace the profile's (any subset)."""

    velocity: LimitValue | None = None
    acceleration: LimitValue | None = None
    jerk: LimitValue | None = None


class MoveCueModel(_Timing):
    """Move registers smoothly to targets; a list of targets is a path through each point."""

    move: Annotated[dict[str, Number | Annotated[list[Number], Field(min_length=1)]],
                    Field(min_length=1)]
    limits: dict[str, LimitsOverride] = Field(default_factory=dict)


class SetCueModel(_Timing):
    """Write register values at once (settings, speeds, modes)."""

    set: Annotated[dict[str, Scalar], Field(min_length=1)]


class WalkCueModel(_Timing):
    """Walk/drive at speeds for the cue's length, then back to standstill."""

    walk: Annotated[dict[str, Number], Field(min_length=1)]


PeriodicAxis = Literal["roll", "pitch", "yaw", "x", "y", "z"]


class PeriodicCueModel(_Timing):
    """Periodic body motion: axis -> period in seconds; 0 stops it."""

    periodic: Annotated[dict[PeriodicAxis, Seconds], Field(min_length=1)]


class LedCueModel(_Timing):
    """Set LED colours (led1..led4 or all), optionally fading."""

    led: Annotated[dict[str, Color], Field(min_length=1)]
    fade: LengthField | None = Field(None, description="Fade from the current colour this long.")


class GripperCueModel(_Timing):
    """Close the gripper to a percentage (0 = open, 100 = closed)."""

    gripper: Number


class ArmTarget(_Model):
    """Dog arm end point in mm."""

    x: Number | None = None
    z: Number | None = None


class ArmCueModel(_Timing):
    """Move a dog's arm end point smoothly."""

    arm: ArmTarget


class PoseCueModel(_Timing):
    """xArm: servo id -> position 0..1000."""

    pose: Annotated[dict[int, Annotated[int, Field(ge=-(2**53), le=2**53)]], Field(min_length=1)]


class PoseDegCueModel(_Timing):
    """xArm: servo id -> angle in degrees (-125..125)."""

    pose_deg: Annotated[dict[int, Number], Field(min_length=1)]


class RestCueModel(_BlockTiming):
    """Do nothing for a while."""

    rest: LengthField


class PhraseCueModel(_BlockTiming):
    """Play a phrase defined under ``phrases:``, with parameter values."""

    phrase: Name
    with_: dict[str, ParamValue] = Field(
        default_factory=dict, alias="with", description="Parameter values (name -> value)."
    )

    model_config = ConfigDict(populate_by_name=True)


class RepeatCueModel(_BlockTiming):
    """Play ``cues`` ``repeat`` times in a row."""

    repeat: Annotated[int, Field(ge=1, le=MAX_REPEAT)]
    cues: Annotated[list["CueModel"], Field(min_length=1)]


class IncludeCueModel(_BlockTiming):
    """Play the cues of another file (path relative to this file), with parameter values."""

    include: Annotated[str, Field(min_length=1)]
    with_: dict[str, ParamValue] = Field(
        default_factory=dict, alias="with",
        description="Values of the part's parameters (its params:).",
    )

    model_config = ConfigDict(populate_by_name=True)


_CUE_CLASSES: dict[str, type[BaseModel]] = {
    "action": ActionCueModel,
    "move": MoveCueModel,
    "set": SetCueModel,
    "walk": WalkCueModel,
    "periodic": PeriodicCueModel,
    "led": LedCueModel,
    "gripper": GripperCueModel,
    "arm": ArmCueModel,
    "pose": PoseCueModel,
    "pose_deg": PoseDegCueModel,
    "rest": RestCueModel,
    "phrase": PhraseCueModel,
    "repeat": RepeatCueModel,
    "include": IncludeCueModel,
}
CUE_KINDS: tuple[str, ...] = tuple(_CUE_CLASSES)
_KIND_OF: dict[type, str] = {cls: kind for kind, cls in _CUE_CLASSES.items()}
_KIND_SET = frozenset(CUE_KINDS)
BLOCK_KINDS: frozenset[str] = frozenset({"rest", "phrase", "repeat", "include"})


def cue_kind(value: object) -> str | None:
    """The kind key of a raw cue mapping (or cue model), or None if it has none or several."""
    return _cue_key(value)


def _cue_tag(value: object) -> str | None:
    # Union tags differ from the data's keys so that error locations stay unambiguous.
    kind = _cue_key(value)
    return None if kind is None else f"{kind}-cue"


def _cue_key(value: object) -> str | None:
    kind = _KIND_OF.get(value.__class__)  # a cue model (the resolver asks for every cue)
    if kind is not None:
        return kind
    if isinstance(value, BaseModel):
        for kind, cls in _CUE_CLASSES.items():
            if isinstance(value, cls):
                return kind
        return None
    if not isinstance(value, dict):
        return None
    kinds = [k for k in value if k in _KIND_SET]  # a cue's few keys, not all the kinds
    return kinds[0] if len(kinds) == 1 else None


if TYPE_CHECKING:  # what the checker sees; pydantic gets the union built from the table
    CueModel = _Model
else:
    CueModel = tagged_union(_CUE_CLASSES, _cue_tag, suffix="-cue", error_type="cue_kind",
                            message="a cue needs exactly one kind key")
# RepeatCueModel's cues (CueModel, defined after it) resolve when its validator is first made:
# a routine's is ShowFile's, which holds every cue model once (a rebuild here made them all at
# import, then again in ShowFile's).


# -- show -------------------------------------------------------------------------------------


class TempoConstant(_Model):
    """One tempo for the whole show."""

    bpm: Bpm
    beats_per_bar: BeatsPerBar = 4


class TempoEntry(_Model):
    """From ``bar`` on, this tempo (and meter; default: the previous entry's)."""

    bar: Annotated[int, Field(ge=1, le=MAX_BARS)]
    bpm: Bpm
    beats_per_bar: BeatsPerBar | None = None


class TempoFile(_Model):
    """The tempo map is in another file (``xgo-show beats song.ogg -o song.tempo.yaml``),
    named relative to this one."""

    file: Annotated[str, Field(min_length=1)]


def _tempo_kind(value: object) -> str:
    if isinstance(value, list):
        return "map"
    return "file" if isinstance(value, dict) and "file" in value else "constant"


_Constant = Annotated[TempoConstant, Tag("constant")]
_Map = Annotated[Annotated[list[TempoEntry], Field(min_length=1)], Tag("map")]

Tempo = Annotated[
    Union[_Constant, _Map, Annotated[TempoFile, Tag("file")]],  # noqa: UP007
    Discriminator(_tempo_kind),
]


class TempoMapFile(_Model):
    """A tempo-map file (``tempo: {file: ...}``): ``tempo:`` as a routine writes it inline."""

    tempo: Annotated[Union[_Constant, _Map], Discriminator(_tempo_kind)]  # noqa: UP007


class MusicModel(_Model):
    """The show's soundtrack: played with it by run and dry-run, on the show clock."""

    file: Annotated[str, Field(min_length=1)] = Field(
        description="WAV, FLAC, MP3 or OGG file, relative to this routine."
    )
    offset: Annotated[float, Field(ge=MIN_MUSIC_OFFSET, le=MAX_MUSIC_OFFSET,
                                   allow_inf_nan=False)] = Field(
        0.0,
        description="Seconds into the recording at bar 1 beat 1 (negative: the music starts "
        "that long after the show).",
    )


class SettingsModel(_Model):
    """Show-wide settings for the compiler and the runtime."""

    control_rate: Annotated[float, Field(ge=MIN_CONTROL_RATE, le=MAX_CONTROL_RATE,
                                         allow_inf_nan=False)] = Field(
        50.0, description="Trajectory samples per second (Hz)."
    )
    gap_ms: Annotated[float, Field(ge=MIN_GAP_MS, le=MAX_GAP_MS,
                                   allow_inf_nan=False)] | None = Field(
        None, description="Silence between frames in ms (default: the robot's own)."
    )
    decimate: bool = Field(
        False, description="Allow dropping trajectory samples that do not fit the link."
    )
    on_failure: Literal["halt_all", "continue"] = "halt_all"
    battery_floor: Annotated[int, Field(ge=0, le=100)] = Field(
        20, description="Battery % below which the pre-flight check fails."
    )
    end: PositionField | None = Field(None, description="Explicit show end.")
    timed_by_hand: list[Name] = Field(
        default_factory=list,
        description="Preset actions the documents give no duration for (the Rider's) whose "
        "durations in this routine you have timed on the robot: their warning is silenced.",
    )


class PerformerModel(_Model):
    """One robot on stage."""

    model: Literal["mini", "lite", "rider", "xarm"]
    port: Annotated[str, Field(min_length=1)] | None = Field(
        None,
        description="Serial port or transport URL; zenoh:RELAY/ROBOT is a robot behind an "
        "xgo-show relay (zenoh:RELAY: its robot named like the performer).",
    )
    arm: bool = Field(False, description="Dogs: carries the arm and gripper accessory.")

    @field_validator("port")
    @classmethod
    def _relay_url(cls, port: str | None) -> str | None:
        # A relay named in the show: a typo is reported at its line, not when the show starts.
        if port is not None and is_relay_url(port):
            try:
                parse_relay_url(port, "rex")  # zenoh:RELAY alone: a performer name fits
            except NetworkError as exc:
                raise PydanticCustomError("relay_url", "{problem}", {"problem": str(exc)}) from None
        return port


class WaitModel(_Model):
    """Hold the show at the section's start until a trigger arrives (or the timeout passes)."""

    trigger: Name = Field(description="The trigger's name (any client may fire it).")
    timeout: Annotated[float, Field(gt=0, le=MAX_SHOW_SECONDS, allow_inf_nan=False)] | None = Field(
        None, description="Seconds to wait at most (default: until the trigger comes)."
    )
    else_: Name | None = Field(
        None,
        alias="else",
        description="After the timeout: a section to jump to, 'continue' (play on, the "
        "default) or 'end' (skip to the show's end).",
    )

    model_config = ConfigDict(populate_by_name=True)

    @model_validator(mode="after")
    def _else_needs_timeout(self) -> "WaitModel":
        if self.else_ is not None and self.timeout is None:
            raise PydanticCustomError(
                "wait", "'else' says what happens after the timeout: give 'timeout' too", {}
            )
        return self


class SectionModel(_Model):
    """A named part of the show from ``at`` to the next section's start."""

    name: Name = Field(description="The section's name (seek targets, else: jumps, status).")
    at: PositionField | None = Field(
        None, description="Start, from the show's start (default 0 for the first section)."
    )
    wait: WaitModel | None = Field(
        None, description="Hold at the section's start until a trigger releases it."
    )


class PhraseModel(_Model):
    """A reusable sequence of cues with parameters (``$name`` in the cues)."""

    params: dict[Name, ParamDefault] = Field(
        default_factory=dict, description="Parameter defaults; null = must be given."
    )
    cues: Annotated[list[Any], Field(min_length=1)] = Field(
        json_schema_extra={"items": {"type": "object"}}
    )


class ShowFile(_Model):
    """A routine file."""

    show: Annotated[str, Field(min_length=1)] = Field(description="The show's name.")
    tempo: Tempo | None = None
    music: MusicModel | None = None
    # The defaults as they are (model_construct): a validator made for them alone would be
    # made again inside ShowFile's.
    settings: SettingsModel = SettingsModel.model_construct()
    performers: Annotated[dict[Name, PerformerModel], Field(min_length=1)]
    include: list[Annotated[str, Field(min_length=1)]] = Field(
        default_factory=list, description="Files whose phrases this show may use."
    )
    phrases: dict[Name, PhraseModel] = Field(default_factory=dict)
    sections: list[SectionModel] = Field(
        default_factory=list,
        description="Named parts of the show, in order; a section may wait for a trigger.",
    )
    tracks: Annotated[dict[Name, list[CueModel]], Field(min_length=1)]


class PartMapping(_Model):
    """An included file written as a mapping: phrases and/or cues."""

    phrases: dict[Name, PhraseModel] = Field(default_factory=dict)
    cues: list[CueModel] = Field(default_factory=list)


class ParamPartMapping(_Model):
    """An included file with parameters: ``$name`` in its cues stands for a value given with
    ``{include: FILE, with: {...}}``. The cues are checked once the values are known."""

    params: dict[Name, ParamDefault] = Field(
        description="Parameter defaults; null = must be given."
    )
    phrases: dict[Name, PhraseModel] = Field(default_factory=dict)
    cues: list[Any] = Field(
        default_factory=list, json_schema_extra={"items": {"type": "object"}}
    )


class CueList(_Model):
    """A bare list of cues (an included file, a phrase body), validated as ``{cues: [...]}``."""

    cues: list[CueModel]
