"""The real clock's waits and the real-time hand-off, in a SCHED_FIFO thread where permitted."""

from __future__ import annotations

import os
import sys
import threading
import time

import pytest

from xgo_show.runtime.clock import (
    HANDOFF,
    MonotonicClock,
    hand_off_cpu,
    is_realtime,
    tighten_timer_slack,
)


def _in_fifo_thread(fn: object) -> dict[str, object]:
    """Run ``fn`` in a new thread switched to SCHED_FIFO priority 1; skip where refused."""
    out: dict[str, object] = {}

    def body() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        except (AttributeError, OSError) as exc:
            out["refused"] = str(exc)
            return
        out["result"] = fn()  # type: ignore[operator]

    th = threading.Thread(target=body)
    th.start()
    th.join(10)
    if "refused" in out:
        pytest.skip(f"SCHED_FIFO not permitted here: {out['refused']}")
    return out


def test_normal_thread_is_not_realtime_and_does_not_hand_off() -> None:
    import resource

    assert not is_realtime()
    # A hand-off is a sleep: a voluntary context switch each. Counted rather than timed, so
    # that a slow or loaded machine cannot make doing nothing look like sleeping.
    before = resource.getrusage(resource.RUSAGE_THREAD).ru_nvcsw
    for _ in range(200):
        hand_off_cpu()
    assert resource.getrusage(resource.RUSAGE_THREAD).ru_nvcsw - before < 20


def test_realtime_thread_hands_off_its_cpu_after_a_write() -> None:
    def work() -> tuple[bool, float]:
        t0 = time.perf_counter()
        hand_off_cpu()
        return is_realtime(), time.perf_counter() - t0

    realtime, took = _in_fifo_thread(work)["result"]  # type: ignore[misc]
    assert realtime
    assert took >= HANDOFF


