"""The relay's deferred bookkeeping (xgo_show/relay/deferred.py): listeners off the writer.

Every wait here is bounded by a deadline, not a fixed sleep: a loaded machine (a mutation run
at idle priority, six suites at once) may run the bookkeeping thread late, never early."""

from __future__ import annotations

import functools
import os
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

import xgo_show.relay.deferred as deferred_mod
from tests.conftest import wait_until
from xgo_show.relay.deferred import DELAY, IDLE, Alarm, DeferredListeners
from xgo_show.runtime.events import Event, EventBus
from xgo_show.runtime.realtime import HELPER_PRIORITY

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="timerfd is Linux's")


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
    wait_until(lambda: len(got) == 5, timeout=10.0)
    assert [t for t, _, _ in got] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert {name for _, name, _ in got} == {"booked"}
    assert all(at - published >= 0.05 for _, _, at in got)  # not before the delay
    deferred.close()


def test_the_defaults_hand_on_4_ms_later_on_a_raised_daemon_thread_named_for_the_relay() -> None:
    assert (DELAY, IDLE, deferred_mod.BACKLOG) == (0.004, 0.3, 100_000)
    deferred = DeferredListeners(EventBus(), [print])
    try:
        assert deferred.delay == DELAY and deferred.realtime is True
        assert deferred.listeners == (print,)
        assert (deferred.dropped, deferred.listener_errors) == (0, 0)
        th = deferred._thread
        assert th.name == "xgo-show relay bookkeeping" and th.daemon and th.is_alive()
    finally:
        deferred.close()


def test_the_first_event_arms_the_delay_from_when_it_was_published() -> None:
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(time.monotonic())], delay=0.25,
                                 realtime=False)
    try:
        published = time.monotonic()
        bus.publish(Event(1.0))
        wait_until(lambda: got, timeout=10.0)
        assert got[0] - published >= 0.25
        again = time.monotonic()
        bus.publish(Event(2.0))  # the next one after a quiet spell: its own delay again
        wait_until(lambda: len(got) == 2, timeout=10.0)
        assert got[1] - again >= 0.25
    finally:
        deferred.close()


def test_flush_hands_on_at_once_and_close_hands_on_what_is_left() -> None:
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=30.0, realtime=False)
    bus.publish(Event(1.0))
    t0 = time.monotonic()
    assert deferred.flush()
    assert got == [1.0] and time.monotonic() - t0 < 0.9  # at once, not after the 30 s delay
    assert deferred.flush()  # nothing pending: at once
    bus.publish(Event(2.0))
    deferred.close()
    assert got == [1.0, 2.0] and not deferred._thread.is_alive()
    bus.publish(Event(3.0))  # after close: not taken
    assert deferred.flush() and got == [1.0, 2.0]


def test_close_takes_no_more_events_even_from_a_bus_it_still_hears(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=30.0, realtime=False)
    deferred.close()
    deferred._put(Event(1.0))  # a writer that published as close ran
    assert got == [] and deferred._queued == 0 and deferred.dropped == 0


def test_a_flush_that_takes_too_long_says_so_after_its_timeout() -> None:
    bus = EventBus()
    gate = threading.Event()
    entered = threading.Event()

    def slow(ev: Event) -> None:
        entered.set()
        gate.wait(30)

    deferred = DeferredListeners(bus, [slow], delay=0.0, realtime=False)
    try:
        bus.publish(Event(1.0))
        assert entered.wait(10.0)
        t0 = time.monotonic()
        assert deferred.flush(timeout=0.2) is False
        assert 0.2 <= time.monotonic() - t0 < 5.0
        t0 = time.monotonic()
        assert deferred.flush() is False  # the default: two seconds
        assert 2.0 <= time.monotonic() - t0 < 2.9
        gate.set()
        assert deferred.flush(timeout=10.0) is True
    finally:
        gate.set()
        deferred.close()


class _Crash(BaseException):
    """Not an Exception: it ends the bookkeeping thread, as a bug in it would."""


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_a_flush_does_not_wait_for_a_thread_that_has_died() -> None:
    bus = EventBus()

    def crash(ev: Event) -> None:
        raise _Crash

    deferred = DeferredListeners(bus, [crash], delay=0.0, realtime=False)
    bus.publish(Event(1.0))
    deferred._thread.join(10.0)
    assert not deferred._thread.is_alive()
    assert deferred._alarm._kernel is None  # its timer was given back as it ended
    bus.publish(Event(2.0))
    t0 = time.monotonic()
    assert deferred.flush(timeout=30.0) is False
    assert time.monotonic() - t0 < 5.0  # at once, not after the 30 s
    deferred.close()


