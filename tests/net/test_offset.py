"""The offset estimator and drift fit against synthetic clocks and delays (asymmetric included).

A synthetic relay clock reads ``c + offset + rate * (c - c0)`` at conductor time ``c``; every
exchange gets its own one-way delays. Whatever the delays, the true offset must lie within the
bound the estimator reports, and the true rate within the drift fit's rate bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.net.offset import (
    RESOLUTION,
    DriftFit,
    Exchange,
    OffsetEstimate,
    Timebase,
    estimate_offset,
)

_EPS = 1e-9  # float rounding over clock readings of some thousand seconds


@dataclass(frozen=True)
class SyntheticRelay:
    offset: float
    rate: float
    c0: float = 1000.0

    def clock(self, c: float) -> float:
        return c + self.offset + self.rate * (c - self.c0)

    def true_offset(self, c: float) -> float:
        return self.clock(c) - c

    def exchange(self, t0: float, up: float, work: float, down: float) -> Exchange:
        """Request sent at t0, ``up`` on the way, ``work`` at the relay, ``down`` back."""
        arrive = t0 + up
        leave = arrive + work
        return Exchange(t0, self.clock(arrive), self.clock(leave), leave + down)


delays = st.floats(min_value=0.0, max_value=0.02)
works = st.floats(min_value=0.0, max_value=0.001)
relays = st.builds(
    SyntheticRelay,
    offset=st.floats(min_value=-1e5, max_value=1e5),
    rate=st.floats(min_value=-200e-6, max_value=200e-6),
)


@st.composite
def bursts(draw: st.DrawFn) -> tuple[SyntheticRelay, list[Exchange]]:
    relay = draw(relays)
    legs = draw(st.lists(st.tuples(delays, works, delays, delays), min_size=1, max_size=30))
    t = draw(st.floats(min_value=1000.0, max_value=5000.0))
    out = []
    for up, work, down, gap in legs:
        x = relay.exchange(t, up, work, down)
        out.append(x)
        t = x.t3 + gap
    return relay, out


@given(bursts())
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_the_true_offset_is_always_within_the_reported_bound(
    case: tuple[SyntheticRelay, list[Exchange]],
) -> None:
    relay, exchanges = case
    est = estimate_offset(exchanges)
    assert est.consistent
    assert abs(est.offset - relay.true_offset(est.at)) <= est.bound + _EPS
    assert est.rtt == min(x.rtt for x in exchanges)
    assert est.bound <= max(est.rtt, 0) / 2 + 500e-6 * (est.rtt + 0.7) + 2 * RESOLUTION + _EPS
    assert est.samples == len(exchanges)


@given(relays, st.floats(min_value=0.0, max_value=0.01), st.floats(min_value=0.0, max_value=0.01))
def test_one_exchange_is_the_classic_ntp_formula(
    relay: SyntheticRelay, up: float, down: float
) -> None:
    x = relay.exchange(2000.0, up, 0.0001, down)
    est = estimate_offset([x])
    assert est.offset == pytest.approx(((x.t1 - x.t0) + (x.t2 - x.t3)) / 2, abs=1e-6)
    assert est.rtt == pytest.approx(up + down, abs=1e-7)  # less the rate error over 0.1 ms


def test_a_wholly_asymmetric_path_is_off_by_half_the_round_trip_and_says_so() -> None:
    relay = SyntheticRelay(offset=3.0, rate=0.0)
    # Requests arrive at once; every reply takes 5 ms: the estimate cannot tell, the bound can.
    exchanges = [relay.exchange(1000.0 + i * 0.01, 0.0, 0.0001, 0.005) for i in range(25)]
    est = estimate_offset(exchanges)
    assert est.offset == pytest.approx(3.0 - 0.0025, abs=1e-6)
    assert est.bound == pytest.approx(0.0025, abs=1e-5)  # plus what 500 ppm could drift


def test_a_fast_leg_in_each_direction_narrows_the_bound_below_half_the_lowest_round_trip() -> None:
    relay = SyntheticRelay(offset=-7.0, rate=0.0)
    fast_up = relay.exchange(1000.0, 0.0, 0.0, 0.004)  # rtt 4 ms, upper side exact
    fast_down = relay.exchange(1000.01, 0.004, 0.0, 0.0)  # rtt 4 ms, lower side exact
    est = estimate_offset([fast_up, fast_down])
    assert est.bound < 1e-5
    assert est.offset == pytest.approx(-7.0, abs=1e-5)


def test_invalid_readings_are_skipped_and_none_at_all_is_an_error() -> None:
    good = SyntheticRelay(1.0, 0.0).exchange(1000.0, 0.001, 0.0, 0.001)
    backwards = Exchange(1000.0, 5.0, 4.0, 1000.1)
    assert not backwards.valid
    assert estimate_offset([good, backwards]).samples == 1
    with pytest.raises(ValueError, match="no valid time-sync exchange"):
        estimate_offset([backwards])


def test_a_stepped_clock_makes_the_burst_inconsistent_and_falls_back_on_the_best_exchange() -> None:
    before = SyntheticRelay(1.0, 0.0).exchange(1000.0, 0.001, 0.0, 0.001)
    after = SyntheticRelay(1.5, 0.0).exchange(1000.01, 0.0005, 0.0, 0.0005)
    est = estimate_offset([before, after])
    assert not est.consistent
    assert est.offset == pytest.approx(1.5, abs=1e-9)
    assert est.bound == pytest.approx(0.0005, abs=1e-6)


def _burst_estimate(
    relay: SyntheticRelay, t: float, legs: list[tuple[float, float]]
) -> OffsetEstimate:
    """One burst of exchanges 3 ms apart from conductor time ``t``, legs as (up, down) delays."""
    return estimate_offset(
        [relay.exchange(t + i * 0.003, up, 0.0001, down) for i, (up, down) in enumerate(legs)]
    )


@given(
    relays,
    st.lists(st.lists(st.tuples(delays, delays), min_size=1, max_size=6), min_size=2, max_size=40),
    st.floats(min_value=0.2, max_value=5.0),
)
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_the_drift_fit_bounds_hold_for_offset_and_rate(
    relay: SyntheticRelay, bursts_legs: list[list[tuple[float, float]]], interval: float
) -> None:
    fit = DriftFit(window=16)
    tb = None
    for k, legs in enumerate(bursts_legs):
        tb = fit.add(_burst_estimate(relay, 1000.0 + k * interval, legs))
        assert abs(tb.offset - relay.true_offset(tb.ref)) <= tb.bound + _EPS
        assert abs(tb.rate - relay.rate) <= tb.rate_bound + _EPS
    assert tb is not None
    later = tb.ref + 30.0
    assert abs(tb.to_relay(later) - relay.clock(later)) <= tb.bound_at(later) + _EPS


def test_the_drift_fit_learns_100_ppm_within_a_ppm_in_a_minute_of_noisy_bursts() -> None:
    import random

    rng = random.Random(7)
    relay = SyntheticRelay(offset=42.0, rate=100e-6)
    fit = DriftFit()
    for k in range(60):
        legs = [(50e-6 + rng.expovariate(5000), 50e-6 + rng.expovariate(5000)) for _ in range(8)]
        tb = fit.add(_burst_estimate(relay, 1000.0 + k, legs))
    assert abs(tb.rate - 100e-6) < 1e-6
    assert tb.rate_bound < 5e-6
    assert abs(tb.offset - relay.true_offset(tb.ref)) < 50e-6


def test_a_step_restarts_the_drift_window() -> None:
    fit = DriftFit()
    for k in range(5):
        fit.add(_burst_estimate(SyntheticRelay(1.0, 0.0), 1000.0 + k, [(0.0001, 0.0001)]))
    assert len(fit) == 5
    tb = fit.add(_burst_estimate(SyntheticRelay(2.0, 0.0), 1006.0, [(0.0001, 0.0001)]))
    assert len(fit) == 1
    assert tb.offset == pytest.approx(2.0, abs=1e-6)


def test_estimates_must_come_in_time_order() -> None:
    fit = DriftFit()
    fit.add(OffsetEstimate(1.0, 0.001, 0.002, 1000.0, 1))
    with pytest.raises(ValueError, match="time order"):
        fit.add(OffsetEstimate(1.0, 0.001, 0.002, 999.0, 1))


@given(
    st.floats(min_value=-1e4, max_value=1e4),
    st.floats(min_value=-500e-6, max_value=500e-6),
    st.floats(min_value=0.0, max_value=1e5),
    st.floats(min_value=0.0, max_value=1e5),
)
def test_timebase_maps_both_ways(offset: float, rate: float, ref: float, c: float) -> None:
    tb = Timebase(offset, rate, ref, 0.0, 0.0)
    assert math.isclose(tb.to_conductor(tb.to_relay(c)), c, rel_tol=0, abs_tol=1e-7)


# --- exact values on small cases: what each reading, interval and bound is ------------------


def test_an_exchange_reads_its_interval_round_trip_and_middle() -> None:
    # Sent at 10.000, at the relay from 15.004 to 15.005 (its clock), back at 10.010.
    x = Exchange(10.0, 15.004, 15.005, 10.010)
    assert x.rtt == pytest.approx(0.009, abs=1e-12)  # 10 ms less the relay's own 1 ms
    assert x.low == pytest.approx(4.995, abs=1e-12)  # the reply took no time
    assert x.high == pytest.approx(5.004, abs=1e-12)  # the request took no time
    assert x.at == pytest.approx(10.005, abs=1e-12)


def test_readings_in_order_are_valid_down_to_an_instant_exchange() -> None:
    assert Exchange(1.0, 2.0, 2.0, 1.0).valid  # no time anywhere: still in order
    assert not Exchange(1.0, 2.0, 2.0, 1.0 - 1e-6).valid  # back before it was sent
    assert not Exchange(1.0, 2.0, 2.0 - 1e-6, 1.5).valid  # the relay replied before it heard
    # A relay clock 500 ppm fast counts 1 s of its own work as up to 500 us too long, so the
    # round trip may go that far below zero, not further.
    assert Exchange(0.0, 10.0, 11.0, 1.0 - 400e-6).valid
    assert not Exchange(0.0, 10.0, 11.0, 1.0 - 600e-6).valid
    # Over 1 us of relay work that is 0.5 ns; the readings' own 4 ns resolution comes on top.
    assert Exchange(0.0, 0.0, 1e-6, 1e-6 - 3e-9).valid
    assert not Exchange(0.0, 0.0, 1e-6, 1e-6 - 6e-9).valid


def test_the_bound_is_the_intersection_of_intervals_widened_by_drift_to_the_reference() -> None:
    best = Exchange(100.0, 105.001, 105.001, 100.004)  # [4.997, 5.001], rtt 4 ms, at 100.002
    # Earlier and slower, but its reply was quick: its low side (4.999) is the tighter one.
    quick_reply = Exchange(99.0, 104.0045, 104.0045, 99.0055)  # [4.999, 5.0045], at 99.00275
    rate = 1e-3
    own = rate * 0.004 + 2 * RESOLUTION  # drift over its own round trip
    carried = rate * ((100.002 - 99.00275) + 0.0055) + 2 * RESOLUTION  # ...and to the reference
    low, high = 4.999 - carried, 5.001 + own
    for exchanges in ([quick_reply, best], [best, quick_reply]):
        est = estimate_offset(exchanges, max_rate=rate)
        assert est.consistent and est.samples == 2
        assert est.at == pytest.approx(100.002, abs=1e-12)  # the lowest round trip's middle
        assert est.rtt == pytest.approx(0.004, abs=1e-12)
        assert est.offset == pytest.approx((low + high) / 2, abs=1e-12)
        assert est.bound == pytest.approx((high - low) / 2, abs=1e-12)
        assert (est.low, est.high) == (pytest.approx(low, abs=1e-12),
                                       pytest.approx(high, abs=1e-12))
    tight = estimate_offset([quick_reply, best], max_rate=0.0)
    assert tight.bound == pytest.approx((5.001 - 4.999) / 2 + 2 * RESOLUTION, abs=1e-12)


def test_the_default_drift_allowance_is_500_ppm() -> None:
    best = Exchange(100.0, 105.001, 105.001, 100.004)
    quick_reply = Exchange(99.0, 104.0045, 104.0045, 99.0055)
    assert estimate_offset([quick_reply, best]) == estimate_offset([quick_reply, best],
                                                                   max_rate=500e-6)
    assert estimate_offset([quick_reply, best]) != estimate_offset([quick_reply, best],
                                                                   max_rate=400e-6)


def test_a_contradicting_burst_falls_back_on_the_best_exchange_with_its_drift() -> None:
    before = Exchange(1000.0, 1001.001, 1001.001, 1000.002)  # offset 1.0, rtt 2 ms
    after = Exchange(1000.01, 1011.0105, 1011.0105, 1000.011)  # offset 11.0, rtt 1 ms
    est = estimate_offset([before, after], max_rate=1e-3)
    assert not est.consistent and est.samples == 2
    assert est.offset == pytest.approx(11.0, abs=1e-9)
    assert est.at == pytest.approx(1000.0105, abs=1e-12)
    # half the round trip, what 1000 ppm adds over it, and the readings' resolution
    assert est.bound == pytest.approx(0.0005 + 1e-3 * 0.001 + 2 * RESOLUTION, abs=1e-12)


def test_a_fallback_on_a_round_trip_below_zero_counts_it_as_zero() -> None:
    before = Exchange(1000.0, 1001.001, 1001.001, 1000.002)
    # The relay worked 1 s by its clock while 0.9998 s passed here: a round trip of -200 us.
    fast = Exchange(1000.01, 1010.0, 1011.0, 1001.0098)
    assert fast.valid and fast.rtt < 0
    est = estimate_offset([before, fast], max_rate=1e-3)
    assert not est.consistent and est.rtt == pytest.approx(-0.0002, abs=1e-9)
    assert est.bound == pytest.approx(1e-3 * 0.9998 + 2 * RESOLUTION, abs=1e-12)


def test_a_timebase_maps_and_bounds_at_a_given_time() -> None:
    tb = Timebase(2.0, 1e-4, 100.0, 0.001, 2e-5)
    assert tb.to_relay(110.0) == pytest.approx(112.001, abs=1e-12)  # 2 s ahead, 1 ms gained
    assert tb.to_conductor(112.001) == pytest.approx(110.0, abs=1e-12)
    assert tb.to_relay(90.0) == pytest.approx(91.999, abs=1e-12)
    assert tb.bound_at(90.0) == pytest.approx(0.0012, abs=1e-15)  # 10 s away, either side
    assert tb.bound_at(110.0) == pytest.approx(0.0012, abs=1e-15)
    assert Timebase(1.5) == Timebase(1.5, 0.0, 0.0, math.inf, 500e-6)  # nothing known yet


def test_an_estimate_spans_its_bound_either_side() -> None:
    est = OffsetEstimate(2.0, 0.25, 0.5, 10.0, 3)
    assert (est.low, est.high, est.consistent) == (1.75, 2.25, True)


def test_the_drift_window_keeps_the_newest_120_estimates_by_default() -> None:
    fit = DriftFit()
    for k in range(130):
        fit.add(OffsetEstimate(1.0, 0.001, 0.002, 1000.0 + k, 1))
    assert len(fit) == 120
    small = DriftFit(window=2)
    for k in range(3):
        small.add(OffsetEstimate(1.0, 0.001, 0.002, 1000.0 + k, 1))
    assert len(small) == 2
    with pytest.raises(ValueError, match=r"^the drift window needs at least two estimates$"):
        DriftFit(window=1)


def test_an_estimate_at_the_same_time_as_the_last_is_refused() -> None:
    fit = DriftFit()
    fit.add(OffsetEstimate(1.0, 0.001, 0.002, 1000.0, 1))
    with pytest.raises(ValueError, match=r"^offset estimates must come in time order$"):
        fit.add(OffsetEstimate(1.0, 0.001, 0.002, 1000.0, 1))


def test_one_estimate_gives_its_own_offset_and_the_whole_rate_allowance() -> None:
    est = OffsetEstimate(3.0, 0.002, 0.004, 50.0, 5)
    assert DriftFit().add(est) == Timebase(3.0, 0.0, 50.0, 0.002, 500e-6)
    assert DriftFit(max_rate=1e-4).add(est) == Timebase(3.0, 0.0, 50.0, 0.002, 1e-4)


def test_two_estimates_bound_the_rate_by_their_intervals_and_the_allowance() -> None:
    # 1.000 +- 2 ms at t=0, then 1.0015 +- 1 ms at t=10: rates from -150 to +450 ppm fit both.
    first = OffsetEstimate(1.0, 0.002, 0.004, 0.0, 5)
    second = OffsetEstimate(1.0015, 0.001, 0.002, 10.0, 5)
    fit = DriftFit(max_rate=2e-4)  # ...but no more than 200 ppm
    fit.add(first)
    tb = fit.add(second)
    assert tb.rate == pytest.approx(1.5e-4, abs=1e-12)  # the line through both
    assert tb.rate_bound == pytest.approx(3e-4, abs=1e-12)  # down to -150 ppm
    assert tb.ref == 10.0 and tb.offset == pytest.approx(1.0015, abs=1e-12)
    assert tb.bound == pytest.approx(0.001, abs=1e-12)
    wide = DriftFit()
    wide.add(first)
    assert wide.add(second).rate_bound == pytest.approx(3e-4, abs=1e-12)  # -150..450 ppm


def test_no_valid_exchange_says_why_it_may_be() -> None:
    with pytest.raises(ValueError) as info:
        estimate_offset([])
    assert str(info.value) == ("no valid time-sync exchange (no reply, or clock readings out "
                               "of order)")


def test_intervals_that_just_touch_agree_on_the_point_they_share() -> None:
    # Two instant exchanges whose intervals, widened by the readings' 2 ns, meet at 0 exactly.
    below = Exchange(2e-9, 0.0, 0.0, 2e-9)  # offset -2 ns
    above = Exchange(0.0, 2e-9, 2e-9, 0.0)  # offset +2 ns
    est = estimate_offset([below, above], max_rate=0.0)
    assert est.consistent is True
    assert (est.offset, est.bound) == (0.0, 0.0)


def test_a_contradiction_is_reported_as_false() -> None:
    before = Exchange(1000.0, 1001.001, 1001.001, 1000.002)
    after = Exchange(1000.01, 1011.0105, 1011.0105, 1000.011)
    assert estimate_offset([before, after]).consistent is False


def test_after_a_restart_the_window_grows_again_with_the_whole_rate_allowance() -> None:
    fit = DriftFit(max_rate=300e-6)
    fit.add(OffsetEstimate(1.0, 0.0001, 0.0002, 1000.0, 1))
    fit.add(OffsetEstimate(1.0, 0.0001, 0.0002, 1001.0, 1))
    restarted = fit.add(OffsetEstimate(2.0, 0.0001, 0.0002, 1002.0, 1))  # a step: start again
    assert len(fit) == 1 and restarted.rate_bound == 300e-6 and restarted.rate == 0.0
    tb = fit.add(OffsetEstimate(2.0, 0.0001, 0.0002, 1003.0, 1))
    assert len(fit) == 2 and tb.rate_bound < 300e-6


def test_estimates_that_pin_the_rate_exactly_are_kept() -> None:
    # Bounds of 0 (intervals that touched): one rate and one offset fit both, exactly.
    fit = DriftFit()
    fit.add(OffsetEstimate(0.0, 0.0, 0.0, 0.0, 1))
    tb = fit.add(OffsetEstimate(1e-4, 0.0, 0.0, 1.0, 1))
    assert len(fit) == 2
    assert (tb.rate, tb.rate_bound, tb.offset, tb.bound) == (1e-4, 0.0, 1e-4, 0.0)


def test_estimates_under_a_second_apart_narrow_the_rate_too() -> None:
    fit = DriftFit()
    fit.add(OffsetEstimate(1.0, 1e-5, 2e-5, 0.0, 1))
    tb = fit.add(OffsetEstimate(1.0, 1e-5, 2e-5, 0.5, 1))
    assert tb.rate_bound == pytest.approx(4e-5, abs=1e-12)  # +-(1e-5 + 1e-5) / 0.5 s


def test_loose_estimates_close_in_time_still_give_their_slope() -> None:
    # Bounds of 1 s half a second apart: the rate is only bounded by the allowance, and the
    # fitted slope is the line through both.
    fit = DriftFit()
    fit.add(OffsetEstimate(1.0, 1.0, 2.0, 0.0, 1))
    tb = fit.add(OffsetEstimate(1.0001, 1.0, 2.0, 0.5, 1))
    assert tb.rate == pytest.approx(2e-4, abs=1e-12)
    assert tb.offset == pytest.approx(1.0001, abs=1e-12)


def test_the_drift_fit_weighs_each_estimate_by_one_over_its_bound_squared() -> None:
    import numpy as np

    points = [OffsetEstimate(1.000, 0.002, 0.004, 0.0, 5),
              OffsetEstimate(1.003, 0.002, 0.004, 10.0, 5),
              OffsetEstimate(1.002, 0.0005, 0.001, 20.0, 5)]  # the newest is the tightest
    fit = DriftFit()
    for p in points:
        tb = fit.add(p)
    x = np.array([p.at - 20.0 for p in points])
    y = np.array([p.offset for p in points])
    # numpy weighs residuals: w = 1 / sigma is least squares with weights 1 / sigma**2
    slope, intercept = np.polyfit(x, y, 1, w=[1 / p.bound for p in points])
    assert tb.rate == pytest.approx(slope, abs=1e-12)
    assert tb.offset == pytest.approx(intercept, abs=1e-12)
    plain_slope, _ = np.polyfit(x, y, 1)
    assert abs(tb.rate - plain_slope) > 3e-5  # unweighted it would be 100 ppm, not 63
