"""A relay's show events, carried back to its conductor in heartbeat answers.

Frames never cross the network before they are sent: the relay plays its robots' schedules
itself. What it sent, what its robots answered, and each executor's state changes and faults
go back afterwards, stamped with the relay's own times, so the conductor's report (send-time
errors, bytes, telemetry), run log, timeline and status cover relayed robots as they cover local
ones: a pause or a resume is at the time the relay's executor acted, not when a heartbeat
happened to bring the news. Each heartbeat answer carries the events since the previous one, at
most :data:`MAX_BATCH`; a relay that collects more than :data:`BACKLOG` between two heartbeats
drops the oldest frame or telemetry event and counts them (``dropped``), never a state change
or a fault, and never blocks its writer threads.

Encoded events (JSON arrays, times on the relay's show clock)::

    ["f", performer, kind, index, planned, t, hex, note, planned_show, actual_show]
    ["t", performer, name, value, t]
    ["s", performer, state, show_time, t]
    ["x", performer, reason, t]
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

from xgo_show.runtime.events import (
    Event,
    EventBus,
    FaultRaised,
    FrameSent,
    StateChanged,
    Subscription,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState

__all__ = ["BACKLOG", "MAX_BATCH", "EventCollector", "decode_events"]

MAX_BATCH = 2000
BACKLOG = 20_000


class EventCollector:
    """Collects the frame, telemetry, state and fault events of ``bus`` until :meth:`drain`."""

    def __init__(self, bus: EventBus) -> None:
        self._lock = threading.Lock()
        self._queue: deque[list[Any]] = deque()
        self.dropped = 0
        self._sub: Subscription = bus.subscribe(
            self._on_event, FrameSent, TelemetryRead, StateChanged, FaultRaised
        )

    def _on_event(self, ev: Event) -> None:
        if isinstance(ev, FrameSent):
            row: list[Any] = [
                "f",
                ev.performer,
                ev.kind,
                ev.index,
                ev.planned,
                ev.t,
                ev.data.hex(),
                ev.label if ev.kind != "frame" else "",
                ev.planned_show,
                ev.actual_show,
            ]
        elif isinstance(ev, TelemetryRead):
            row = ["t", ev.performer, ev.name, ev.value, ev.t]
        elif isinstance(ev, StateChanged):
            row = ["s", ev.performer, ev.state.value, ev.show_time, ev.t]
        elif isinstance(ev, FaultRaised):
            row = ["x", ev.performer, ev.reason, ev.t]
        else:
            return
        with self._lock:
            if len(self._queue) >= BACKLOG:
                self._drop_oldest()
            self._queue.append(row)

    def _drop_oldest(self) -> None:
        # The oldest frame or telemetry row: state changes and faults (a few per show) stay.
        for i, row in enumerate(self._queue):
            if row[0] in ("f", "t"):
                del self._queue[i]
                self.dropped += 1
                return

    def drain(self) -> list[list[Any]]:
        """The events collected since the last call (oldest first, at most MAX_BATCH)."""
        with self._lock:
            n = min(len(self._queue), MAX_BATCH)
            return [self._queue.popleft() for _ in range(n)]

    def close(self) -> None:
        self._sub.close()


def decode_events(
    rows: Any, names: Mapping[str, str], to_local: Callable[[float], float]
) -> list[Event]:
    """Events from encoded ``rows``: performers renamed by ``names`` (relay robot -> show
    performer; others skipped) and times mapped by ``to_local``. Malformed rows are skipped."""
    out: list[Event] = []
    if not isinstance(rows, list):
        return out
    for row in rows:
        try:
            if not isinstance(row, list) or row[1] not in names:
                continue
            perf = names[row[1]]
            if row[0] == "f" and len(row) == 10:
                _, _, kind, index, planned, t, data, note, planned_show, actual_show = row
                out.append(
                    FrameSent(
                        to_local(float(t)),
                        perf,
                        str(kind),
                        None if index is None else int(index),
                        None if planned is None else to_local(float(planned)),
                        bytes.fromhex(str(data)),
                        str(note),
                        None if planned_show is None else float(planned_show),
                        float(actual_show),
                    )
                )
            elif row[0] == "t" and len(row) == 5:
                out.append(TelemetryRead(to_local(float(row[4])), perf, str(row[2]), float(row[3])))
            elif row[0] == "s" and len(row) == 5:
                state = ExecutorState(str(row[2]))
                out.append(StateChanged(to_local(float(row[4])), perf, state, float(row[3])))
            elif row[0] == "x" and len(row) == 4:
                out.append(FaultRaised(to_local(float(row[3])), perf, str(row[2])))
        except (TypeError, ValueError, IndexError):
            continue
    return out