def test_a_broken_listener_is_counted_and_the_others_still_get_the_event() -> None:
    bus = EventBus()
    got: list[float] = []

    def broken(ev: Event) -> None:
        raise RuntimeError("a bug")

    deferred = DeferredListeners(bus, [broken, lambda ev: got.append(ev.t)], realtime=False)
    bus.publish(Event(1.0))
    bus.publish(Event(2.0))
    assert deferred.flush()
    assert got == [1.0, 2.0] and deferred.listener_errors == 2
    deferred.close()


def test_a_full_queue_drops_the_newest_and_counts_them(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(deferred_mod, "BACKLOG", 3)
    bus = EventBus()
    gate = threading.Event()
    entered = threading.Event()
    got: list[float] = []

    def slow(ev: Event) -> None:
        entered.set()
        gate.wait(30)
        got.append(ev.t)

    deferred = DeferredListeners(bus, [slow], delay=0.0, realtime=False)
    bus.publish(Event(0.0))
    assert entered.wait(10.0)  # the thread took it and waits in the listener
    for i in range(1, 6):
        bus.publish(Event(float(i)))
    assert deferred.dropped == 2 and deferred._queued == 4
    gate.set()
    deferred.close()
    assert got == [0.0, 1.0, 2.0, 3.0]


def test_a_queue_half_full_is_handed_on_without_waiting_for_the_delay(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(deferred_mod, "BACKLOG", 10)
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=60.0, realtime=False)
    try:
        for i in range(4):
            bus.publish(Event(float(i)))
        time.sleep(0.3)
        assert got == []  # under half full: the delay holds
        half = time.monotonic()
        bus.publish(Event(4.0))
        wait_until(lambda: len(got) == 5, timeout=10.0)  # at once, not after the 60 s delay
        assert got == [0.0, 1.0, 2.0, 3.0, 4.0] and time.monotonic() - half < 0.9
    finally:
        deferred.close()


@pytest.fixture
def raised(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[tuple[str, object, str, float]]]:
    """Records the bookkeeping thread's raising and lowering (granted), with the thread that
    asked and when; the real policy is never asked (a test process is not real-time)."""
    calls: list[tuple[str, object, str, float]] = []

    def enter(priority: int) -> bool:
        calls.append(("enter", priority, threading.current_thread().name, time.monotonic()))
        return True

    def leave() -> None:
        calls.append(("leave", None, threading.current_thread().name, time.monotonic()))

    monkeypatch.setattr(deferred_mod, "enter_show_thread", enter)
    monkeypatch.setattr(deferred_mod, "leave_show_thread", leave)
    monkeypatch.setattr(deferred_mod, "IDLE", 0.2)
    yield calls


def test_the_thread_is_raised_from_the_first_event_until_a_quiet_spell(
    raised: list[tuple[str, object, str, float]],
) -> None:
    bus = EventBus()
    deferred = DeferredListeners(bus, [lambda ev: None], delay=0.0, name="booked")
    try:
        assert raised == []  # nothing real-time before a show's first event
        bus.publish(Event(1.0))
        assert deferred.flush(10.0)
        last = time.monotonic()  # read before the event is queued: it is no later
        bus.publish(Event(2.0))
        assert deferred.flush(10.0)
        assert [c[:3] for c in raised] == [("enter", HELPER_PRIORITY, "booked")]  # once
        wait_until(lambda: len(raised) == 2, timeout=10.0)
        kind, _, thread, at = raised[1]
        assert (kind, thread) == ("leave", "booked")
        assert at - last >= 0.2  # not before IDLE without an event
        bus.publish(Event(3.0))  # the next show raises it again
        wait_until(lambda: len(raised) == 3, timeout=10.0)
        assert raised[2][:3] == ("enter", HELPER_PRIORITY, "booked")
    finally:
        deferred.close()
    assert [c[0] for c in raised] == ["enter", "leave", "enter", "leave"]  # closing lowers it


def test_a_quiet_spell_is_counted_from_the_last_event_not_the_first(
    raised: list[tuple[str, object, str, float]],
) -> None:
    bus = EventBus()
    deferred = DeferredListeners(bus, [lambda ev: None], delay=0.0)
    try:
        last = time.monotonic()
        for _ in range(8):  # events 0.05 s apart: never quiet for 0.2 s
            last = time.monotonic()  # read before the event is queued: it is no later
            bus.publish(Event(1.0))
            time.sleep(0.05)
        wait_until(lambda: len(raised) == 2, timeout=10.0)
        assert raised[1][3] - last >= 0.2
    finally:
        deferred.close()


def test_a_thread_that_was_not_granted_real_time_is_never_lowered(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    calls: list[str] = []
    monkeypatch.setattr(deferred_mod, "enter_show_thread",
                        lambda priority: calls.append("enter") and False)
    monkeypatch.setattr(deferred_mod, "leave_show_thread", lambda: calls.append("leave"))
    monkeypatch.setattr(deferred_mod, "IDLE", 0.05)
    bus = EventBus()
    deferred = DeferredListeners(bus, [lambda ev: None], delay=0.0)
    bus.publish(Event(1.0))
    assert deferred.flush(10.0)
    time.sleep(0.2)
    bus.publish(Event(2.0))  # not granted: it asks again with the next batch
    assert deferred.flush(10.0)
    deferred.close()
    assert calls == ["enter", "enter"]


def test_without_realtime_the_thread_is_never_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []
    monkeypatch.setattr(deferred_mod, "enter_show_thread",
                        lambda priority: calls.append("enter") or True)
    bus = EventBus()
    deferred = DeferredListeners(bus, [lambda ev: None], delay=0.0, realtime=False)
    bus.publish(Event(1.0))
    assert deferred.flush(10.0)
    deferred.close()
    assert calls == []


@linux_only
def test_closing_gives_the_timer_back() -> None:
    fds = len(os.listdir("/proc/self/fd"))
    for _ in range(20):
        DeferredListeners(EventBus(), [], realtime=False).close()
    assert len(os.listdir("/proc/self/fd")) <= fds


def _switches(tid: int) -> int:
    """How many times thread ``tid`` of this process went off its CPU (woken and slept)."""
    text = Path(f"/proc/self/task/{tid}/status").read_text(encoding="ascii")
    return sum(int(line.split()[1]) for line in text.splitlines() if "ctxt_switches" in line)


def _asleep(tid: int) -> int:
    """Wait until thread ``tid`` sleeps and stays asleep; its switch count then."""
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        count = _switches(tid)
        time.sleep(0.02)
        status = Path(f"/proc/self/task/{tid}/status").read_text(encoding="ascii")
        if "State:\tS" in status and _switches(tid) == count:
            return count
    raise AssertionError("the bookkeeping thread never went to sleep")


@linux_only
def test_publishing_wakes_nobody_until_the_delay_is_over() -> None:
    # The writer publishes right after its write, while the frame is being delivered: the
    # bookkeeping thread must not wake then (it used to be notified, wake, and sleep again).
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=1.0, realtime=False)
    tid = deferred._thread.native_id
    assert tid is not None
    for _ in range(5):  # a look that came after the delay tells nothing: look again
        got.clear()
        before = _asleep(tid)  # the thread waits for its alarm
        published = time.monotonic()
        bus.publish(Event(1.0))
        bus.publish(Event(2.0))
        time.sleep(0.15)
        switches, seen = _switches(tid), list(got)
        in_time = time.monotonic() - published < 1.0
        wait_until(lambda: len(got) == 2, timeout=10.0)
        if in_time:
            assert switches == before and seen == []
            assert got == [1.0, 2.0] and _switches(tid) > before
            break
    else:
        raise AssertionError("the machine was too busy to look within the delay five times")
    deferred.close()


def _waited(alarm: Alarm) -> tuple[threading.Thread, list[float]]:
    """A thread waiting on ``alarm``; the list gets the time it woke."""
    woke: list[float] = []
    th = threading.Thread(target=lambda: (alarm.wait(), woke.append(time.monotonic())),
                          daemon=True)
    th.start()
    return th, woke


def _alarm(kind: str) -> Alarm:
    """An alarm on the kernel's timer (timerfd, Linux) or the portable way (closed: the
    condition-variable way, as where there is no timerfd)."""
    if kind == "kernel" and not sys.platform.startswith("linux"):
        pytest.skip("timerfd is Linux's")
    alarm = Alarm()
    if kind == "portable":
        alarm.close()
    else:
        assert alarm._kernel is not None
    return alarm


@pytest.mark.parametrize("kind", ["kernel", "portable"])
def test_an_alarm_fires_once_at_the_latest_time_set(kind: str) -> None:
    alarm = _alarm(kind)
    alarm.arm(5.0)
    alarm.arm(0.05)  # replaces the 5 s
    t0 = time.monotonic()
    alarm.wait()
    assert 0.04 <= time.monotonic() - t0 < 4.0
    th, woke = _waited(alarm)  # fired once: the next wait lasts until it is armed again
    time.sleep(1.2)
    assert woke == []
    armed = time.monotonic()
    alarm.arm(0.0)
    th.join(10.0)
    assert woke and woke[0] - armed < 4.0
    alarm.arm(1.2)  # over a second: the whole seconds count too
    t0 = time.monotonic()
    alarm.wait()
    assert 1.19 <= time.monotonic() - t0 < 5.0
    alarm.close()
    alarm.close()  # closing again does nothing


@pytest.mark.parametrize("kind", ["kernel", "portable"])
def test_a_prepared_arming_arms_its_delay_as_arm_does(kind: str) -> None:
    alarm = _alarm(kind)
    arm = alarm.prepared(0.1)
    if kind == "kernel":  # the old value's pointer is NULL: the kernel writes it nowhere
        assert isinstance(arm, functools.partial) and len(arm.args) == 4
        assert arm.args[1] == 0 and arm.args[3] is None
    alarm.arm(5.0)
    t0 = time.monotonic()
    arm()  # replaces the 5 s, as arm(0.1) would
    alarm.wait()
    assert 0.09 <= time.monotonic() - t0 < 4.0
    t0 = time.monotonic()
    arm()  # the same callable, again
    alarm.wait()
    assert 0.09 <= time.monotonic() - t0 < 4.0
    alarm.close()


def test_a_dead_bookkeeping_thread_leaves_writers_arming_the_portable_way() -> None:
    got: list[Event] = []
    bus = EventBus()
    deferred = DeferredListeners(bus, [got.append], delay=0.01, realtime=False)
    deferred.close()  # the thread ends and gives its timerfd back
    assert deferred._alarm._kernel is None
    assert getattr(deferred._arm_delay, "func", None) == deferred._alarm.arm  # not the fd's
    deferred._arm_delay()  # what a late writer's event would do: no system call on a stale fd


def test_the_portable_alarm_wakes_its_waiter_for_a_new_time() -> None:
    alarm = Alarm()
    alarm.close()
    th, woke = _waited(alarm)
    time.sleep(0.05)  # it waits with no time set
    armed = time.monotonic()
    alarm.arm(0.1)
    th.join(10.0)
    assert woke and woke[0] - armed >= 0.1


@pytest.fixture
def lowered(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """When the bookkeeping thread went back to normal priority (raising always granted)."""
    times: list[float] = []
    monkeypatch.setattr(deferred_mod, "enter_show_thread", lambda priority: True)
    monkeypatch.setattr(deferred_mod, "leave_show_thread", lambda: times.append(time.monotonic()))
    return times


def test_the_quiet_spell_counts_the_delay_already_waited(
    lowered: list[float], monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Handed on 0.4 s after the event, the thread waits the rest of IDLE (0.1 s), not IDLE.
    monkeypatch.setattr(deferred_mod, "IDLE", 0.5)
    bus = EventBus()
    deferred = DeferredListeners(bus, [lambda ev: None], delay=0.4)
    try:
        published = time.monotonic()
        bus.publish(Event(1.0))
        wait_until(lambda: lowered, timeout=10.0)
        assert 0.5 <= lowered[0] - published < 1.1
    finally:
        deferred.close()


@linux_only
def test_the_timer_is_not_inherited_by_programs_the_relay_starts() -> None:
    import fcntl

    alarm = Alarm()
    assert alarm._kernel is not None
    try:
        assert fcntl.fcntl(alarm._kernel[0], fcntl.F_GETFD) & fcntl.FD_CLOEXEC
    finally:
        alarm.close()


@linux_only
def test_a_wait_on_a_timer_that_is_gone_raises_rather_than_hangs() -> None:
    alarm = Alarm()
    assert alarm._kernel is not None
    os.close(alarm._kernel[0])  # closed behind its back (a bug elsewhere)
    with pytest.raises(OSError):
        alarm.wait()
    alarm._kernel = None


def test_close_hands_on_at_once_and_gives_a_stuck_listener_two_seconds() -> None:
    bus = EventBus()
    got: list[float] = []
    deferred = DeferredListeners(bus, [lambda ev: got.append(ev.t)], delay=30.0, realtime=False)
    bus.publish(Event(1.0))
    t0 = time.monotonic()
    deferred.close()
    assert got == [1.0] and time.monotonic() - t0 < 0.9  # not after the 30 s delay

    gate, entered = threading.Event(), threading.Event()
    stuck = DeferredListeners(bus, [lambda ev: (entered.set(), gate.wait(30))],
                              delay=0.0, realtime=False)
    try:
        bus.publish(Event(2.0))
        assert entered.wait(10.0)
        t0 = time.monotonic()
        stuck.close()
        assert 2.0 <= time.monotonic() - t0 < 2.9
    finally:
        gate.set()
        stuck._thread.join(10.0)


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_a_flush_notices_the_thread_dying_while_it_waits() -> None:
    bus = EventBus()
    gate, entered = threading.Event(), threading.Event()

    def crash(ev: Event) -> None:
        entered.set()
        gate.wait(30)
        raise _Crash

    deferred = DeferredListeners(bus, [crash], delay=0.0, realtime=False)
    bus.publish(Event(1.0))
    assert entered.wait(10.0)
    threading.Timer(0.05, gate.set).start()
    t0 = time.monotonic()
    assert deferred.flush(timeout=30.0) is False
    assert time.monotonic() - t0 < 0.9  # within its 10 ms polls of the thread, not a second
    deferred.close()
