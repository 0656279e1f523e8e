"""The telemetry poller's cadence: watched items on their own period, the rest in rotation;
and an executor that leaves reading the port to its owner."""

from __future__ import annotations

import itertools
import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st

from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import EventRecorder, TelemetryRead
from xgo_show.runtime.executor import PerformerExecutor
from xgo_show.runtime.telemetry import TelemetryPoller, TelemetrySample
from xgo_show.sim import create_robot
from xgo_show.transports.sim import SimTransport
from xgo_show.wire.xgo import reply_frame

RIDER = get_profile("rider")


def _poll(poller: TelemetryPoller, until: float, step: float) -> list[tuple[float, str]]:
    """Send every request as soon as it is due, checking every ``step`` seconds."""
    sent: list[tuple[float, str]] = []
    t = 0.0
    while t < until:
        item = poller.due(t)
        if item is not None:
            poller.sent(t)
            sent.append((t, item.name))
        else:
            t += step
    return sent


def test_watched_items_are_read_on_their_own_period_and_the_rest_rotate() -> None:
    poller = TelemetryPoller(RIDER, interval=0.25, watch={"status": 0.02, "nonesuch": 0.01})
    assert poller.watch == {"status": 0.02}  # an item the model lacks is left out
    sent = _poll(poller, 1.0, 0.001)
    status = [t for t, name in sent if name == "status"]
    gaps = [b - a for a, b in itertools.pairwise(status)]
    assert len(status) >= 45 and max(gaps) < 0.0215
    others = [name for _, name in sent if name != "status"]
    assert others[:4] == ["battery", "attitude", "battery", "attitude"]
    assert len(others) == 4  # one every 0.25 s: at 0, 0.25, 0.5, 0.75


def test_without_watch_the_items_rotate_as_before() -> None:
    poller = TelemetryPoller(RIDER, interval=0.1)
    names = [name for _, name in _poll(poller, 0.6, 0.001)]
    assert names == ["battery", "status", "attitude"] * 2


@given(st.lists(st.floats(0.0, 0.05), min_size=1, max_size=40))
def test_next_due_is_when_due_first_answers(steps: list[float]) -> None:
    poller = TelemetryPoller(RIDER, interval=0.05, watch={"status": 0.02})
    t = 0.0
    for step in steps:
        t += step
        if poller.due(t) is not None:
            poller.sent(t)
        nxt = poller.next_due
        assert poller.due(nxt) is not None
        assert nxt <= t or poller.due(nxt - 1e-6) is None


def test_an_executor_that_does_not_read_the_port_takes_bytes_from_its_owner() -> None:
    from xgo_show.compiler.schedule import PerformerSchedule

    link = SimTransport(create_robot("rider"))
    link.open()
    idle = PerformerSchedule("rio", "rider", RIDER.link, (), 0.0)
    ex = PerformerExecutor(idle, link, clock=FakeClock(), profile=RIDER,
                           telemetry=TelemetryPoller(RIDER), read_port=False)
    rec = EventRecorder(ex.events)
    before = threading.active_count()
    ex._start_reader()
    assert threading.active_count() == before  # no reader thread of its own
    status = RIDER.register("status").address
    assert ex.received(reply_frame(status, b"\x01"), 1.0)
    reads = [e for e in rec.events if isinstance(e, TelemetryRead)]
    assert [(e.name, e.value, e.t) for e in reads] == [("status", 1.0, 1.0)]
    assert not ex.received(reply_frame(status, b"\x00"), 2.0)  # fallen: a fault
    assert ex.fault is not None and "fallen" in ex.fault
    ex.port_failed("port gone")  # already failed: the first fault stands
    assert "fallen" in ex.fault
    other = PerformerExecutor(idle, link, clock=FakeClock(), profile=RIDER,
                              telemetry=TelemetryPoller(RIDER), read_port=False)
    other.port_failed("port gone")
    assert other.fault == "port gone"


def _reply(name: str, byte: int) -> bytes:
    return reply_frame(RIDER.register(name).address, bytes((byte,)))


