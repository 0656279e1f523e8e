"""The slewing show clock: continuous, monotonic, bounded rate changes, converges exactly."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xgo_show.net.offset import Timebase
from xgo_show.net.slew import HOLD_AFTER, SlewingClock
from xgo_show.net.testhooks import SkewedClock
from xgo_show.runtime.clock import FakeClock, MonotonicClock

SLEW = 500e-6


def test_before_any_estimate_it_reads_the_base_clock() -> None:
    base = FakeClock(50.0)
    clock = SlewingClock(base)
    assert clock.now() == 50.0
    assert clock.timebase is None


def test_the_first_estimate_is_taken_at_once() -> None:
    base = FakeClock(50.0)
    clock = SlewingClock(base)
    tb = Timebase(offset=10.0, rate=100e-6, ref=40.0, bound=1e-4)
    assert clock.follow(tb) == 0.0
    assert clock.now() == pytest.approx(tb.to_conductor(50.0), abs=1e-12)
    base.advance(100.0)
    assert clock.now() == pytest.approx(tb.to_conductor(150.0), abs=1e-12)
    assert clock.timebase == tb


def test_a_later_estimate_is_slewed_to_without_a_jump_at_the_bounded_rate() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base, max_slew=SLEW)
    clock.follow(Timebase(offset=0.0, ref=100.0))
    # The conductor now thinks the relay is 1 ms further ahead: the show clock must slow down.
    new = Timebase(offset=0.001, ref=100.0)
    before = clock.now()
    assert clock.follow(new) == pytest.approx(-0.001, abs=1e-12)
    assert clock.now() == before
    base.advance(1.0)
    assert clock.now() - before == pytest.approx(1.0 - SLEW, abs=1e-12)
    assert clock.error() == pytest.approx(-0.0005, abs=1e-12)
    base.advance(1.0)  # 2 s at 500 ppm: caught up exactly
    assert clock.error() == pytest.approx(0.0, abs=1e-12)
    base.advance(5.0)
    assert clock.now() == pytest.approx(new.to_conductor(base.now()), abs=1e-12)


timebases = st.builds(
    Timebase,
    offset=st.floats(min_value=-0.005, max_value=0.005),
    rate=st.floats(min_value=-150e-6, max_value=150e-6),
    ref=st.just(100.0),
)


@given(
    st.lists(st.tuples(timebases, st.floats(min_value=0.0, max_value=1.0)), min_size=1, max_size=8)
)
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_frames_are_never_skipped_or_bunched_whatever_the_estimates(
    updates: list[tuple[Timebase, float]],
) -> None:
    """Frames every 20 ms of show time: their base-time spacing stays within the slew bound."""
    base = FakeClock(100.0)
    clock = SlewingClock(base, max_slew=SLEW)
    clock.follow(Timebase(0.0, 0.0, 100.0))
    frame = 0.02
    t = clock.now()
    last_base = base.now()
    for tb, wait in updates:
        clock.follow(tb)
        end = base.now() + wait
        while base.now() < end:
            t += frame
            due = clock.to_base(t)
            gap = due - last_base
            # One frame's base-time spacing: the rate error (150 ppm at most here) and the slew,
            # never more (to first order: 1 / (1 - 650e-6) is 1 + 650.4e-6).
            assert abs(gap / frame - 1) <= 150e-6 + SLEW + 1e-6
            assert clock.sleep_until(t)
            assert clock.now() == pytest.approx(t, abs=1e-9)
            last_base = base.now()


def test_a_long_wait_is_cut_into_hops_so_a_correction_meanwhile_moves_the_wake_up() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base)
    clock.follow(Timebase(0.0, 0.0, 100.0))
    assert clock.sleep_until(103.0)
    assert len(base.waits) > 10
    assert base.waits[-1] == pytest.approx(103.0)
    assert all(b - a <= 0.25 + 1e-9 for a, b in zip(base.waits, base.waits[1:], strict=False))


def test_an_interrupt_cuts_the_wait_short() -> None:
    clock = SlewingClock(FakeClock(100.0))
    stop = threading.Event()
    stop.set()
    assert not clock.sleep_until(200.0, stop)
    assert clock.now() == 100.0


def test_reset_keeps_time_running_and_lets_the_next_estimate_set_the_clock_at_once() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base)
    clock.follow(Timebase(5.0, 0.0, 0.0))
    assert clock.now() == pytest.approx(95.0)
    clock.reset()
    assert clock.timebase is None
    base.advance(1.0)
    assert clock.now() == pytest.approx(96.0)
    clock.follow(Timebase(-2.0, 0.0, 0.0))
    assert clock.now() == pytest.approx(103.0)


def test_max_slew_must_be_a_small_fraction() -> None:
    with pytest.raises(ValueError, match="max_slew"):
        SlewingClock(FakeClock(), max_slew=0.5)


def test_on_a_skewed_real_clock_waits_land_on_the_conductors_time() -> None:
    """A relay clock 12.5 s ahead and 100 ppm fast, mapped back: a 30 ms wait lasts 30 ms."""
    real = MonotonicClock()
    skewed = SkewedClock(real, offset=12.5, ppm=100.0)
    clock = SlewingClock(skewed)
    start = real.now()
    clock.follow(Timebase(12.5, 100e-6, start))
    assert skewed.to_base(clock.to_base(start + 5.0)) == pytest.approx(start + 5.0, abs=1e-6)
    deadline = clock.now() + 0.03
    # The wait lands on this machine's clock at the deadline (to float rounding)...
    assert skewed.to_base(clock.to_base(deadline)) == pytest.approx(deadline, abs=1e-6)
    assert clock.sleep_until(deadline)
    # ...and never before it (how late depends on the machine's load, not on the mapping).
    assert real.now() >= deadline - 1e-6


def test_a_skewed_clock_is_offset_and_fast_by_what_it_was_told() -> None:
    base = FakeClock(1000.0)
    skewed = SkewedClock(base, offset=-3.0, ppm=250.0)
    assert skewed.now() == pytest.approx(997.0)
    base.advance(1000.0)
    assert skewed.now() == pytest.approx(1997.0 + 0.25)
    assert skewed.sleep_until(3000.0)
    assert skewed.now() == pytest.approx(3000.0)


# --- the rate limits and the mapping, exactly ------------------------------------------------


def test_by_default_a_1_ms_correction_takes_2_s_at_500_ppm() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base)
    assert clock.max_slew == 500e-6
    clock.follow(Timebase(0.0, 0.0, 100.0))
    ahead = Timebase(-0.001, 0.0, 100.0)  # the conductor is 1 ms ahead of what we read
    assert clock.follow(ahead) == pytest.approx(0.001, abs=1e-12)
    assert clock.error() == pytest.approx(0.001, abs=1e-12)  # behind: positive
    start = clock.now()
    base.advance(1.0)
    assert clock.now() - start == pytest.approx(1.0005, abs=1e-12)  # running 500 ppm fast
    base.advance(0.999)
    assert clock.error() == pytest.approx(0.0000005, abs=1e-12)  # not yet
    base.advance(0.001)
    assert clock.error() == pytest.approx(0.0, abs=1e-12)
    base.advance(3.0)  # and then it follows the estimate, at its rate
    assert clock.now() == pytest.approx(ahead.to_conductor(base.now()), abs=1e-12)
    assert clock.error() == pytest.approx(0.0, abs=1e-12)


def test_a_slew_runs_at_the_new_estimates_rate_plus_the_slew() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base, max_slew=SLEW)
    clock.follow(Timebase(0.0, 0.0, 100.0))
    fast = Timebase(-0.002, 100e-6, 100.0)  # relay clock 100 ppm fast; conductor 2 ms ahead
    start = clock.now()
    base.advance(0.5)
    assert clock.now() - start == pytest.approx(0.5, abs=1e-12)  # the old mapping until then
    start = clock.now()
    clock.follow(fast)
    base.advance(1.0)
    assert clock.now() - start == pytest.approx(1.0 / (1 + 100e-6) + SLEW, abs=1e-12)


@pytest.mark.parametrize("slew", [0.0, -1e-4, 0.1, 0.5])
def test_max_slew_outside_0_to_10_percent_is_refused(slew: float) -> None:
    with pytest.raises(ValueError, match=r"^max_slew must be a small positive fraction "
                       r"\(e\.g\. 500e-6\)$"):
        SlewingClock(FakeClock(), max_slew=slew)


def test_max_slew_just_under_10_percent_is_taken() -> None:
    assert SlewingClock(FakeClock(), max_slew=0.0999).max_slew == 0.0999


def test_the_timebase_is_the_one_followed_until_a_reset() -> None:
    clock = SlewingClock(FakeClock(100.0))
    first, second = Timebase(1.0, 0.0, 0.0), Timebase(1.001, 0.0, 0.0)
    clock.follow(first)
    assert clock.timebase == first
    clock.follow(second)
    assert clock.timebase == second  # while still slewing to it
    clock.reset()
    assert clock.timebase is None


def test_to_base_inverts_now_while_slewing_and_after() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base, max_slew=SLEW)
    clock.follow(Timebase(0.0, 0.0, 100.0))
    clock.follow(Timebase(0.001, 0.0, 100.0))  # 1 ms behind: 2 s of slewing
    now = clock.now()
    assert clock.to_base(now) == pytest.approx(100.0, abs=1e-12)
    assert clock.to_base(now + 1.0) == pytest.approx(100.0 + 1.0 / (1 - SLEW), abs=1e-9)
    # Past the slew's end the estimate's own mapping holds: 1 ms behind the base. The slew
    # ends when this clock reads now + 2 s less 1 ms: 2 s on is already past it.
    assert clock.to_base(now + 2.0) == pytest.approx(102.001, abs=1e-9)
    assert clock.to_base(now + 3.0) == pytest.approx(103.001, abs=1e-9)


def test_to_base_of_a_time_before_the_first_estimate_uses_its_mapping() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base)
    tb = Timebase(5.0, 1e-4, 50.0)
    clock.follow(tb)
    earlier = clock.now() - 10.0
    assert clock.to_base(earlier) == pytest.approx(tb.to_relay(earlier), abs=1e-12)


def test_after_a_reset_the_clock_runs_at_the_base_rate_with_nothing_to_correct() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base)
    clock.follow(Timebase(5.0, 200e-6, 0.0))
    clock.reset()
    now = clock.now()
    assert clock.error() == pytest.approx(0.0, abs=1e-12)
    assert clock.to_base(now + 2.0) == pytest.approx(102.0, abs=1e-9)
    base.advance(2.0)
    assert clock.now() == pytest.approx(now + 2.0, abs=1e-12)


def test_a_long_wait_hops_a_quarter_second_at_a_time_and_ends_in_one_short_wait() -> None:
    base = FakeClock(100.0)
    clock = SlewingClock(base)
    clock.follow(Timebase(0.0, 0.0, 0.0))
    assert clock.sleep_until(101.0)
    # 250 ms hops while more than 50 ms is left; one hop to 25 ms before; then the deadline.
    assert base.waits == pytest.approx([100.25, 100.5, 100.75, 100.975, 101.0], abs=1e-9)
    base.waits.clear()
    assert clock.sleep_until(101.05)  # 50 ms left: one wait
    assert base.waits == [pytest.approx(101.05, abs=1e-12)]


def test_a_short_wait_can_be_interrupted_too() -> None:
    clock = SlewingClock(FakeClock(100.0))
    stop = threading.Event()
    stop.set()
    assert not clock.sleep_until(100.01, stop)


class _CorrectedDuringAWait(FakeClock):
    """A base clock on which a new estimate arrives during the third hop of a wait."""

    def __init__(self) -> None:
        super().__init__(100.0)
        self.clock: SlewingClock | None = None

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        if len(self.waits) == 2 and self.clock is not None:
            self.clock.follow(Timebase(-0.0004, 0.0, 0.0))  # the conductor is 400 us ahead
        return super().sleep_until(deadline, interrupt)


def test_a_correction_during_a_long_wait_moves_its_wake_up() -> None:
    base = _CorrectedDuringAWait()
    clock = SlewingClock(base)
    base.clock = clock
    clock.follow(Timebase(0.0, 0.0, 0.0))
    assert clock.sleep_until(102.0)
    assert clock.now() == pytest.approx(102.0, abs=1e-9)  # on the show clock as it now runs
    assert base.now() < 102.0 - 0.0003  # the base clock woke earlier, as the show clock ran fast


def test_a_wait_of_exactly_50_ms_is_one_wait() -> None:
    base = FakeClock(0.0)  # 0.05 - 0.0 is 0.05 exactly in floats
    clock = SlewingClock(base)
    clock.follow(Timebase(0.0, 0.0, 0.0))
    assert clock.sleep_until(0.05)
    assert base.waits == [0.05]


# ---------------------------------------------------------------------------- hold_off


class Still(FakeClock):
    """A fake base clock whose waits return at once without moving time: a writer's wait is
    then registered and still pending, as it is while a real writer sleeps."""

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        return True


@pytest.fixture
def held(monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Still, SlewingClock, list[float]]]:
    """A slewing clock over :class:`Still`, and the sleeps ``hold_off`` takes (each one moves
    the fake time on by its length)."""
    from xgo_show.net import slew

    base = Still(100.0)
    sleeps: list[float] = []

    def sleep(seconds: float) -> None:
        sleeps.append(round(seconds, 9))
        base.advance(seconds)

    monkeypatch.setattr(slew.time, "sleep", sleep)
    yield base, SlewingClock(base), sleeps
    while _WRITERS:
        _WRITERS.pop().set()


_WRITERS: list[threading.Event] = []


def _waits_for(clock: SlewingClock, *deadlines: float) -> None:
    """Each deadline waited for by a thread of its own (as each robot's writer does), which
    stays alive until the test ends (a thread's id is reused once it has ended)."""
    for deadline in deadlines:
        registered, end = threading.Event(), threading.Event()
        _WRITERS.append(end)

        def writer(deadline: float = deadline, registered: threading.Event = registered,
                   end: threading.Event = end) -> None:
            clock.sleep_until(deadline)
            registered.set()
            end.wait(10)

        threading.Thread(target=writer, daemon=True).start()
        assert registered.wait(10)


def test_hold_off_returns_at_once_when_no_writer_waits(held) -> None:  # type: ignore[no-untyped-def]
    base, clock, sleeps = held
    clock.hold_off()
    assert sleeps == [] and base.now() == 100.0


@pytest.mark.parametrize(
    ("due", "slept"),
    [
        (0.0015, [0.002]),  # 1.5 ms ahead: until 0.5 ms past it
        (0.00199, [0.00249]),  # just inside the 2 ms before
        (0.002, []),  # 2 ms ahead: far enough
        (0.003, []),
        (-0.0003, [0.0002]),  # passed 0.3 ms ago: the writer may still be writing
        (-0.0005, []),  # 0.5 ms ago: done
        (-0.010, []),
    ],
)
def test_hold_off_waits_from_2_ms_before_a_writers_deadline_to_half_a_ms_after(
    held, due: float, slept: list[float]
) -> None:  # type: ignore[no-untyped-def]
    _, clock, sleeps = held
    _waits_for(clock, 100.0 + due)
    clock.hold_off()
    assert sleeps == pytest.approx(slept, abs=1e-9)


def test_hold_off_waits_for_every_writer_due_meanwhile_but_5_ms_at_most(held) -> None:  # type: ignore[no-untyped-def]
    base, clock, sleeps = held
    _waits_for(clock, 100.0015, 100.0034)  # the second is due 1.4 ms after the first hold
    clock.hold_off()
    assert sleeps == pytest.approx([0.002, 0.0019], abs=1e-9)
    assert base.now() == pytest.approx(100.0039, abs=1e-9)
    _waits_for(clock, 100.0054, 100.0073, 100.0092)  # a chain: cut at 5 ms
    clock.hold_off()
    assert base.now() == pytest.approx(100.0089, abs=1e-9)


def test_hold_off_ends_after_5_ms_of_sleep_on_a_base_clock_that_does_not_move(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xgo_show.net import slew

    base = Still(100.0)
    clock = SlewingClock(base)
    sleeps: list[float] = []
    monkeypatch.setattr(slew.time, "sleep", lambda seconds: sleeps.append(round(seconds, 9)))
    _waits_for(clock, 100.0015)  # due, and still due whatever is slept: the base stands still
    done = threading.Thread(target=clock.hold_off, daemon=True)
    done.start()
    done.join(5.0)  # a hold-off bounded by the base clock's reading never ends here
    assert not done.is_alive()
    assert sleeps == pytest.approx([0.002, 0.002, 0.001], abs=1e-9)
    while _WRITERS:
        _WRITERS.pop().set()


def test_a_writers_next_wait_replaces_its_last_and_a_reset_forgets_them(held) -> None:  # type: ignore[no-untyped-def]
    _, clock, sleeps = held
    clock.sleep_until(100.001)  # this thread: due 1 ms ahead...
    clock.sleep_until(100.010)  # ... then its next frame, 10 ms ahead: nothing due soon
    clock.hold_off()
    assert sleeps == []
    _waits_for(clock, 100.001)
    clock.reset()  # between shows: no writer waits any more
    clock.hold_off()
    assert sleeps == []


def test_hold_off_reads_deadlines_on_the_conductors_time_as_the_writers_wait_for_them(
    held,
) -> None:  # type: ignore[no-untyped-def]
    _, clock, sleeps = held
    clock.follow(Timebase(offset=-5.0, ref=100.0))  # the conductor's clock is 5 s ahead
    _waits_for(clock, 105.0015)  # a show-clock deadline: 1.5 ms from now
    clock.hold_off()
    assert sleeps == pytest.approx([0.002], abs=1e-9)


def test_on_the_real_clock_a_thread_holds_off_until_past_a_waiting_writers_deadline() -> None:
    clock = SlewingClock(MonotonicClock())
    deadline = time.monotonic() + 0.2
    writer = threading.Thread(target=clock.sleep_until, args=(deadline,))
    writer.start()
    MonotonicClock().sleep_until(deadline - 0.001)  # 1 ms before it (or later, if busy)
    clock.hold_off()
    assert time.monotonic() >= deadline + HOLD_AFTER  # never earlier, however late it woke
    writer.join()
