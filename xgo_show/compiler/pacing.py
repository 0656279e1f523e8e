"""Pace a performer's planned frames onto its serial link.

Frames go out in planned order. A frame starts no earlier than its planned time, and no earlier
than the previous frame's start plus that frame's wire time (``Link.wire_time``: 10 bits a byte,
86.8 µs a byte at 115200 baud) plus the silence between frames (the show's ``gap`` or the
profile's ``Link.gap``; the XGO document asks for "at least 1 ms between instructions" and we
read it the safe way: silence after the last byte, 1.2 ms for XGO robots, the 0.2 ms above the
1 ms a margin for delivery jitter measured by ``benchmarks/silence_jitter.py``; see
``xgo_show.profiles._common``). A frame that cannot start on time
moves later; gaps never shrink. All arithmetic is in integer microseconds, wire times rounded up.

**Link fit.** A track fits its link when every frame starts at most one control period
(``1 / control_rate``) after its planned time. Beyond that, the frame would land on or after the
next tick's frames, so the backlog is no longer a momentary burst but the link falling behind
the choreography. Every cue with a frame later than that is an error (the first late frame of
each cue is named), unless the show allows ``decimate``:

**Decimation.** A frame holding only trajectory or fade samples that would start more than
*half* a period late is dropped instead (actions and settings are never dropped, and keep the
other half period as headroom). The values it carried are not lost: they stay pending and go out
at the next tick when the link has room, unless a later frame overwrites the same registers
first. A preset action clears what is pending (the action takes the robot over). Settings and
actions that are still more than a period late are errors even with ``decimate``.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from itertools import islice
from operator import sub
from typing import NamedTuple

from xgo_show.compiler.frames import PlannedFrame, PlannedFrames, Write
from xgo_show.diagnostics import Origin
from xgo_show.profiles.model import Link

__all__ = ["PaceResult", "Paced", "pace", "wire_us"]


def wire_us(link: Link, nbytes: int) -> int:
    """Wire time of ``nbytes`` in whole microseconds, rounded up (integer arithmetic)."""
    num = nbytes * link.bits_per_byte * 1_000_000
    return -(-num // link.baud)


class Paced(NamedTuple):
    """A frame and the microsecond it starts on the wire (a tuple: cheap to make by the 100k)."""

    start_us: int
    frame: PlannedFrame


@dataclass
class PaceResult:
    """Paced frames, frames later than a period (errors), and decimation counts.

    The frames sent and their starts are two parallel lists, not a :class:`Paced` each: a show
    paces hundreds of thousands of frames, and the compiler reads them once (``frames`` pairs
    them up for other readers).
    """

    starts: list[int]  # the microsecond each frame of ``sent`` starts on the wire
    sent: Sequence[PlannedFrame]  # in order; without decimation, the planned frames themselves
    late: list[Paced] = field(default_factory=list)
    dropped: int = 0  # planned sample frames dropped
    first_drop_us: int | None = None
    first_drop_origin: Origin | None = None  # the cue of the first dropped frame

    @property
    def frames(self) -> list[Paced]:
        """Every frame sent with its start, in order."""
        return [Paced(start, f) for start, f in zip(self.starts, self.sent, strict=True)]


def pace(
    frames: Sequence[PlannedFrame],
    *,
    link: Link,
    gap_us: int,
    period_us: int,
    decimate: bool = False,
    remerge: Callable[[int, list[Write]], list[PlannedFrame]] | None = None,
) -> PaceResult:
    """Give every frame a start time on ``link`` (see the module docstring for the rules).

    ``frames`` must be in planned order. ``remerge(t_us, writes)`` builds frames for pending
    sample values when decimating (the compiler passes its frame merger); without it dropped
    values are simply superseded by later samples.
    """
    starts: list[int] = []
    sent: list[PlannedFrame] = []
    result = PaceResult(starts, sent)
    # Re-sends of pending values, as (planned us, sequence): they go after the planned frames
    # of the same microsecond, so a fresher sample supersedes them first.
    flushes: list[tuple[int, int]] = []
    seq = 0
    pending: dict[int, Write] = {}
    free_us = -(1 << 62)  # when the link may start the next frame
    half = period_us // 2

    def send(f: PlannedFrame, t_us: int, planned: bool) -> None:
        nonlocal free_us, seq
        start = t_us if t_us > free_us else free_us
        late_by = start - t_us
        if decimate and f.droppable and late_by > half:
            if planned:
                result.dropped += 1
                if result.first_drop_us is None:
                    result.first_drop_us = t_us
                    result.first_drop_origin = f.origin
            for w in f.written:
                pending[w.address] = w
            if remerge is not None and not flushes:
                heapq.heappush(flushes, (t_us + period_us, seq))
                seq += 1
            return
        starts.append(start)
        sent.append(f)
        if late_by > period_us:
            result.late.append(Paced(start, f))
        free_us = start + wire_us(link, len(f.data)) + gap_us
        if pending:
            if f.action:
                pending.clear()
            else:
                for address, _ in f.fields:
                    pending.pop(address, None)

    def flush_until(limit: int | None) -> None:
        while flushes and (limit is None or flushes[0][0] < limit):
            t_us, _ = heapq.heappop(flushes)
            if not pending or remerge is None:
                continue
            batch = remerge(t_us, [pending[a] for a in sorted(pending)])
            pending.clear()
            for f in batch:
                send(f, t_us, False)

    if not decimate:
        # send() without decimation (so nothing pending, nothing to flush, and every planned
        # frame sent): this loop runs once per frame of the show, so it reads two columns
        # (PlannedFrames: the fast path made them so), each frame's planned time and the link
        # time it takes (its wire time, one per frame length, plus the gap), and finds the
        # late frames afterwards.
        result.sent = frames
        append = starts.append
        columns = PlannedFrames.of(frames)
        planned = columns.t_us
        lengths = list(map(len, columns.data))
        if len(planned) < 2 or (min(map(sub, islice(planned, 1, None), planned))
                                >= wire_us(link, max(lengths)) + gap_us):
            # Every frame planned at least the longest frame's link time after the one before
            # (a performer sending one frame a tick): the link is free when each is planned,
            # so each starts then, and none is late (one C-level pass instead of the loop).
            result.starts = planned
            return result
        cost = {n: wire_us(link, n) + gap_us for n in set(lengths)}
        for t_us, busy in zip(planned, map(cost.__getitem__, lengths), strict=True):
            start = t_us if t_us > free_us else free_us
            append(start)
            free_us = start + busy
        if frames and max(map(sub, starts, planned)) > period_us:
            result.late = [Paced(start, columns[i]) for i, start, t_us
                           in zip(range(len(starts)), starts, planned, strict=True)
                           if start - t_us > period_us]
        return result
    for frame in frames:
        if flushes:
            flush_until(frame.t_us)
        send(frame, frame.t_us, True)
    flush_until(None)
    return result
