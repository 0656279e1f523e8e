"""Musical time: a tempo map that turns bar/beat positions and beat counts into seconds.

Bars and beats are counted from 1 (the show starts at bar 1, beat 1). A tempo map is a list of
segments, each starting at a bar with its own ``bpm`` and ``beats_per_bar``; a constant tempo is
one segment. Internally a position is an absolute beat count from show start (0 = bar 1 beat 1),
which makes every conversion a piecewise-linear, strictly increasing map.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["Segment", "TempoMap"]


@dataclass(frozen=True)
class Segment:
    """From ``bar`` on (1-based), ``bpm`` beats per minute and ``beats_per_bar`` beats a bar."""

    bar: int
    bpm: float
    beats_per_bar: int = 4


class TempoMap:
    """Conversions between seconds, absolute beats and bar/beat positions.

    Raises :class:`ValueError` for an invalid map (first segment not at bar 1, bars not
    increasing, non-positive tempo) or an invalid position; callers turn that into a diagnostic.
    """

    def __init__(self, segments: Sequence[Segment]) -> None:
        if not segments:
            raise ValueError("a tempo map needs at least one entry")
        if segments[0].bar != 1:
            raise ValueError(f"the tempo map must start at bar 1, not bar {segments[0].bar}")
        for prev, seg in itertools.pairwise(segments):
            if seg.bar <= prev.bar:
                raise ValueError(
                    f"tempo map bars must increase: bar {seg.bar} after bar {prev.bar}"
                )
        for seg in segments:
            if not (math.isfinite(seg.bpm) and seg.bpm > 0):
                raise ValueError(f"bpm must be a positive number, not {seg.bpm:g}")
            if seg.beats_per_bar < 1:
                raise ValueError(f"beats_per_bar must be at least 1, not {seg.beats_per_bar}")
        self.segments = tuple(segments)
        beats = [0.0]
        seconds = [0.0]
        for prev, seg in itertools.pairwise(segments):
            span = (seg.bar - prev.bar) * prev.beats_per_bar
            beats.append(beats[-1] + span)
            seconds.append(seconds[-1] + span * 60.0 / prev.bpm)
        self._beats = beats  # absolute beat where each segment starts
        self._seconds = seconds  # and the second
        self._bars = [seg.bar for seg in segments]  # and its bar (a lookup per position)

    @classmethod
    def constant(cls, bpm: float, beats_per_bar: int = 4) -> TempoMap:
        """One tempo and meter for the whole show."""
        return cls([Segment(1, bpm, beats_per_bar)])

    def _segment_by_beat(self, beat: float) -> int:
        return max(0, bisect.bisect_right(self._beats, beat) - 1)

    def _segment_by_second(self, t: float) -> int:
        return max(0, bisect.bisect_right(self._seconds, t) - 1)

    def seconds(self, beat: float) -> float:
        """Absolute beat count (0 = show start) -> seconds."""
        i = self._segment_by_beat(beat)
        return self._seconds[i] + (beat - self._beats[i]) * 60.0 / self.segments[i].bpm

    def beats(self, t: float) -> float:
        """Seconds -> absolute beat count (inverse of :meth:`seconds`)."""
        i = self._segment_by_second(t)
        return self._beats[i] + (t - self._seconds[i]) * self.segments[i].bpm / 60.0

    def beats_per_bar_at(self, t: float) -> int:
        """The meter in force at ``t`` seconds."""
        return self.segments[self._segment_by_second(t)].beats_per_bar

    def position_beats(self, bar: int, beat: float) -> float:
        """Bar/beat (1-based; beat may be fractional) -> absolute beat count."""
        if bar < 1:
            raise ValueError(f"bars count from 1, not {bar}")
        i = max(0, bisect.bisect_right(self._bars, bar) - 1)
        seg = self.segments[i]
        if not 1 <= beat < seg.beats_per_bar + 1:
            raise ValueError(
                f"beat {beat:g} is outside bar {bar}, which has beats 1..{seg.beats_per_bar}"
            )
        return self._beats[i] + (bar - seg.bar) * seg.beats_per_bar + (beat - 1)

    def position(self, bar: int, beat: float = 1) -> float:
        """Bar/beat (1-based) -> seconds from show start."""
        return self.seconds(self.position_beats(bar, beat))

    def bar_beat(self, t: float) -> tuple[int, float]:
        """Seconds -> (bar, beat), 1-based; the inverse of :meth:`position`."""
        b = self.beats(t)
        i = self._segment_by_beat(b)
        seg = self.segments[i]
        offset = b - self._beats[i]
        bars = math.floor(offset / seg.beats_per_bar + 1e-9)
        return seg.bar + bars, max(1.0, 1 + offset - bars * seg.beats_per_bar)

    def span(self, start: float, beats: float) -> float:
        """Seconds taken by ``beats`` beats that begin at ``start`` seconds."""
        return max(0.0, self.seconds(self.beats(start) + beats) - start)
