"""The statistics benchmarks/trigger_latency.py states its flood verdict with: the bootstrap
interval of the pooled p99's difference, and the frames left out for the CPU stalls."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import trigger_latency as bench


def test_two_pairs_of_one_frame_give_the_resampling_distribution_by_hand() -> None:
    # Pairs resampled: (0,0) diff 0 (1/4), (1,1) diff 10 (1/4), mixed diff p99([0,10]) = 9.9
    # (1/2); the 2.5 % and 97.5 % quantiles are its ends, the estimate the mixed value.
    est, lo, hi = bench.bootstrap_p99_difference([[0.0], [0.0]], [[0.0], [10.0]])
    assert est == pytest.approx(9.9)
    assert (lo, hi) == (0.0, 10.0)


def test_a_constant_shift_is_found_exactly_by_every_resample_of_pairs() -> None:
    # Resampled pairs keep each flood run with its alone run: every draw sees the same shift.
    # Frames resampled within runs are drawn apart for alone and flood: the shift with noise.
    alone = [[0.001 * k + 0.0001 * i for i in range(50)] for k in range(4)]
    flood = [[x + 0.0005 for x in run] for run in alone]
    est, lo, hi = bench.bootstrap_p99_difference(alone, flood, resamples=300)
    assert est == pytest.approx(0.0005)
    assert lo == pytest.approx(0.0005) and hi == pytest.approx(0.0005)
    est, lo, hi = bench.bootstrap_p99_difference(alone, flood, unit="frame", resamples=300)
    assert lo < 0.0005 < hi


def test_resampling_runs_keeps_the_run_to_run_spread_that_frames_hide() -> None:
    # One flood run of four is slow throughout: resampled frames within runs still contain it
    # every time (a narrow interval near its level); resampled runs leave it out in about a
    # third of the draws (0.75**4), so the interval reaches down to no difference at all.
    alone = [[0.0] * 100 for _ in range(4)]
    flood = [[0.0] * 100, [0.0] * 100, [0.0] * 100, [1.0] * 100]
    est, lo, hi = bench.bootstrap_p99_difference(alone, flood)
    _, flo, fhi = bench.bootstrap_p99_difference(alone, flood, unit="frame")
    assert est == 1.0
    assert (lo, hi) == (0.0, 1.0)
    assert flo > 0.5 and fhi == 1.0


def test_the_interval_holds_the_estimate_and_the_seed_repeats_it() -> None:
    alone = [[0.0001 * ((7 * i + k) % 13) for i in range(80)] for k in range(5)]
    flood = [[x * (1 + 0.1 * k) for x in run] for k, run in enumerate(alone)]
    first = bench.bootstrap_p99_difference(alone, flood, resamples=500, seed=3)
    assert first == bench.bootstrap_p99_difference(alone, flood, resamples=500, seed=3)
    est, lo, hi = first
    assert lo <= est <= hi and lo < hi


def test_unpaired_or_empty_runs_are_refused() -> None:
    with pytest.raises(ValueError, match="as many flood runs"):
        bench.bootstrap_p99_difference([[0.0]], [[0.0], [1.0]])
    with pytest.raises(ValueError, match="at least one"):
        bench.bootstrap_p99_difference([], [])
    with pytest.raises(ValueError, match="'run' or 'frame'"):
        bench.bootstrap_p99_difference([[0.0]], [[0.0]], unit="pair")


def test_frames_overlapping_a_stall_of_any_cpu_are_left_out() -> None:
    errors = [0.1, 0.2, 0.3, 0.4]
    spans = [(1.0, 1.1), (2.0, 2.2), (3.0, 3.3), (4.0, 3.9)]  # the last one arrived early
    stalls = [(0, 2.1, 2.15), (1, 3.3, 3.5), (1, 3.92, 3.95)]
    # the first stall is inside frame 2's span; the second starts when frame 3 arrived (no
    # overlap); the third falls between frame 4's arrival and its planned time
    assert bench.outside_stalls(errors, spans, stalls) == [0.1, 0.3]
    assert bench.outside_stalls(errors, spans, []) == errors


def test_the_difference_row_says_which_resampling_and_refuses_one_pair() -> None:
    alone = [[0.0] * 10, [0.0] * 10]
    flood = [[0.001] * 10, [0.001] * 10]
    line = bench.difference_row("all frames", alone, flood)
    assert "flood - alone +1.00 ms, 95 % CI [+1.00, +1.00] resampling the 2 run pairs" in line
    assert "(n=20/20)" in line
    assert "no interval" in bench.difference_row("x", alone[:1], flood[:1])
