"""From cues to planned write frames: the compiler core's shared types.

The core is three modules, one job each: :mod:`~xgo_show.compiler.planner` walks a performer's
cues and files each tick's writes (settings, actions, move and fade samples);
:mod:`~xgo_show.compiler.merge` turns one tick's writes into as few frames as pays (the general
path, and the reference); :mod:`~xgo_show.compiler.fastpath` walks the ticks in time order,
de-duplicates, and builds the frames of ticks only moves and fades write straight from their
samples (the same frames as the general path: ``tests/compiler/test_fast_path.py`` checks it on
random tracks). :func:`~xgo_show.compiler.planner.plan_xgo_track` runs the three.


Everything runs on integer microseconds from show start, so equal times compare equal and the
output does not depend on float formatting. Trajectory and fade samples sit on a fixed tick grid
(tick ``k`` at ``k / control_rate`` seconds) but for each one's last, the exact target, which goes
out at the move's or fade's end itself; actions and settings go out at their own start.

Per tick, each register's physical value becomes its byte through :meth:`Register.to_byte` (or
:meth:`Register.encode_value` for settings); a *sample* whose bytes equal what was last sent is
dropped (settings and actions are always sent: the user asked for them). The registers left at
one tick are merged into as few frames as possible: registers at consecutive addresses share one
write frame (the layout is :meth:`Profile.walk`'s), and two runs separated by a small gap are
joined by re-sending the bytes the gap registers already hold, when that costs less link time
than a separate frame would (8 bytes of frame overhead plus the silence between frames).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from operator import attrgetter
from typing import NamedTuple, overload

from xgo_show.compiler.schedule import to_us
from xgo_show.diagnostics import Diagnostic, Origin

__all__ = [
    "BYTES",
    "TIME_EPS",
    "PlannedFrame",
    "PlannedFrames",
    "TrackPlan",
    "Write",
    "cue_label",
    "cut_rows",
    "first_tick",
    "tick_times",
    "tick_us",
    "to_us",
]

BYTES = tuple(bytes((i,)) for i in range(256))  # BYTES[b] == bytes((b,)), without making one
TIME_EPS = 1e-9  # seconds of float noise ignored when comparing times


def cut_rows(buf: bytes | bytearray, width: int) -> list[bytes]:
    """``buf`` cut into rows of ``width`` bytes (at least one), each a ``bytes``, in order; a
    shorter rest at the end is left out. One regular expression's ``findall`` makes them all
    in C, with no Python slice a row; its pattern is compiled once a width. Any byte is a
    row's: ``DOTALL`` lets ``.`` match a newline too.
    """
    cut = _CUTS.get(width)
    if cut is None:
        cut = _CUTS[width] = re.compile(b"." * width, re.DOTALL)
    return cut.findall(buf)


_CUTS: dict[int, re.Pattern[bytes]] = {}  # width -> a pattern matching that many bytes


def tick_us(k: int, rate: float) -> int:
    """Time of control tick ``k`` in integer microseconds."""
    return round(k * 1_000_000 / rate)


def tick_times(k0: int, k1: int, rate: float) -> list[int]:
    """:func:`tick_us` of ticks ``k0`` to ``k1`` (excluded).

    At a rate whose period is a whole number of microseconds (50 Hz: 20,000), every tick's
    time is exact in floats (``k * 1e6`` and its quotient are integers well below 2**53), so
    ``tick_us(k)`` is ``k`` periods: a range, not a ``round`` a tick.
    """
    if (rate.is_integer() and 0 < rate <= 1_000_000 and 1_000_000 % int(rate) == 0
            and k0 >= 0 and k1 * 1_000_000 < 2**53):
        period = 1_000_000 // int(rate)
        return list(range(k0 * period, k1 * period, period))
    return [round(k * 1_000_000 / rate) for k in range(k0, k1)]


def first_tick(t: float, rate: float) -> int:
    """Index of the first tick at or after ``t`` seconds."""
    return math.ceil(t * rate - TIME_EPS)


class Write(NamedTuple):
    """One register's bytes to send (at the tick it is filed under)."""

    address: int
    data: bytes
    origin: Origin | None
    order: int  # index of the cue in its track: authoring order breaks ties within a tick
    sample: bool  # a trajectory/fade sample: de-duplicated, and droppable when decimating
    duration: float = 0.0  # seconds a preset action runs


class PlannedFrame(NamedTuple):
    """A frame at its planned time, before pacing."""

    t_us: int
    data: bytes  # complete wire bytes
    # Every field in the frame, (address, bytes), and what the plan asked for (the gap fillers
    # are not there). Both empty in sample frames planned without details (plan_xgo_track)
    # and in xArm frames: pacing reads them only when decimating, and an xArm has no samples.
    fields: tuple[tuple[int, bytes], ...]
    written: tuple[Write, ...]
    origin: Origin | None
    order: int
    droppable: bool  # only samples in it
    action: bool  # starts a preset action
    duration: float = 0.0


