"""The relay's deferred bookkeeping (xgo_show/relay/deferred.py): listeners off the writer."""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import pytest

from xgo_show.relay.deferred import Alarm, DeferredListeners
from xgo_show.runtime.events import Event, EventBus


def test_listeners_get_every_event_in_order_later_on_another_thread() -> None:
    bus = EventBus()
    got: list[tuple[float, str, float]] = []

    def listener(ev: Event) -> None:
        got.append((ev.t, threading.current_thread().name, time.monotonic()))

    deferred = DeferredListeners(bus, [listener], delay=0.05, realtime=False, name="booked")
    published = time.monotonic()
    for i in range(5):
        bus.publish(Event(float(i)))
    assert got == []  # the publisher returned at once; nothing was handed on yet
    time.sleep(0.2)
    assert [t for t, _, _ in got] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert {name for _, name, _ in got} == {"booked"}
    assert all(at - published >= 0.05 for _, _, at in got)  # not before the delay
    deferred.close()


def test_flush_hands_on_at_once_and_close_hands_on_what_is_left() -> None:
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=30.0, realtime=False)
    bus.publish(Event(1.0))
    t0 = time.monotonic()
    assert deferred.flush()
    assert got == [1.0] and time.monotonic() - t0 < 1.0  # not the 30 s delay
    assert deferred.flush()  # nothing pending: at once
    bus.publish(Event(2.0))
    deferred.close()
    assert got == [1.0, 2.0]
    bus.publish(Event(3.0))  # after close: not taken
    time.sleep(0.01)
    assert got == [1.0, 2.0]


def test_a_broken_listener_is_counted_and_the_others_still_get_the_event() -> None:
    bus = EventBus()
    got: list[float] = []

    def broken(ev: Event) -> None:
        raise RuntimeError("a bug")

    deferred = DeferredListeners(bus, [broken, lambda ev: got.append(ev.t)], realtime=False)
    bus.publish(Event(1.0))
    assert deferred.flush()
    assert got == [1.0] and deferred.listener_errors == 1
    deferred.close()


def test_a_full_queue_drops_the_newest_and_counts_them(monkeypatch) -> None:
    import xgo_show.relay.deferred as mod

    monkeypatch.setattr(mod, "BACKLOG", 3)
    bus = EventBus()
    gate = threading.Event()
    got: list[float] = []

    def slow(ev: Event) -> None:
        gate.wait(5)
        got.append(ev.t)

    deferred = DeferredListeners(bus, [slow], delay=0.0, realtime=False)
    bus.publish(Event(0.0))
    time.sleep(0.05)  # the thread took it and waits in the listener
    for i in range(1, 6):
        bus.publish(Event(float(i)))
    assert deferred.dropped == 2
    gate.set()
    deferred.close()
    assert got == [0.0, 1.0, 2.0, 3.0]


def _switches(tid: int) -> int:
    """How many times thread ``tid`` of this process went off its CPU (woken and slept)."""
    text = Path(f"/proc/self/task/{tid}/status").read_text(encoding="ascii")
    return sum(int(line.split()[1]) for line in text.splitlines() if "ctxt_switches" in line)


def _asleep(tid: int) -> int:
    """Wait until thread ``tid`` sleeps and stays asleep; its switch count then."""
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        count = _switches(tid)
        time.sleep(0.02)
        status = Path(f"/proc/self/task/{tid}/status").read_text(encoding="ascii")
        if "State:\tS" in status and _switches(tid) == count:
            return count
    raise AssertionError("the bookkeeping thread never went to sleep")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="timerfd is Linux's")
def test_publishing_wakes_nobody_until_the_delay_is_over() -> None:
    # The writer publishes right after its write, while the frame is being delivered: the
    # bookkeeping thread must not wake then (it used to be notified, wake, and sleep again).
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=0.3, realtime=False)
    tid = deferred._thread.native_id
    assert tid is not None
    before = _asleep(tid)  # the thread waits for its alarm
    bus.publish(Event(1.0))
    bus.publish(Event(2.0))
    time.sleep(0.15)
    assert _switches(tid) == before and got == []
    deadline = time.monotonic() + 5.0
    while not got and time.monotonic() < deadline:
        time.sleep(0.01)
    assert got == [1.0, 2.0] and _switches(tid) > before
    deferred.close()


def test_the_portable_alarm_fires_at_the_latest_time_set() -> None:
    alarm = Alarm()
    alarm.close()  # the condition-variable way, as where there is no timerfd
    alarm.arm(5.0)
    alarm.arm(0.05)  # replaces the 5 s
    t0 = time.monotonic()
    alarm.wait()
    assert 0.04 <= time.monotonic() - t0 < 1.0
    alarm.arm(0.0)
    t0 = time.monotonic()
    alarm.wait()
    assert time.monotonic() - t0 < 0.5


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="timerfd is Linux's")
def test_the_kernel_alarm_fires_at_the_latest_time_set() -> None:
    alarm = Alarm()
    assert alarm._kernel is not None
    alarm.arm(5.0)
    alarm.arm(0.05)
    t0 = time.monotonic()
    alarm.wait()
    assert 0.04 <= time.monotonic() - t0 < 1.0
    alarm.close()
