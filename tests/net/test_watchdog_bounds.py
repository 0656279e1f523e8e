"""The watchdog (net/watchdog.py) at its edges: its defaults, the refusal of a timeout that is
not positive, its thread's name, and stopping it from anywhere, its own thread included
(test_watchdog.py holds the timing on a fake and on the real clock)."""

from __future__ import annotations

import threading
import time

import pytest

from xgo_show.net.watchdog import Watchdog
from xgo_show.runtime.clock import FakeClock


@pytest.mark.parametrize("timeout", [0.0, -1.0])
def test_a_timeout_must_be_positive(timeout: float) -> None:
    with pytest.raises(ValueError) as info:
        Watchdog(timeout)
    assert str(info.value) == "a watchdog timeout must be positive"
    dog = Watchdog(0.5)
    with pytest.raises(ValueError) as info:
        dog.set_timeout(timeout)
    assert str(info.value) == "a watchdog timeout must be positive"
    assert dog.timeout == 0.5


def test_by_default_it_watches_a_peer_on_the_monotonic_clock() -> None:
    dog = Watchdog(0.5)
    assert dog.name == "peer"
    assert abs(dog.last_heard - time.monotonic()) < 1.0
    assert dog.lost is False
    with dog:
        thread = dog._thread
        assert thread is not None
        assert (thread.name, thread.daemon) == ("xgo-show watchdog peer", True)
    assert not thread.is_alive()


def test_a_named_watchdogs_thread_is_named_after_it() -> None:
    with Watchdog(0.5, name="relay hall") as dog:
        assert dog._thread is not None and dog._thread.name == "xgo-show watchdog relay hall"


def test_heard_again_after_a_loss_it_is_not_lost() -> None:
    clock = FakeClock(10.0)
    back: list[float] = []
    dog = Watchdog(0.5, clock=clock, on_back=back.append)
    assert dog.check(10.5) == 0.5
    assert dog.lost is True
    dog.heard(11.0)
    assert dog.lost is False and back == [1.0]
    dog.heard(11.1)  # not lost: no "back"
    assert back == [1.0]


def test_it_can_be_stopped_from_its_own_callback_and_started_again() -> None:
    stopped = threading.Event()
    dog = Watchdog(0.05)

    def on_silence(silence: float) -> None:
        dog.stop()  # from the watchdog's own thread: no join of itself
        stopped.set()

    dog.on_silence = on_silence
    dog.start()
    assert stopped.wait(5.0)
    deadline = time.monotonic() + 5
    while dog._thread is not None:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    dog._stopped = False
    with dog:  # stopped: entering starts it again
        assert dog._thread is not None and dog._thread.is_alive()
    assert dog._thread is None


def test_stop_waits_for_the_thread_to_end() -> None:
    dog = Watchdog(30.0).start()
    thread = dog._thread
    assert thread is not None and thread.is_alive()
    dog.stop()
    assert not thread.is_alive() and dog._thread is None


def test_start_counts_from_now_and_forgets_an_old_loss() -> None:
    dog = Watchdog(30.0)
    assert dog.check(time.monotonic() + 31) is not None and dog.lost is True
    dog.start()  # no grace by default: from now
    try:
        assert abs(dog.last_heard - time.monotonic()) < 0.5 and dog.lost is False
    finally:
        dog.stop()
    dog.start(grace=5.0)
    try:
        assert 4.5 < dog.last_heard - time.monotonic() <= 5.0
    finally:
        dog.stop()


def test_a_watchdog_without_a_callback_only_marks_the_loss() -> None:
    dog = Watchdog(0.05).start()
    try:
        deadline = time.monotonic() + 5
        while not dog.lost:
            assert time.monotonic() < deadline
            time.sleep(0.005)
        dog.heard()
        assert dog._thread is not None and dog._thread.is_alive()  # not killed by a None call
        assert dog.lost is False
    finally:
        dog.stop()