def test_replies_become_samples_and_other_frames_are_counted() -> None:
    poller = TelemetryPoller(RIDER)
    assert poller.enabled and [i.name for i in poller.items] == ["battery", "status", "attitude"]
    both = _reply("battery", 87) + _reply("status", 1)
    samples = poller.feed(both[:7], 1.0)  # half a frame: nothing yet
    assert samples == []
    samples = poller.feed(both[7:], 1.5)
    assert samples == [TelemetrySample("battery", 87.0, 1.5), TelemetrySample("status", 1.0, 1.5)]
    assert poller.last == {"battery": 87.0, "status": 1.0} and poller.samples == 2
    # A reply at an address nobody asked for (the Rider's auto-feedback, say) is not a sample,
    # and the replies after it in the same bytes still are.
    assert poller.feed(_reply("show_mode", 1), 2.0) == []
    assert poller.unsolicited == 1 and poller.samples == 2 and poller.fault is None
    samples = poller.feed(_reply("show_mode", 0) + _reply("battery", 86), 2.5)
    assert samples == [TelemetrySample("battery", 86.0, 2.5)]
    assert poller.unsolicited == 2 and poller.samples == 3


def test_a_low_battery_is_a_fault_on_the_second_reading_in_a_row() -> None:
    poller = TelemetryPoller(RIDER, battery_floor=30)
    poller.feed(_reply("battery", 25), 1.0)
    assert poller.fault is None  # one low reading: a load spike, perhaps
    poller.feed(_reply("battery", 40), 2.0)  # back up: the count starts again
    poller.feed(_reply("battery", 25), 3.0)
    assert poller.fault is None
    poller.feed(_reply("battery", 30), 3.5)  # at the floor is not below it
    poller.feed(_reply("battery", 25), 4.0)
    assert poller.fault is None
    poller.feed(_reply("battery", 29), 5.0)
    assert poller.fault is not None and "29" in poller.fault and "30" in poller.fault
    first = poller.fault
    poller.feed(_reply("status", 0), 6.0)  # fallen too: the first fault stands
    assert poller.fault == first


def test_low_readings_sets_how_many_in_a_row_make_a_fault() -> None:
    once = TelemetryPoller(RIDER, battery_floor=30, low_readings=1)
    once.feed(_reply("battery", 29), 1.0)
    assert once.fault is not None
    thrice = TelemetryPoller(RIDER, battery_floor=30, low_readings=3)
    for t in (1.0, 2.0):
        thrice.feed(_reply("battery", 10), t)
    assert thrice.fault is None
    thrice.feed(_reply("battery", 10), 3.0)
    assert thrice.fault is not None
    no_floor = TelemetryPoller(RIDER)
    for t in (1.0, 2.0, 3.0):
        no_floor.feed(_reply("battery", 1), t)
    assert no_floor.fault is None  # without a floor the battery is only reported


def test_a_fall_is_a_fault_unless_a_listener_handles_it() -> None:
    show = TelemetryPoller(RIDER, battery_floor=30)
    show.feed(_reply("status", 0), 1.0)
    assert show.fault is not None and "fallen" in show.fault
    behaviour = TelemetryPoller(RIDER, battery_floor=30, detect_falls=False)
    samples = behaviour.feed(_reply("status", 0), 1.0)
    assert behaviour.fault is None and samples == [TelemetrySample("status", 0.0, 1.0)]
    behaviour.feed(_reply("battery", 5), 2.0)
    behaviour.feed(_reply("battery", 5), 3.0)
    assert behaviour.fault is not None and "fallen" not in behaviour.fault  # still the battery


def test_the_first_request_is_due_at_once_and_the_next_after_the_interval() -> None:
    poller = TelemetryPoller(RIDER, interval=0.5)
    assert poller.next_due == float("-inf")
    assert poller.due(0.0) is not None
    assert poller.due(0.0) is not None  # asking again without sending changes nothing
    poller.sent(0.0)
    assert poller.next_due == 0.5 and poller.due(0.49) is None
    item = poller.due(0.5)
    assert item is not None and item.name == "status"
    poller.sent(0.6)  # it went out late: the next is an interval after it went out
    assert poller.next_due == pytest.approx(1.1)
    # Every item watched: nothing rotates, and each is due at once.
    watched = TelemetryPoller(RIDER, watch={"status": 0.02, "battery": 0.1, "attitude": 0.1})
    assert watched.next_due == float("-inf")
    for _ in range(3):
        assert watched.due(0.0) is not None
        watched.sent(0.0)
    assert watched.due(0.0) is None and watched.next_due == pytest.approx(0.02)


def test_by_default_one_item_is_read_every_quarter_second() -> None:
    # docs/behaviours.md: the items not watched are read "in rotation every 0.25 s".
    poller = TelemetryPoller(RIDER)
    names = [name for _, name in _poll(poller, 1.0, 0.001)]
    assert names == ["battery", "status", "attitude", "battery"]
    assert poller.next_due == pytest.approx(1.0)
