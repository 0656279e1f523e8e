"""The event bus: listeners, kinds, bounded channels and their overflow policies."""

from __future__ import annotations

import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st

from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.runtime.events import (
    EventBus,
    EventChannel,
    EventRecorder,
    FaultRaised,
    FrameSent,
    ShowPaused,
    TelemetryRead,
)


def _reading(i: int) -> TelemetryRead:
    return TelemetryRead(float(i), "rex", "battery", float(i))


def test_listeners_get_the_kinds_they_asked_for_in_subscription_order() -> None:
    bus = EventBus()
    seen: list[tuple[str, object]] = []
    bus.subscribe(lambda e: seen.append(("all", e)))
    bus.subscribe(lambda e: seen.append(("faults", e)), FaultRaised)
    fault = FaultRaised(1.0, "rex", "port gone")
    pause = ShowPaused(2.0, 3.5)
    bus.publish(fault)
    bus.publish(pause)
    assert seen == [("all", fault), ("faults", fault), ("all", pause)]


def test_a_listener_of_other_kinds_does_not_stop_the_ones_after_it() -> None:
    bus = EventBus()
    seen: list[object] = []
    bus.subscribe(seen.append, FaultRaised)
    bus.subscribe(seen.append)
    bus.publish(_reading(1))
    assert seen == [_reading(1)]
    assert bus.listener_errors == 0 and bus.last_listener_error is None


def test_a_channel_of_its_own_drops_the_oldest_and_closes_without_a_bus() -> None:
    ch = EventChannel(2)
    assert ch.overflow == "drop_oldest" and ch.subscription is None
    for i in range(3):
        ch.put(_reading(i))
    assert ch.drain() == [_reading(1), _reading(2)] and ch.dropped == 1
    ch.close()  # never subscribed: nothing to close


def test_a_closed_subscription_hears_nothing_more() -> None:
    bus = EventBus()
    seen: list[object] = []
    with bus.subscribe(seen.append):
        bus.publish(_reading(1))
    bus.publish(_reading(2))
    assert seen == [_reading(1)]


def test_a_failing_listener_is_counted_and_the_others_still_hear() -> None:
    bus = EventBus()
    seen: list[object] = []

    def broken(event: object) -> None:
        raise ValueError("no")

    bus.subscribe(broken)
    bus.subscribe(seen.append)
    bus.publish(_reading(1))
    assert seen == [_reading(1)]
    assert bus.listener_errors == 1 and isinstance(bus.last_listener_error, ValueError)


@given(st.integers(1, 20), st.integers(0, 60))
def test_drop_oldest_keeps_the_latest_events(maxlen: int, n: int) -> None:
    bus = EventBus()
    ch = bus.channel(maxlen, overflow="drop_oldest")
    for i in range(n):
        bus.publish(_reading(i))
    kept = ch.drain()
    assert [e.t for e in kept] == [float(i) for i in range(max(0, n - maxlen), n)]
    assert ch.dropped == max(0, n - maxlen)


@given(st.integers(1, 20), st.integers(0, 60))
def test_drop_newest_keeps_the_first_events(maxlen: int, n: int) -> None:
    bus = EventBus()
    ch = bus.channel(maxlen, overflow="drop_newest")
    for i in range(n):
        bus.publish(_reading(i))
    assert [e.t for e in ch.drain()] == [float(i) for i in range(min(n, maxlen))]
    assert ch.dropped == max(0, n - maxlen)


def test_a_channel_wakes_its_consumer_and_times_out_when_empty() -> None:
    bus = EventBus()
    ch = bus.channel(4, TelemetryRead)
    assert ch.get(timeout=0.01) is None
    got: list[object] = []
    consumer = threading.Thread(target=lambda: got.append(ch.get(timeout=5)))
    consumer.start()
    bus.publish(FaultRaised(0.0, "rex", "ignored: not a kind the channel wants"))
    bus.publish(_reading(7))
    consumer.join(5)
    assert got == [_reading(7)]
    ch.close()
    bus.publish(_reading(8))
    assert len(ch) == 0


