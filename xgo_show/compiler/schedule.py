"""The compiled schedule: what the compiler produces and the runtime executes.

A schedule holds, per performer, the exact wire bytes of every frame and the planned time its
first byte goes out (seconds from show start), already paced to the performer's link.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Final, NamedTuple, overload

from xgo_show.choreo.music import Music
from xgo_show.choreo.sections import Section
from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.profiles.model import Link

__all__ = [
    "SCHEDULE_VERSION",
    "FrameColumns",
    "Frames",
    "PerformerSchedule",
    "Schedule",
    "ScheduledFrame",
    "frame_columns",
    "frame_data",
    "ready_frames",
    "to_us",
]

SCHEDULE_VERSION = 2  # of the schedule file (xgo_show.compiler.artifact)


def to_us(seconds: float) -> int:
    """Seconds -> integer microseconds (round half to even, deterministic)."""
    return round(seconds * 1_000_000)


class ScheduledFrame:
    """One frame: planned send time, exact bytes, where it came from, how long it acts.

    A value: treat it as immutable (mypy does: its attributes are ``Final``). Slotted, with a
    plain ``__init__``: a compiled show makes hundreds of thousands of these (0.06 s for
    325,551 against 0.14 s for a frozen dataclass filled through its ``__dict__``).

    Its :attr:`label` is not stored: it is derived from the bytes when read, by ``labels`` (a
    ``bytes -> str`` shared by a performer's frames, e.g. :func:`xgo_show.compiler.state.
    frame_labels`), so the label always says what the bytes say and costs nothing until shown.
    Equality and hashing look at ``t``, ``data``, ``origin`` and ``duration`` only.
    """

    __slots__ = ("data", "duration", "labels", "origin", "t")

    def __init__(
        self,
        t: float,
        data: bytes,
        origin: Origin | None = None,
        duration: float = 0.0,
        labels: Callable[[bytes], str] | None = None,
    ) -> None:
        self.t: Final = t
        self.data: Final = data
        self.origin: Final = origin
        # Seconds the frame's effect runs on its own: a preset action, an xArm move; 0 otherwise.
        self.duration: Final = duration
        self.labels: Final = labels

    @property
    def label(self) -> str:
        """What the frame says, e.g. ``body_z=98.0mm roll=5.0deg`` ("" without ``labels``)."""
        labels = self.labels
        return "" if labels is None else labels(self.data)

    def _key(self) -> tuple[float, bytes, Origin | None, float]:
        return (self.t, self.data, self.origin, self.duration)

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not ScheduledFrame:
            return NotImplemented
        assert isinstance(other, ScheduledFrame)
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        return (f"ScheduledFrame(t={self.t!r}, data={self.data!r}, origin={self.origin!r}, "
                f"duration={self.duration!r})")


class FrameColumns(NamedTuple):
    """A performer's frames as parallel columns, one entry a frame: what the compiler makes
    and the schedule file stores (see :class:`Frames`)."""

    starts_us: Sequence[int]  # planned send time, integer microseconds from show start
    data: Sequence[bytes]  # exact wire bytes
    origins: Sequence[Origin | None]
    durations: Sequence[float]  # seconds (ScheduledFrame.duration)
    labels: Callable[[bytes], str] | None  # shared by the frames (ScheduledFrame.labels)


class Frames(Sequence[ScheduledFrame]):
    """A performer's frames, kept as :class:`FrameColumns` until one is read.

    ``compile`` hands a schedule straight to the file writer, which reads the columns
    (:func:`frame_columns`): the 325,551 :class:`ScheduledFrame` objects of the compile_speed
    show would cost a tenth of a second to make for nothing. The first read of a frame (an
    index, an iteration) makes them all, once; equal to, and hashed like, the tuple of them.
    """

    __slots__ = ("_frames", "columns")

    def __init__(self, columns: FrameColumns) -> None:
        if not (len(columns.starts_us) == len(columns.data) == len(columns.origins)
                == len(columns.durations)):
            raise ValueError("frame columns of different lengths")
        self.columns: Final = columns
        self._frames: tuple[ScheduledFrame, ...] | None = None

    def frames(self) -> tuple[ScheduledFrame, ...]:
        """Every frame as a :class:`ScheduledFrame` (made on the first call)."""
        frames = self._frames
        if frames is None:
            starts, data, origins, durations, labels = self.columns
            frames = self._frames = tuple([
                ScheduledFrame(start / 1_000_000, d, origin, duration, labels)
                for start, d, origin, duration in zip(starts, data, origins, durations,
                                                      strict=True)
            ])
        return frames

    def __len__(self) -> int:
        return len(self.columns.data)

    @overload
    def __getitem__(self, index: int) -> ScheduledFrame: ...
    @overload
    def __getitem__(self, index: slice) -> tuple[ScheduledFrame, ...]: ...
    def __getitem__(self, index: int | slice) -> ScheduledFrame | tuple[ScheduledFrame, ...]:
        return self.frames()[index]

    def __iter__(self) -> Iterator[ScheduledFrame]:
        return iter(self.frames())

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Frames):
            return self is other or self.frames() == other.frames()
        if isinstance(other, tuple):
            return self.frames() == other
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self.frames())

    def __repr__(self) -> str:
        return repr(self.frames())


def ready_frames(frames: Sequence[ScheduledFrame]) -> None:
    """Make a :class:`Frames`' frame objects now (nothing to do for a tuple): a runtime calls
    it while it sets up, so that a show thread never stalls making them once started."""
    if isinstance(frames, Frames):
        frames.frames()


def frame_data(frames: Sequence[ScheduledFrame]) -> Sequence[bytes]:
    """Each frame's wire bytes: a :class:`Frames`' own column (no frame made), else read off
    the frames."""
    if isinstance(frames, Frames):
        return frames.columns.data
    return [f.data for f in frames]


def frame_columns(frames: Sequence[ScheduledFrame]) -> FrameColumns:
    """``frames`` as columns: a :class:`Frames`' own (no frame made), else read off the frames
    (``labels`` then the first frame's)."""
    if isinstance(frames, Frames):
        return frames.columns
    return FrameColumns(
        [round(f.t * 1_000_000) for f in frames], [f.data for f in frames],
        [f.origin for f in frames], [f.duration for f in frames],
        frames[0].labels if frames else None,
    )


@dataclass(frozen=True)
class PerformerSchedule:
    """One performer's paced frames (a tuple, or :class:`Frames` made from columns)."""

    name: str
    model: str
    link: Link
    frames: Sequence[ScheduledFrame]
    end: float  # seconds: when this performer's part is over (last cue end)
    port: str | None = None

    @property
    def total_bytes(self) -> int:
        return sum(map(len, frame_data(self.frames)))


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
