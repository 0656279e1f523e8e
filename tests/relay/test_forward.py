"""A relay's show events carried back to its conductor (relay/forward.py), in-process: what the
collector keeps, in which order and how much, and what the conductor makes of the rows."""

from __future__ import annotations

import json

import pytest

from xgo_show.compiler.schedule import ScheduledFrame
from xgo_show.relay.forward import BACKLOG, MAX_BATCH, EventCollector, decode_events
from xgo_show.runtime.events import (
    Event,
    EventBus,
    FaultRaised,
    FrameSent,
    ShowPaused,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState


def frame(t: float, kind: str = "frame", *, note: str = "", index: int | None = 3,
          planned: float | None = None, planned_show: float | None = 1.25,
          performer: str = "rex") -> FrameSent:
    return FrameSent(t, performer, kind, index, planned, b"\x55\x00\x09", note, planned_show,
                     2.5)


def wire(rows: list[list[object]]) -> list[list[object]]:
    """The rows as the conductor receives them: through JSON."""
    return json.loads(json.dumps(rows))  # type: ignore[no-any-return]


def shift(t: float) -> float:
    return t + 100.0


def test_every_kind_of_event_comes_back_renamed_and_on_the_conductors_clock() -> None:
    bus = EventBus()
    collector = EventCollector(bus)
    sent = [
        frame(1.0, planned=0.9),
        frame(1.1, "stop", note="safe stop", index=None, planned=None, planned_show=None),
        TelemetryRead(1.2, "rex", "battery", 87.5),
        StateChanged(1.3, "rex", ExecutorState.PAUSED, 4.75),
        FaultRaised(1.4, "rex", "port closed"),
    ]
    for event in sent:
        bus.publish(event)
    got = decode_events(wire(collector.drain()), {"rex": "dog"}, shift)
    assert got == [
        FrameSent(101.0, "dog", "frame", 3, 100.9, b"\x55\x00\x09", "", 1.25, 2.5),
        FrameSent(101.1, "dog", "stop", None, None, b"\x55\x00\x09", "safe stop", None, 2.5),
        TelemetryRead(101.2, "dog", "battery", 87.5),
        StateChanged(101.3, "dog", ExecutorState.PAUSED, 4.75),
        FaultRaised(101.4, "dog", "port closed"),
    ]
    assert collector.drain() == []  # drained once
    assert collector.dropped == 0


def test_a_scheduled_frame_travels_without_its_label_and_other_frames_with_their_note() -> None:
    bus = EventBus()
    collector = EventCollector(bus)
    scheduled = ScheduledFrame(0.5, b"\x01", labels=lambda data: "cue wave")
    assert scheduled.label == "cue wave"
    bus.publish(FrameSent(1.0, "rex", "frame", 0, 1.0, b"\x01", "", 0.5, 0.5, scheduled))
    bus.publish(frame(1.1, "reach", note="catch-up"))
    rows = collector.drain()
    # The conductor has the schedule: a scheduled frame's label is found there, not sent.
    assert [row[7] for row in rows] == ["", "catch-up"]
    assert [row[0] for row in rows] == ["f", "f"]


def test_other_events_are_not_collected_and_closing_stops_collecting() -> None:
    bus = EventBus()
    collector = EventCollector(bus)
    bus.publish(ShowPaused(1.0, 2.0))
    assert collector.drain() == []
    bus.publish(frame(1.0))
    collector.close()
    bus.publish(frame(2.0))
    assert [row[5] for row in collector.drain()] == [1.0]


def test_a_drain_gives_at_most_a_batch_oldest_first() -> None:
    bus = EventBus()
    collector = EventCollector(bus)
    for i in range(MAX_BATCH + 5):
        bus.publish(TelemetryRead(float(i), "rex", "battery", 50.0))
    first = collector.drain()
    assert [row[4] for row in first] == [float(i) for i in range(MAX_BATCH)]
    assert [row[4] for row in collector.drain()] == [float(MAX_BATCH + i) for i in range(5)]
    assert collector.drain() == []


def test_a_full_backlog_drops_the_oldest_frames_never_a_state_change_or_a_fault() -> None:
    bus = EventBus()
    collector = EventCollector(bus)
    bus.publish(StateChanged(0.0, "rex", ExecutorState.RUNNING, 0.0))
    bus.publish(FaultRaised(0.5, "rex", "overheat"))
    for i in range(BACKLOG - 2):  # exactly full
        bus.publish(frame(1.0 + i))
    assert collector.dropped == 0
    bus.publish(TelemetryRead(1e6, "rex", "battery", 10.0))
    bus.publish(frame(2e6))
    assert collector.dropped == 2
    rows: list[list[object]] = []
    while batch := collector.drain():
        rows += batch
    assert len(rows) == BACKLOG
    assert [row[0] for row in rows[:3]] == ["s", "x", "f"]
    assert rows[2][5] == 3.0  # frames at 1.0 and 2.0 dropped, the oldest first
    assert rows[-2] == ["t", "rex", "battery", 10.0, 1e6]
    assert rows[-1][0] == "f" and rows[-1][5] == 2e6


def test_a_full_backlog_drops_telemetry_too_the_oldest_first() -> None:
    bus = EventBus()
    collector = EventCollector(bus)
    bus.publish(StateChanged(0.0, "rex", ExecutorState.RUNNING, 0.0))
    bus.publish(TelemetryRead(0.5, "rex", "battery", 80.0))
    for i in range(BACKLOG - 2):
        bus.publish(frame(1.0 + i))
    bus.publish(frame(1e6))
    assert collector.dropped == 1
    first = collector.drain()
    assert [row[0] for row in first[:2]] == ["s", "f"]  # the telemetry row went, not a frame
    assert first[1][5] == 1.0


def test_a_backlog_of_state_changes_only_keeps_growing() -> None:
    # Nothing droppable: state changes and faults are all kept (a few per show in practice).
    bus = EventBus()
    collector = EventCollector(bus)
    for i in range(BACKLOG + 3):
        bus.publish(StateChanged(float(i), "rex", ExecutorState.RUNNING, 0.0))
    assert collector.dropped == 0
    total = 0
    while batch := collector.drain():
        total += len(batch)
    assert total == BACKLOG + 3


GOOD: list[object] = ["t", "rex", "battery", 50.0, 1.0]


@pytest.mark.parametrize(
    "bad",
    [
        "t",  # not a list
        ["t", "rex", "battery", 50.0],  # short
        ["t", "rex", "battery", 50.0, 1.0, 2.0],  # long
        ["f", "rex", "frame", 1, 1.0, 1.0, "55", "", 1.0],  # a frame row one short
        ["f", "rex", "frame", 1, 1.0, 1.0, "zz", "", 1.0, 1.0],  # not hex
        ["f", "rex", "frame", "one", 1.0, 1.0, "55", "", 1.0, 1.0],  # index not a number
        ["f", "rex", "frame", 1, 1.0, 1.0, "55", "", 1.0, None],  # no actual show time
        ["s", "rex", "dancing", 1.0, 1.0],  # no such state
        ["s", "rex", "paused", 1.0],  # short
        ["x", "rex", "fault"],  # short
        ["x", "rex", "fault", "soon"],  # not a time
        ["t", "rex", "battery", "full", 1.0],  # not a value
        ["q", "rex", "battery", 50.0, 1.0],  # no such kind
        ["q", "rex", "paused", 1.0, 1.0],  # no such kind, a state change's fields
        ["q", "rex", "frame", 1, 1.0, 1.0, "55", "", 1.0, 1.0],  # no such kind, a frame's
        ["t", "rex", "frame", 1, 1.0, 1.0, "55", "", 1.0, 1.0],  # a frame's fields
        ["t", "nobody", "battery", 50.0, 1.0],  # not a robot of this show
        ["t"],  # no performer
    ],
)
def test_a_malformed_row_is_skipped_and_the_rest_kept(bad: object) -> None:
    got = decode_events([GOOD, bad, GOOD], {"rex": "dog"}, shift)
    assert got == [TelemetryRead(101.0, "dog", "battery", 50.0)] * 2


@pytest.mark.parametrize("rows", [None, {"t": 1}, "rows", 3])
def test_rows_that_are_not_a_list_give_no_events(rows: object) -> None:
    assert decode_events(rows, {"rex": "dog"}, shift) == []


def test_each_kind_of_row_decodes_its_own_fields() -> None:
    rows = [
        ["f", "rex", "read", None, None, 7.0, "0a0b", "battery?", None, 3.0],
        ["s", "rex", "stopped", 9.5, 8.0],
        ["x", "rex", "link lost", 8.5],
    ]
    events: list[Event] = decode_events(rows, {"rex": "dog"}, shift)
    assert events == [
        FrameSent(107.0, "dog", "read", None, None, b"\x0a\x0b", "battery?", None, 3.0),
        StateChanged(108.0, "dog", ExecutorState.STOPPED, 9.5),
        FaultRaised(108.5, "dog", "link lost"),
    ]
