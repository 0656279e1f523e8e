"""The event bus: listeners, kinds, bounded channels and their overflow policies."""

from __future__ import annotations

import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st

from xgo_show.runtime.events import (
    EventBus,
    EventChannel,
    FaultRaised,
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
    with pytest.raises(ValueError, match="at least one"):
        EventChannel(0)
    with pytest.raises(ValueError, match="unknown overflow policy"):
        EventChannel(3, overflow="block")  # type: ignore[arg-type]


def test_events_are_frozen() -> None:
    event = _reading(1)
    with pytest.raises(AttributeError):
        event.value = 2.0  # type: ignore[misc]
