"""Tempo maps: bar/beat <-> seconds, constant and changing tempo and meter."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import TypeAdapter, ValidationError

from xgo_show.choreo.model import Length, LengthField, Position, PositionField
from xgo_show.choreo.timebase import Segment, TempoMap

PositionAdapter: TypeAdapter[Position] = TypeAdapter(PositionField)
LengthAdapter: TypeAdapter[Length] = TypeAdapter(LengthField)


def test_constant_tempo() -> None:
    tempo = TempoMap.constant(120)
    assert tempo.position(1, 1) == 0.0
    assert tempo.position(1, 3) == 1.0
    assert tempo.position(2, 1) == 2.0
    assert tempo.position(3, 2.5) == pytest.approx(4.75)
    assert tempo.span(10.0, 4) == pytest.approx(2.0)
    assert tempo.bar_beat(4.75) == (3, pytest.approx(2.5))


def test_tempo_map_changes_tempo_and_meter() -> None:
    # Bars 1-2 at 120 bpm 4/4 (4 s), bars 3-4 at 60 bpm 3/4 (3 s each).
    tempo = TempoMap([Segment(1, 120, 4), Segment(3, 60, 3)])
    assert tempo.position(3, 1) == pytest.approx(4.0)
    assert tempo.position(4, 1) == pytest.approx(7.0)
    assert tempo.position(3, 3) == pytest.approx(6.0)
    assert tempo.beats_per_bar_at(5.0) == 3
    # Two beats that straddle the change: half a second at 120, then one second at 60.
    assert tempo.span(3.5, 2) == pytest.approx(1.5)
    with pytest.raises(ValueError, match="beat 4 is outside bar 3"):
        tempo.position(3, 4)


@pytest.mark.parametrize(
    ("segments", "message"),
    [
        ([], "at least one"),
        ([Segment(2, 120)], "start at bar 1"),
        ([Segment(1, 120), Segment(1, 100)], "must increase"),
        ([Segment(1, 0)], "positive"),
        ([Segment(1, math.nan)], "positive"),
        ([Segment(1, 120, 0)], "at least 1"),
    ],
)
def test_invalid_maps(segments: list[Segment], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        TempoMap(segments)


tempo_maps = st.lists(
    st.tuples(
        st.integers(1, 16),
        st.floats(30, 300, allow_nan=False),
        st.integers(1, 12),
    ),
    min_size=1,
    max_size=6,
).map(
    lambda rows: TempoMap(
        [Segment(1, rows[0][1], rows[0][2])]
        + [
            Segment(1 + sum(r[0] for r in rows[1 : i + 1]), bpm, per_bar)
            for i, (_, bpm, per_bar) in enumerate(rows[1:], start=1)
        ]
    )
)


@given(tempo_maps, st.floats(0, 600), st.floats(0, 600))
def test_seconds_are_monotonic_in_beats(tempo: TempoMap, a: float, b: float) -> None:
    lo, hi = sorted((a, b))
    assert tempo.seconds(lo) <= tempo.seconds(hi) + 1e-9
    assert tempo.beats(tempo.seconds(a)) == pytest.approx(a, abs=1e-6)


@given(tempo_maps, st.integers(1, 80), st.data())
def test_bar_beat_round_trip(tempo: TempoMap, bar: int, data: st.DataObject) -> None:
    seg = [s for s in tempo.segments if s.bar <= bar][-1]
    beat = data.draw(st.floats(1, seg.beats_per_bar + 0.999))
    t = tempo.position(bar, beat)
    back_bar, back_beat = tempo.bar_beat(t)
    assert back_bar == bar
    assert back_beat == pytest.approx(beat, abs=1e-6)


@given(tempo_maps, st.floats(0, 300), st.floats(0, 64))
def test_span_is_positive_and_additive(tempo: TempoMap, start: float, beats: float) -> None:
    first = tempo.span(start, beats / 2)
    assert first >= 0
    assert first + tempo.span(start + first, beats / 2) == pytest.approx(
        tempo.span(start, beats), rel=1e-9, abs=1e-6
    )


@given(st.integers(1, 10_000), st.integers(1, 64))
def test_bar_beat_strings_parse(bar: int, beat: int) -> None:
    assert PositionAdapter.validate_python(f"{bar}.{beat}") == Position(bar=bar, beat=beat)
    assert PositionAdapter.validate_python({"bar": bar, "beat": beat}) == Position(
        bar=bar, beat=beat
    )


@given(st.one_of(st.text(max_size=12), st.floats(), st.integers(), st.none(), st.booleans(),
                 st.dictionaries(st.text(max_size=4), st.integers(), max_size=3)))
def test_time_parser_accepts_or_explains(value: object) -> None:
    try:
        pos = PositionAdapter.validate_python(value)
    except ValidationError as exc:
        assert exc.errors()[0]["type"] == "position"
        return
    assert (pos.seconds is not None and pos.seconds >= 0) or (pos.bar or 0) >= 1
    assert LengthAdapter.validate_python(1.5) == Length(1.5)


def test_a_position_in_a_long_tempo_map_costs_a_lookup_not_a_scan() -> None:
    """A tempo map of 60,000 bars and a cue at every few bars: each position is a binary
    search (it was a list of every bar built per position, seconds for such a routine)."""
    import time

    tm = TempoMap([Segment(bar, 60.0 + bar % 300, 4) for bar in range(1, 60_001)])
    started = time.process_time()
    for bar in range(1, 60_000, 12):
        tm.position(bar, 2)
    assert time.process_time() - started < 1.0
    assert tm.position(3, 1) == pytest.approx(4 * 60 / 61 + 4 * 60 / 62)
