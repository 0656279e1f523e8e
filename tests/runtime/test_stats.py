"""Send statistics in fixed memory: the histogram's quantiles against exact percentiles."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from xgo_show.runtime.stats import ErrorHistogram, error_stats

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