def test_a_channel_refuses_nonsense_sizes_and_policies() -> None:
    with pytest.raises(ValueError, match=r"^a channel holds at least one event$"):
        EventChannel(0)
    with pytest.raises(ValueError, match="unknown overflow policy"):
        EventChannel(3, overflow="block")  # type: ignore[arg-type]


def test_events_are_frozen() -> None:
    event = _reading(1)
    with pytest.raises(AttributeError):
        event.value = 2.0  # type: ignore[misc]


def test_a_frame_sent_says_when_how_late_and_what() -> None:
    frame = ScheduledFrame(2.0, b"\x55\x00\x09", labels=lambda data: f"{len(data)} bytes")
    late = FrameSent(2.0015, "rex", "frame", 4, 2.0, frame.data, "", 2.0, 2.0015, frame)
    assert late.actual == 2.0015 and late.nbytes == 3
    assert late.error == pytest.approx(0.0015)
    assert late.label == "3 bytes"  # a scheduled frame's label comes from its bytes
    early = FrameSent(1.999, "rex", "frame", 4, 2.0, frame.data, "", 2.0, 1.999, frame)
    assert early.error == pytest.approx(-0.001)
    rest = FrameSent(5.0, "rex", "rest", None, None, b"\x55\x00", "vx=0", None, 5.0)
    assert rest.error is None and rest.label == "vx=0" and rest.nbytes == 2


def test_closing_one_subscription_leaves_the_others() -> None:
    bus = EventBus()
    first: list[object] = []
    second: list[object] = []
    a = bus.subscribe(first.append)
    bus.subscribe(second.append)
    c = bus.subscribe(first.append)  # the same listener twice: two subscriptions
    a.close()
    bus.publish(_reading(1))
    assert first == [_reading(1)] and second == [_reading(1)]
    c.close()
    c.close()  # closing again is harmless
    bus.publish(_reading(2))
    assert first == [_reading(1)] and second == [_reading(1), _reading(2)]


def test_a_listener_error_is_the_latest_one() -> None:
    bus = EventBus()
    errors = iter([KeyError("first"), RuntimeError("second")])

    def broken(event: object) -> None:
        raise next(errors)

    bus.subscribe(broken)
    bus.publish(_reading(1))
    bus.publish(_reading(2))
    assert bus.listener_errors == 2 and isinstance(bus.last_listener_error, RuntimeError)


def test_a_channel_hands_out_oldest_first_and_iterates_by_draining() -> None:
    bus = EventBus()
    ch = bus.channel(8)
    assert ch.maxlen == 8 and ch.overflow == "drop_oldest" and ch.dropped == 0
    for i in range(3):
        bus.publish(_reading(i))
    assert len(ch) == 3
    assert ch.get(timeout=0) == _reading(0)  # waits for nothing when one is queued
    assert ch.get() == _reading(1)
    assert list(ch) == [_reading(2)] and len(ch) == 0
    assert ch.drain() == []
    ch.close()
    ch.close()  # closing again is harmless
    assert ch.subscription is None


def test_a_recorder_keeps_every_event_in_order_and_filters_frames() -> None:
    bus = EventBus()
    everything = EventRecorder(bus)
    faults = EventRecorder(bus, FaultRaised)
    rex = FrameSent(1.0, "rex", "frame", 0, 1.0, b"\x01", "", 1.0, 1.0)
    fido = FrameSent(1.1, "fido", "read", None, None, b"\x02", "battery", None, 1.1)
    fault = FaultRaised(1.2, "rex", "port gone")
    for event in (rex, _reading(1), fido, fault):
        bus.publish(event)
    assert everything.events == [rex, _reading(1), fido, fault]
    assert everything.sent() == [rex, fido]
    assert everything.sent("fido") == [fido] and everything.sent("spot") == []
    assert faults.events == [fault] and faults.sent() == []
    everything.close()
    bus.publish(_reading(2))
    assert len(everything.events) == 4
