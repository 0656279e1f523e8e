"""The watchdog: a silent peer is noticed at exactly last-heard + timeout, once, and a thawed
peer is reported back."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from xgo_show.net.watchdog import Watchdog
from xgo_show.runtime.clock import FakeClock, MonotonicClock


def test_the_decision_is_a_function_of_the_times() -> None:
    clock = FakeClock(100.0)
    dog = Watchdog(0.5, clock=clock)
    assert dog.deadline == 100.5
    assert dog.check(100.49) is None
    dog.heard(100.3)
    assert dog.check(100.79) is None
    assert dog.check(100.8) == pytest.approx(0.5)
    assert dog.lost
    assert dog.check(101.5) is None  # once per loss
    dog.heard(102.0)
    assert not dog.lost
    assert dog.check(102.6) == pytest.approx(0.6)


def test_an_earlier_report_never_moves_the_last_heard_time_back() -> None:
    dog = Watchdog(0.5, clock=FakeClock(100.0))
    dog.heard(101.0)
    dog.heard(100.9)  # a late callback from another thread
    assert dog.last_heard == 101.0


def test_the_thread_fires_at_the_deadline_itself_and_reports_a_peer_that_comes_back(
    wait: Callable[..., None],
) -> None:
    clock = FakeClock(100.0)
    silences: list[tuple[float, float]] = []
    backs: list[float] = []
    dog = Watchdog(
        0.5,
        lambda s: silences.append((s, clock.now())),
        on_back=backs.append,
        clock=clock,
    )
    with dog.start(grace=1.0):
        wait(lambda: len(silences) == 1)
        assert silences[0] == (pytest.approx(0.5), pytest.approx(101.5))
        clock.advance(0.25)
        dog.heard()
        assert backs == [pytest.approx(0.75)]
        wait(lambda: len(silences) == 2)  # armed again: the fake clock jumps to the deadline
        assert silences[1] == (pytest.approx(0.5), pytest.approx(102.25))


def test_on_the_real_clock_a_peer_heard_often_is_kept_and_silence_is_noticed_on_time() -> None:
    lost = threading.Event()
    noticed: list[float] = []

    def on_silence(silence: float) -> None:
        noticed.append(time.monotonic())
        lost.set()

    with Watchdog(0.1, on_silence, clock=MonotonicClock()) as dog:
        for _ in range(15):
            dog.heard()
            time.sleep(0.02)
        assert not lost.is_set()
        last = dog.last_heard
        assert lost.wait(2.0)
    late = noticed[0] - (last + 0.1)
    assert 0 <= late < 0.02  # a sleeper wakes ~0.1 ms late; more only on a busy machine


def test_a_timeout_must_be_positive() -> None:
    with pytest.raises(ValueError, match="positive"):
        Watchdog(0.0)


def test_a_shorter_timeout_set_while_waiting_takes_effect_at_once() -> None:
    lost = threading.Event()
    with Watchdog(30.0, lambda s: lost.set(), clock=MonotonicClock()) as dog:
        time.sleep(0.05)
        dog.set_timeout(0.1)
        assert lost.wait(2.0)
        assert dog.lost
    with pytest.raises(ValueError, match="positive"):
        dog.set_timeout(-1.0)