def test_realtime_thread_wakes_on_time_never_early() -> None:
    clock = MonotonicClock()

    def work() -> list[float]:
        errors = []
        for _ in range(20):
            deadline = clock.now() + 0.003
            clock.sleep_until(deadline)
            errors.append(clock.now() - deadline)
        return errors

    errors: list[float] = _in_fifo_thread(work)["result"]  # type: ignore[assignment]
    assert min(errors) >= 0.0
    assert sorted(errors)[len(errors) // 2] < 0.001


def test_monotonic_wait_returns_true_at_the_deadline_never_before() -> None:
    from xgo_show.runtime.clock import MonotonicClock

    clock = MonotonicClock()
    for delay in (0.0, 0.0001, 0.003, 0.02):
        deadline = clock.now() + delay
        assert clock.sleep_until(deadline, threading.Event()) is True
        assert clock.now() >= deadline


def test_monotonic_wait_interrupted_mid_sleep_returns_false_early() -> None:
    """A pause or stop request cuts a long wait short and says so (not 'deadline reached')."""
    from xgo_show.runtime.clock import MonotonicClock

    clock = MonotonicClock()
    interrupt = threading.Event()
    deadline = clock.now() + 2.0
    timer = threading.Timer(0.05, interrupt.set)
    timer.start()
    try:
        assert clock.sleep_until(deadline, interrupt) is False
        woke = clock.now()
    finally:
        timer.cancel()
    assert woke < deadline - 1.0  # well before the deadline, not after a full sleep


def test_monotonic_wait_interrupted_in_its_final_spin_returns_false() -> None:
    from xgo_show.runtime.clock import MonotonicClock

    # No sleep phase at all: the whole wait is the spin, which must still see the interrupt.
    clock = MonotonicClock(margin=0.0, aim=0.0, spin=1.0)
    interrupt = threading.Event()
    deadline = clock.now() + 0.5
    timer = threading.Timer(0.02, interrupt.set)
    timer.start()
    try:
        assert clock.sleep_until(deadline, interrupt) is False
    finally:
        timer.cancel()
    assert clock.now() < deadline


def test_monotonic_wait_with_the_interrupt_already_set_returns_false_at_once() -> None:
    from xgo_show.runtime.clock import MonotonicClock

    clock = MonotonicClock()
    interrupt = threading.Event()
    interrupt.set()
    start = clock.now()
    assert clock.sleep_until(start + 1.0, interrupt) is False
    assert clock.now() - start < 0.5


def test_a_wait_sleeps_and_spins_only_its_last_moments() -> None:
    # Half a second's wait costs the waiting thread almost no CPU: it sleeps up to the margin
    # and spins only the last fraction of a millisecond (a busy machine would take a whole
    # time slice from a thread that spins long, and the others' deadlines with it).
    clock = MonotonicClock()
    for interrupt in (None, threading.Event()):
        cpu = time.thread_time()
        deadline = clock.now() + 0.5
        assert clock.sleep_until(deadline, interrupt) is True
        assert clock.now() >= deadline
        assert time.thread_time() - cpu < 0.02


def test_a_wait_wakes_near_its_deadline_whatever_its_margins() -> None:
    # Wide margins so that aiming past the deadline by one of them (60 ms sleeping, 30 ms in
    # the short naps) could not hide in a loaded machine's wake-up latency. The best of three
    # waits is compared: only scheduling noise differs between them.
    clock = MonotonicClock(margin=0.06, aim=0.03, spin=0.04)
    for interrupt in (None, threading.Event()):
        late = []
        for _ in range(3):
            deadline = clock.now() + 0.15
            assert clock.sleep_until(deadline, interrupt) is True
            late.append(clock.now() - deadline)
        assert min(late) >= 0.0 and min(late) < 0.015, late


def test_timer_slack_is_tightened_for_the_calling_thread_only() -> None:
    import ctypes
    import sys

    if not sys.platform.startswith("linux"):
        assert tighten_timer_slack() is False
        return
    libc = ctypes.CDLL(None, use_errno=True)
    set_slack, get_slack = 29, 30  # PR_SET_TIMERSLACK, PR_GET_TIMERSLACK

    def tighten() -> tuple[bool, int]:
        return tighten_timer_slack(), int(libc.prctl(get_slack, 0, 0, 0, 0))

    def from_usual_slack() -> None:
        # A new thread takes its creator's slack as its own and as its default, and another
        # test may have tightened this one's: create the thread under test from a thread set
        # back to the kernel's usual 50 us (so neither its slack nor its default is 1 ns).
        libc.prctl(set_slack, 50_000, 0, 0, 0)
        inner = threading.Thread(target=lambda: out.append(tighten()))
        inner.start()
        inner.join(5)

    before = int(libc.prctl(get_slack, 0, 0, 0, 0))
    out: list[tuple[bool, int]] = []
    thread = threading.Thread(target=from_usual_slack)
    thread.start()
    thread.join(5)
    assert out == [(True, 1)]  # 1 ns: sleeps wake on time instead of up to 50 us late
    assert int(libc.prctl(get_slack, 0, 0, 0, 0)) == before  # other threads keep theirs


def test_a_fake_clock_waits_by_jumping_and_an_interrupt_stops_it() -> None:
    from xgo_show.runtime.clock import FakeClock

    clock = FakeClock(50.0)
    assert clock.sleep_until(52.5) is True and clock.now() == 52.5
    assert clock.sleep_until(51.0) is True and clock.now() == 52.5  # never backwards
    stop = threading.Event()
    stop.set()
    assert clock.sleep_until(60.0, stop) is False and clock.now() == 52.5
    assert clock.waits == [52.5, 51.0]  # the interrupted wait asked for nothing
    quiet = FakeClock(keep_waits=False)
    quiet.sleep_until(quiet.now() + 1.0)
    assert quiet.waits == []


def test_a_forked_fake_clock_starts_at_the_same_time_and_goes_its_own_way() -> None:
    from xgo_show.runtime.clock import FakeClock

    for keep in (True, False):
        clock = FakeClock(10.0, keep_waits=keep)
        clock.advance(2.0)
        fork = clock.fork()
        assert fork.now() == 12.0 and fork.keep_waits is keep
        fork.sleep_until(20.0)
        assert (fork.now(), clock.now()) == (20.0, 12.0)
        assert fork.waits == ([20.0] if keep else []) and clock.waits == []


class _NapLog(threading.Event):
    """A real event that also notes how long each wait on it was asked to last."""

    def __init__(self) -> None:
        super().__init__()
        self.naps: list[float | None] = []

    def wait(self, timeout: float | None = None) -> bool:
        self.naps.append(timeout)
        return super().wait(timeout)


def test_a_long_wait_sleeps_to_its_margin_then_naps_short_of_the_deadline() -> None:
    clock = MonotonicClock()
    log = _NapLog()
    deadline = clock.now() + 0.05
    assert clock.sleep_until(deadline, log) is True
    naps = [n for n in log.naps if n is not None]
    # First one sleep that stops a margin before the deadline (a loaded machine wakes a
    # sleeper a millisecond or so late) ...
    assert 0.05 - clock.margin - 0.01 < naps[0] <= 0.05 - clock.margin
    # ... then only short naps, each aiming ``aim`` before the deadline, never past it.
    assert all(0 < n < clock.margin + clock.spin - clock.aim for n in naps[1:])


def test_timed_waits_are_trusted_to_end_past_the_deadline_only_on_glibc_2_30_or_later() -> None:
    import platform

    from xgo_show.runtime.clock import _timeouts_on_monotonic

    lib, version = platform.libc_ver()
    expected = (sys.platform.startswith("linux") and lib == "glibc"
                and tuple(int(p) for p in version.split(".")[:2]) >= (2, 30))
    assert _timeouts_on_monotonic() is expected


def test_an_early_wait_blocks_then_ends_on_the_cpu_never_before_the_deadline(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # clock.EARLY: a real-time wait stops blocking that long before its deadline and runs
    # out the rest on its CPU. Called directly (the real-time wait itself, in this thread).
    from xgo_show.runtime import clock as clock_module

    monkeypatch.setattr(clock_module, "EARLY", 0.002)
    for interrupt in (None, threading.Event()):
        cpu = time.thread_time()
        deadline = time.monotonic() + 0.03
        assert clock_module._block_until(deadline, interrupt)
        assert time.monotonic() >= deadline
        # Blocked for all but the last 2 ms: the CPU it used is at most those (a wait that
        # spun all along would have used about 30 ms).
        assert time.thread_time() - cpu < 0.015


def test_an_early_wait_is_cut_short_by_its_interrupt_while_on_the_cpu(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xgo_show.runtime import clock as clock_module

    monkeypatch.setattr(clock_module, "EARLY", 5.0)  # the whole wait on the CPU
    stop = threading.Event()
    stop.set()
    t0 = time.monotonic()
    assert not clock_module._block_until(t0 + 3.0, stop)
    assert time.monotonic() - t0 < 1.0


@pytest.mark.parametrize(("confstr", "trusted"), [
    ("glibc 2.30", True),  # sem_clockwait: timed waits on CLOCK_MONOTONIC
    ("glibc 2.36", True),
    ("glibc 3.0", True),
    ("glibc 2.29", False),  # waits on the wall clock
    ("glibc 1.99", False),
    ("musl 1.2", False),
    ("musl 2.31", False),  # a version new enough, but not glibc
    ("glibc", False),  # a version this cannot read
    ("glibc 2", False),
    ("glibc 2.30.1", True),  # a third part, read past
    ("", False),
    (None, False),
])
def test_which_c_libraries_wait_on_the_monotonic_clock(
    monkeypatch: pytest.MonkeyPatch, confstr: str | None, trusted: bool
) -> None:
    from xgo_show.runtime import clock as clock_module

    monkeypatch.setattr(clock_module.sys, "platform", "linux")
    monkeypatch.setattr(clock_module.os, "confstr", lambda name: confstr)
    assert clock_module._timeouts_on_monotonic() is trusted
    monkeypatch.setattr(clock_module.sys, "platform", "darwin")
    monkeypatch.setattr(clock_module.os, "confstr", lambda name: "glibc 2.36")
    assert clock_module._timeouts_on_monotonic() is False


class _SleepLog:
    """``time`` for clock.py: the real clock, and every sleep's length noted."""

    def __init__(self) -> None:
        self.naps: list[float] = []
        self.monotonic = time.monotonic

    def sleep(self, seconds: float) -> None:
        self.naps.append(seconds)
        time.sleep(seconds)


def test_an_early_wait_blocks_only_up_to_early_before_its_deadline(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xgo_show.runtime import clock as clock_module

    monkeypatch.setattr(clock_module, "EARLY", 0.005)
    log = _SleepLog()
    monkeypatch.setattr(clock_module, "time", log)
    deadline = time.monotonic() + 0.03
    assert clock_module._block_until(deadline, None) is True
    assert time.monotonic() >= deadline
    assert log.naps and all(0 < nap <= 0.025 for nap in log.naps)
    naps = _NapLog()
    deadline = time.monotonic() + 0.03
    assert clock_module._block_until(deadline, naps) is True
    assert naps.naps and all(n is not None and 0 < n <= 0.025 for n in naps.naps)


def test_a_real_time_wait_is_cut_short_by_its_interrupt_while_it_blocks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from xgo_show.runtime import clock as clock_module

    monkeypatch.setattr(clock_module, "EARLY", 0.002)
    stop = threading.Event()
    stop.set()
    t0 = time.monotonic()
    assert clock_module._block_until(t0 + 3.0, stop) is False
    assert time.monotonic() - t0 < 1.0

    def work() -> tuple[bool, float]:
        # In a SCHED_FIFO thread, through the clock: a stop request wakes the wait at once.
        late = threading.Event()
        threading.Timer(0.05, late.set).start()
        start = time.monotonic()
        woke = MonotonicClock().sleep_until(start + 5.0, late)
        return woke, time.monotonic() - start

    woke, took = _in_fifo_thread(work)["result"]  # type: ignore[misc]
    assert woke is False and took < 2.5


def test_without_early_a_wait_that_ran_out_ends_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    from xgo_show.runtime import clock as clock_module

    monkeypatch.setattr(clock_module, "EARLY", 0.0)
    for interrupt in (None, threading.Event()):
        deadline = time.monotonic() + 0.01
        assert clock_module._block_until(deadline, interrupt) is True
        assert time.monotonic() >= deadline
