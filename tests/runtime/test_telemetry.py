"""The telemetry poller's cadence: watched items on their own period, the rest in rotation;
and an executor that leaves reading the port to its owner."""

from __future__ import annotations

import threading

from hypothesis import given
from hypothesis import strategies as st

from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import EventRecorder, TelemetryRead
from xgo_show.runtime.executor import PerformerExecutor
from xgo_show.runtime.telemetry import TelemetryPoller
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
    gaps = [b - a for a, b in zip(status, status[1:], strict=False)]
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