_T_US, _DATA, _ORIGIN, _ORDER = (attrgetter("t_us"), attrgetter("data"), attrgetter("origin"),
                                  attrgetter("order"))


class PlannedFrames(Sequence[PlannedFrame]):
    """A performer's planned frames as parallel columns, one entry a frame, in planned order.

    Pacing and the schedule read a frame's time, bytes and cue only, column by column; the fast
    path (:mod:`~xgo_show.compiler.fastpath`) makes hundreds of thousands of *sample frames*
    and adds them here as columns (:meth:`add_samples`), with no :class:`PlannedFrame` made a
    frame nor taken apart again. Any other frame (the general merger's: settings, actions,
    ...) is added whole (:meth:`extend`) and kept as it is besides. Read as a sequence, a
    sample frame is made when read: no ``fields`` nor ``written``, droppable, no action, no
    duration, as the fast path planned them.
    """

    __slots__ = ("data", "orders", "origins", "t_us", "whole")

    def __init__(self, frames: Iterable[PlannedFrame] = ()) -> None:
        self.t_us: list[int] = []
        self.data: list[bytes] = []
        self.origins: list[Origin | None] = []
        self.orders: list[int] = []
        self.whole: dict[int, PlannedFrame] = {}  # frames added whole, by index
        self.extend(frames)

    @classmethod
    def of(cls, frames: Sequence[PlannedFrame]) -> PlannedFrames:
        """``frames`` as columns: themselves when they are, else read off the frames (every
        one kept whole)."""
        if isinstance(frames, PlannedFrames):
            return frames
        return cls(frames)

    def extend(self, frames: Iterable[PlannedFrame]) -> None:
        """Add frames, each kept whole."""
        frames = list(frames)
        at = len(self.data)
        self.whole.update(enumerate(frames, at))
        self.t_us += map(_T_US, frames)
        self.data += map(_DATA, frames)
        self.origins += map(_ORIGIN, frames)
        self.orders += map(_ORDER, frames)

    def add_samples(self, times: Sequence[int], data: Sequence[bytes],
                    origins: Sequence[Origin | None], orders: Sequence[int]) -> None:
        """Add sample frames: a time, bytes and cue (origin and order) each."""
        if not len(times) == len(data) == len(origins) == len(orders):
            raise ValueError("sample frame columns of different lengths")
        self.t_us += times
        self.data += data
        self.origins += origins
        self.orders += orders

    def add_run(self, times: Sequence[int], data: Sequence[bytes], origin: Origin | None,
                order: int) -> None:
        """Add sample frames all filed under one cue (``origin`` and ``order``)."""
        count = len(times)
        self.add_samples(times, data, [origin] * count, [order] * count)

    def durations(self) -> list[float]:
        """Each frame's ``duration``: 0.0 but in frames added whole (a preset action's)."""
        out = [0.0] * len(self.data)
        for index, frame in self.whole.items():
            out[index] = frame.duration
        return out

    def __len__(self) -> int:
        return len(self.data)

    def _made(self, index: int) -> PlannedFrame:
        frame = self.whole.get(index)
        if frame is None:
            return PlannedFrame(self.t_us[index], self.data[index], (), (), self.origins[index],
                                self.orders[index], True, False)  # duration 0.0
        return frame

    @overload
    def __getitem__(self, index: int) -> PlannedFrame: ...
    @overload
    def __getitem__(self, index: slice) -> list[PlannedFrame]: ...
    def __getitem__(self, index: int | slice) -> PlannedFrame | list[PlannedFrame]:
        at = range(len(self.data))[index]  # negative indices, slices, IndexError: as a list's
        if isinstance(at, range):
            return list(map(self._made, at))
        return self._made(at)

    def __iter__(self) -> Iterator[PlannedFrame]:
        return map(self._made, range(len(self.data)))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, (PlannedFrames, list, tuple)):
            return list(self) == list(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # mutable, as a list

    def __repr__(self) -> str:
        return f"PlannedFrames({list(self)!r})"


@dataclass
class TrackPlan:
    """A performer's planned frames, the end of its part, and what went wrong."""

    frames: Sequence[PlannedFrame]  # PlannedFrames from the XGO planner
    end: float
    diagnostics: list[Diagnostic]
    samples: int = 0  # planned frames that hold only samples


def cue_label(origin: Origin) -> str:
    """How messages name a cue: by its name, else by its line."""
    return f"cue {origin.cue!r}" if origin.cue else f"the cue at line {origin.line}"
