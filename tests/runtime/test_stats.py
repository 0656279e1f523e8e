"""Send statistics in fixed memory: the histogram's quantiles against exact percentiles."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from xgo_show.runtime.events import Event, FrameSent
from xgo_show.runtime.stats import (
    P99_TARGET_MS,
    P999_TARGET_MS,
    ErrorHistogram,
    ErrorStats,
    SendStats,
    error_stats,
    percentile,
)

# Errors in seconds: mostly near zero (1 us bins), some far out (coarser bins).
near = st.floats(-0.001, 0.005, allow_nan=False)
far = st.floats(-1.0, 10.0, allow_nan=False)


@given(st.lists(near, min_size=1, max_size=300))
def test_quantiles_near_zero_are_within_a_microsecond_of_exact(errors: list[float]) -> None:
    hist = ErrorHistogram()
    for e in errors:
        hist.add(e)
    exact = error_stats(errors)
    got = hist.stats()
    assert got.count == exact.count
    assert got.max == pytest.approx(exact.max)
    # The histogram answers with the bin's middle: off by at most one bin plus the
    # interpolation the exact percentile does between two neighbours.
    ordered = sorted(e * 1000 for e in errors)
    for q, value in ((0.5, got.p50), (0.99, got.p99), (0.999, got.p999)):
        pos = (len(ordered) - 1) * q
        lo, hi = ordered[math.floor(pos)], ordered[math.ceil(pos)]
        assert lo - 0.0011 <= value <= hi + 0.0011, (q, value, lo, hi)


@given(st.lists(far, min_size=1, max_size=200))
def test_far_errors_keep_exact_extremes_and_ordered_quantiles(errors: list[float]) -> None:
    hist = ErrorHistogram()
    for e in errors:
        hist.add(e)
    s = hist.stats()
    assert s.max == pytest.approx(max(errors) * 1000)
    assert min(errors) * 1000 - 1e-9 <= s.p50 <= s.p95 <= s.p99 <= s.p999 <= s.max + 1e-9


def test_an_empty_histogram_says_no_frames_sent() -> None:
    assert ErrorHistogram().stats().format() == "no frames sent"


def _sent(kind: str, t: float = 1.0, planned: float | None = None, data: bytes = b"\x00" * 9,
          note: str = "") -> FrameSent:
    return FrameSent(t, "rex", kind, None, planned, data, note, planned, t)


def test_send_stats_count_frames_reads_and_bytes_by_kind() -> None:
    stats = SendStats()
    stats.on_event(_sent("frame", t=1.0005, planned=1.0, data=bytes(11)))
    stats.on_event(_sent("frame", t=2.0, planned=None, data=bytes(9)))  # counted, not timed
    stats.on_event(_sent("read", data=bytes(9)))
    stats.on_event(_sent("read", data=bytes(0)))
    stats.on_event(_sent("reach", data=bytes(12)))
    stats.on_event(_sent("stop", data=bytes(10)))
    stats.on_event(Event(1.0))  # not a frame: ignored
    assert (stats.frames, stats.reads, stats.bytes) == (2, 2, 51)
    assert stats.errors.count == 1
    assert stats.errors.max == pytest.approx(500.0)  # microseconds late


def test_send_stats_count_rests_by_their_first_frame_and_keep_32_labels() -> None:
    stats = SendStats()
    for _ in range(3):  # three pauses, each the same two-frame rest sequence
        stats.on_event(_sent("rest", note="vx=0"))
        stats.on_event(_sent("rest", note="periodic off"))
    assert stats.rests == 3 and stats.frames == 0
    assert list(stats.rest_labels) == ["vx=0", "periodic off"]
    for i in range(40):
        stats.on_event(_sent("rest", note=f"other {i}"))
    assert len(stats.rest_labels) == 32 and stats.rests == 3
    assert list(stats.rest_labels)[:2] == ["vx=0", "periodic off"]


def test_the_histogram_bins_each_range_to_its_width() -> None:
    # 1 us bins from -1 ms to 5 ms, 10 us to 50 ms, 1 ms to 5 s: two errors in one bin answer
    # the median with the bin's middle (within the exact min and max).
    for lo_us, width in ((-1000, 1), (-1, 1), (4999, 1), (5000, 10), (49_990, 10),
                         (50_000, 1000), (4_999_000, 1000)):  # fmt: skip
        hist = ErrorHistogram()
        hist.add((lo_us + 0.1 * width) / 1e6)
        hist.add((lo_us + 0.9 * width) / 1e6)
        assert hist.quantile_ms(0.5) == pytest.approx((lo_us + 0.5 * width) / 1000), lo_us
    wide = ErrorHistogram()
    for us in (100.2, 100.7, 7000.0, 7003.0, 7009.9, 700_100.0, 700_900.0):
        wide.add(us / 1e6)
    assert wide.quantile_ms(0.0) == pytest.approx(0.1002)  # the exact minimum
    assert wide.quantile_ms(1 / 6) == pytest.approx(0.1005)  # 1 us bin 100..101 us
    assert wide.quantile_ms(3 / 6) == pytest.approx(7.005)  # 10 us bin 7000..7010 us
    assert wide.quantile_ms(5 / 6) == pytest.approx(700.5)  # 1 ms bin 700..701 ms
    assert wide.quantile_ms(1.0) == pytest.approx(700.9)  # the exact maximum


def test_errors_outside_the_bins_keep_their_rank() -> None:
    hist = ErrorHistogram()
    for seconds in (-0.5, -0.002, 0.0000005, 7.0, 9.0):  # two early, one binned, two late
        hist.add(seconds)
    assert hist.quantile_ms(0.0) == pytest.approx(-500.0)
    assert hist.quantile_ms(0.25) == pytest.approx(-500.0)  # below the bins: the minimum
    assert hist.quantile_ms(0.5) == pytest.approx(0.0005)  # the binned one (clamped to 0.5 us)
    assert hist.quantile_ms(0.75) == pytest.approx(9000.0)  # above the bins: the maximum
    assert hist.stats().max == pytest.approx(9000.0)
    assert hist.count == 5


def test_error_stats_format_and_targets() -> None:
    ok = ErrorStats(10, 0.01, 0.2, 0.5, 3.0, 2.0)
    assert ok.format() == ("p50 0.010 ms, p95 0.200 ms, p99 0.500 ms, p99.9 2.000 ms, "
                           "max 3.000 ms")
    assert ok.over_target() == ""  # at the targets is within them
    assert ErrorStats(10, 0.0, 0.0, 0.5001, 1.0, 1.0).over_target() == (
        "ABOVE TARGET: p99 0.500 ms > 0.5 ms")
    assert ErrorStats(10, 0.0, 0.0, 0.7, 3.0, 2.5).over_target() == (
        "ABOVE TARGET: p99 0.700 ms > 0.5 ms, p99.9 2.500 ms > 2 ms")
    assert ErrorStats(10, 0.0, 0.0, 0.1, 3.0, 2.5).over_target() == (
        "ABOVE TARGET: p99.9 2.500 ms > 2 ms")
    assert (P99_TARGET_MS, P999_TARGET_MS) == (0.5, 2.0)  # issue 12's targets
    empty = ErrorHistogram().stats()
    assert empty.count == 0 and all(
        math.isnan(v) for v in (empty.p50, empty.p95, empty.p99, empty.max, empty.p999))


def test_percentile_interpolates_between_neighbours() -> None:
    assert math.isnan(percentile([], 0.5))
    assert percentile([4.0], 0.99) == 4.0
    assert percentile([1.0, 2.0, 3.0, 4.0, 5.0], 0.0) == 1.0
    assert percentile([5.0, 1.0, 3.0, 2.0, 4.0], 1.0) == 5.0
    assert percentile([1.0, 2.0, 3.0, 4.0, 5.0], 0.3) == pytest.approx(2.2)
    stats = error_stats([0.001, 0.003])
    assert (stats.count, stats.p50, stats.max) == (2, pytest.approx(2.0), pytest.approx(3.0))
    assert stats.p95 == pytest.approx(2.9) and stats.p99 == pytest.approx(2.98)
    assert stats.p999 == pytest.approx(2.998)
    assert math.isnan(error_stats([]).max)


def test_the_edges_of_the_bins() -> None:
    # Exactly -1 ms is the first bin's start, not below the bins.
    hist = ErrorHistogram()
    for seconds in (-0.001, -0.001, -0.0009991):
        hist.add(seconds)
    assert hist.quantile_ms(0.5) == pytest.approx(-0.9995)  # the middle of -1000..-999 us
    # Exactly 5 s late is past the last bin: the maximum answers for it.
    late = ErrorHistogram()
    late.add(5.0)
    late.add(0.0)
    assert late.quantile_ms(1.0) == pytest.approx(5000.0)
    assert late.stats().max == pytest.approx(5000.0)


def test_p999_is_not_the_maximum_of_a_thousand() -> None:
    hist = ErrorHistogram()
    for _ in range(1000):
        hist.add(0.001)
    hist.add(0.1)  # one outlier
    s = hist.stats()
    assert s.p999 == pytest.approx(1.0005) and s.max == pytest.approx(100.0)
