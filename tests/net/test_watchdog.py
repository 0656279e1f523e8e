"""The watchdog: a silent peer is noticed at exactly last-heard + timeout, once, and a thawed
peer is reported back."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from xgo_show.net.watchdog import GRACE, LATE, Watchdog
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


class WakeRecordingClock(MonotonicClock):
    """The real clock, noting each completed wait's deadline and how late it woke after it."""

    def __init__(self) -> None:
        super().__init__()
        self.woke: list[tuple[float, float]] = []

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        done = super().sleep_until(deadline, interrupt)
        if done:
            self.woke.append((deadline, self.now() - deadline))
        return done


def test_on_the_real_clock_a_peer_heard_often_is_kept_and_silence_is_noticed_on_time() -> None:
    lost = threading.Event()
    noticed: list[float] = []

    def on_silence(silence: float) -> None:
        noticed.append(time.monotonic())
        lost.set()

    clock = WakeRecordingClock()
    with Watchdog(0.1, on_silence, clock=clock) as dog:
        for _ in range(15):
            dog.heard()
            time.sleep(0.02)
        assert not lost.is_set()
        last = dog.last_heard
        assert lost.wait(2.0)
    late = noticed[0] - (last + 0.1)
    # The waits for the final silence: from its deadline on (the earlier ones ended heard).
    final = [w for at, w in clock.woke if at >= last + 0.1 - 1e-9]
    starved = [w for w in final if w > LATE]
    if not starved:
        assert 0 <= late < LATE  # a sleeper wakes ~0.1 ms late on an idle machine
    else:
        # This host starved the watchdog (a loaded machine): it gave the process a grace of its
        # late wake-up (at least GRACE) before judging, so the silence is noticed after that
        # grace, and only that much later (each grace at most the timeout, each wait's own
        # lateness on top).
        first = starved[0]
        assert first + min(max(first, GRACE), 0.1) <= late < sum(final) + 0.1 * len(starved) + LATE


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


class StarvedClock(FakeClock):
    """A fake clock whose sleeps, while ``starve`` is set, end ``late`` seconds late; before
    each sleep it runs ``on_sleep`` (what the process's other threads do meanwhile)."""

    def __init__(self, start: float) -> None:
        super().__init__(start)
        self.late = 0.0
        self.starve = 0  # how many sleeps to end late
        self.on_sleep: Callable[[], None] = lambda: None

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        self.on_sleep()
        ok = super().sleep_until(deadline, interrupt)
        if ok and self.starve > 0:
            self.starve -= 1
            self.advance(self.late)
        return ok


def test_a_watchdog_starved_past_its_deadline_first_hears_what_arrived_meanwhile(
    wait: Callable[..., None],
) -> None:
    clock = StarvedClock(100.0)
    silences: list[tuple[float, float]] = []
    dog = Watchdog(0.5, lambda s: silences.append((s, clock.now())), clock=clock)
    clock.late, clock.starve = 0.2, 1  # the whole process got no CPU for 0.2 s
    woke: list[float] = []

    def catch_up() -> None:
        # The heartbeat the starvation held up is read once the process runs again: here, when
        # the watchdog goes to sleep for its grace after its late wake-up.
        if clock.now() > 100.5 and not woke:
            woke.append(clock.now())
            dog.heard()

    clock.on_sleep = catch_up
    with dog.start():
        wait(lambda: len(silences) == 1)
    assert woke == [pytest.approx(100.7)]  # it woke 0.2 s late and did not judge then
    # heard during its grace, so lost only at that heartbeat's deadline (silent from then on)
    assert silences == [(pytest.approx(0.5), pytest.approx(101.2))]


def test_a_silent_peer_is_lost_after_the_grace_a_late_wake_up_gives() -> None:
    clock = StarvedClock(100.0)
    lost = threading.Event()
    at: list[tuple[float, float]] = []

    def on_silence(silence: float) -> None:
        at.append((silence, clock.now()))
        lost.set()

    clock.late, clock.starve = 0.3, 2  # late from the deadline, and from the first grace
    with Watchdog(0.5, on_silence, clock=clock).start():
        assert lost.wait(2.0)
    # woke at 100.8 (0.3 late): grace to 101.1, woke 101.4 (late again): grace to 101.7, on time
    assert at == [(pytest.approx(1.7), pytest.approx(101.7))]
    assert clock.waits[:3] == [pytest.approx(100.5), pytest.approx(101.1), pytest.approx(101.7)]
