"""The resolved show: what the loader hands to the compiler.

Everything here is already validated against the device profiles, with times in seconds from
show start (tempo, bars/beats, phrases, repeats and includes are expanded away) and values in
physical units keyed by register name. The compiler is a pure function of this.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

from xgo_show.choreo.music import Music
from xgo_show.choreo.sections import Section
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.profiles.model import Limits

__all__ = [
    "ActionCue",
    "ArmCue",
    "Cue",
    "FadeCue",
    "MotionCue",
    "ResolvedShow",
    "ResolvedTrack",
    "SetCue",
]

FailurePolicy = Literal["halt_all", "continue"]


@dataclass(frozen=True)
class ActionCue:
    """Run a preset action (register 0x3E) for ``duration`` seconds."""

    start: float
    origin: Origin
    action_id: int
    name: str
    duration: float
    duration_given: bool = False  # the user gave it (e.g. Rider actions have no documented time)
    interrupts: bool = False  # may interrupt a still-running action on purpose


@dataclass(frozen=True)
class MotionCue:
    """Move registers to physical targets along one synchronised jerk-limited trajectory.

    ``duration`` None means "as fast as the limits allow". ``limits`` overrides the profile's
    per-register limits. Multi-point paths are consecutive MotionCues: ``segment`` is (n, of).
    ``given``: the length as the user wrote it, for messages, e.g. (0.25, "beats") for one
    segment of a 1-beat four-point path; None when given in seconds or not at all.
    """

    start: float
    origin: Origin
    targets: Mapping[str, float]
    duration: float | None = None
    limits: Mapping[str, Limits] = field(default_factory=dict)
    interrupts: bool = False
    segment: tuple[int, int] = (1, 1)
    given: tuple[float, str] | None = None


@dataclass(frozen=True)
class SetCue:
    """Write register values at once: settings, speeds, periodic motions, LED colours, gripper.

    Values are physical numbers for linear registers, choice names or numbers for enum
    registers, (r, g, b) tuples for RGB registers.
    """

    start: float
    origin: Origin
    values: Mapping[str, object]
    interrupts: bool = False


@dataclass(frozen=True)
class FadeCue:
    """Fade an RGB register from its current colour to ``to`` over ``duration`` seconds."""

    start: float
    origin: Origin
    register: str
    to: tuple[int, int, int]
    duration: float
    interrupts: bool = False  # may cut a fade of the same register still under way


@dataclass(frozen=True)
class ArmCue:
    """xArm: move servos (id -> position 0..1000) in ``duration`` seconds (one ServoMove)."""

    start: float
    origin: Origin
    positions: Mapping[int, int]
    duration: float
    interrupts: bool = False  # may cut a move of the same servo still under way, on purpose


Cue = ActionCue | MotionCue | SetCue | FadeCue | ArmCue


@dataclass(frozen=True)
class ResolvedTrack:
    """One performer's cues, sorted by start time."""

    performer: str
    model: str
    cues: tuple[Cue, ...]
    port: str | None = None


@dataclass(frozen=True)
class ResolvedShow:
    """A validated, fully expanded show."""

    name: str
    source: str  # path of the top-level file
    tracks: tuple[ResolvedTrack, ...]
    control_rate: float = 50.0  # Hz, trajectory sampling
    gap: float | None = None  # s of silence between frames; None = the profile's default
    decimate: bool = False  # allow dropping trajectory samples that do not fit the link
    on_failure: FailurePolicy = "halt_all"
    battery_floor: int = 20  # percent (XGO) below which pre-flight fails / telemetry faults
    end: float | None = None  # explicit show end in seconds, else the last cue's end
    bpm: float | None = None  # for progress display only (times are already in seconds)
    beats_per_bar: int = 4
    warnings: tuple[Diagnostic, ...] = ()  # non-fatal findings of the loader
    # The whole tempo map as (first bar, bpm, beats_per_bar) segments, empty without a tempo
    # (bpm/beats_per_bar above are its first segment). Bar <-> seconds with tempo changes:
    # xgo_show.choreo.timebase.TempoMap([Segment(*row) for row in tempo_map]).
    tempo_map: tuple[tuple[int, float, int], ...] = ()
    # Named parts of the show in time order; a section may wait for a trigger (see sections).
    sections: tuple[Section, ...] = ()
    music: Music | None = None  # the soundtrack, played on the show clock
