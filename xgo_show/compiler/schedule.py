"""The compiled schedule: what the compiler produces and the runtime executes.

A schedule holds, per performer, the exact wire bytes of every frame and the planned time its
first byte goes out (seconds from show start), already paced to the performer's link.
"""

from __future__ import annotations

from dataclasses import dataclass

from xgo_show.choreo.music import Music
from xgo_show.choreo.sections import Section
from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.profiles.model import Link

__all__ = ["SCHEDULE_VERSION", "PerformerSchedule", "Schedule", "ScheduledFrame", "to_us"]

SCHEDULE_VERSION = 1


def to_us(seconds: float) -> int:
    """Seconds -> integer microseconds (round half to even, deterministic)."""
    return round(seconds * 1_000_000)


@dataclass(frozen=True)
class ScheduledFrame:
    """One frame: planned send time, exact bytes, where it came from, what it says."""

    t: float
    data: bytes
    origin: Origin | None = None
    label: str = ""  # e.g. "body_z=98.0mm roll=5.0deg" — for transcripts and progress
    # Seconds the frame's effect runs on its own: a preset action, an xArm move; 0 otherwise.
    duration: float = 0.0


class _LazyLabel:
    """``ScheduledFrame.label``: the text given, or made from the frame's bytes when first read.

    The compiler makes hundreds of thousands of frames whose labels are mostly never read (a
    run prints a few, a transcript all): instead of the text it may store a callable, ``bytes
    -> str`` (one per performer), that makes it from ``data`` on first read and is replaced
    by the text. Reading ``label``, equality, hashing and repr see only text; the constructor
    takes the text as before.
    """

    def __get__(self, frame: ScheduledFrame | None, owner: type | None = None) -> str:
        if frame is None:
            return ""  # the field's default, as the dataclass declared it
        value = frame.__dict__["label"]
        if value.__class__ is str:
            return value
        text: str = value(frame.data)
        frame.__dict__["label"] = text  # a cache: the frame still reads the same
        return text

    def __set__(self, frame: ScheduledFrame, value: object) -> None:
        frame.__dict__["label"] = value  # the dataclass __init__ (object.__setattr__) lands here


# Installed after the dataclass is made, so the dataclass (fields, __init__, eq, repr) stays the
# plain declaration above; a data descriptor is read before the instance dict.
setattr(ScheduledFrame, "label", _LazyLabel())  # noqa: B010


@dataclass(frozen=True)
class PerformerSchedule:
    """One performer's paced frames."""

    name: str
    model: str
    link: Link
    frames: tuple[ScheduledFrame, ...]
    end: float  # seconds: when this performer's part is over (last cue end)
    port: str | None = None

    @property
    def total_bytes(self) -> int:
        return sum(len(f.data) for f in self.frames)


@dataclass(frozen=True)
class Schedule:
    """A whole show, compiled."""

    name: str
    source: str
    performers: tuple[PerformerSchedule, ...]
    control_rate: float
    on_failure: str = "halt_all"
    battery_floor: int = 20
    warnings: tuple[Diagnostic, ...] = ()
    version: int = SCHEDULE_VERSION
    bpm: float | None = None
    beats_per_bar: int = 4
    # The show's whole tempo map as (first bar, bpm, beats_per_bar) rows; empty without a tempo
    # (bpm/beats_per_bar above are its first row, kept for simple consumers).
    tempo_map: tuple[tuple[int, float, int], ...] = ()
    # Named parts of the show in time order; a section with a wait holds the show at its
    # start until a trigger releases it (xgo_show.choreo.sections). Empty: one straight run.
    sections: tuple[Section, ...] = ()
    music: Music | None = None  # the soundtrack (file found relative to the routine)

    def tempo(self) -> TempoMap | None:
        """The tempo map (bar/beat <-> seconds, tempo changes included), or None without one."""
        if self.tempo_map:
            return TempoMap([Segment(*row) for row in self.tempo_map])
        if self.bpm:
            return TempoMap.constant(self.bpm, self.beats_per_bar)
        return None

    @property
    def duration(self) -> float:
        return max((p.end for p in self.performers), default=0.0)

    def performer(self, name: str) -> PerformerSchedule:
        for p in self.performers:
            if p.name == name:
                return p
        raise KeyError(name)
