"""The run log: one JSON object per line, everything a show run did and when.

A run log is a subscriber of the runtime's :class:`~xgo_show.runtime.events.EventBus`
(:meth:`RunLog.attach`): it turns each typed event into one record. Record kinds (``"kind"``):

- ``"event"``: ``event`` is one of ``preflight``, ``start``, ``pause``, ``resume``, ``seek``,
  ``fault``, ``safe_stop``, ``end`` (plus free fields such as ``performer`` and ``reason``);
- ``"state"``: a performer changed state: ``performer``, ``state``, ``show_time``, ``t`` (the
  clock time it changed: a relayed robot's is its relay's, converted to this clock);
- ``"frame"``: one frame sent: ``performer``, ``send`` (``frame`` = scheduled, ``reach`` =
  catch-up for a mid-show start or resume, ``read`` = telemetry request, ``rest`` and
  ``stop`` = stop frames, ``set`` = written beside the schedule on request), ``index`` into
  the schedule, ``planned`` and ``actual`` send times in seconds from the show start
  (``planned`` is null for frames the schedule does not hold), ``bytes`` (hex);
- ``"telemetry"``: ``performer``, ``name``, ``value``, ``t``;
- ``"sim"``: final state of a simulated robot (``dry-run`` and ``run --sim``).

Every record carries ``mono``, the monotonic time it was written. Writes are thread-safe and
buffered; events flush so that what led to a fault is on disk even if the process then dies.
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import IO, Any

from xgo_show.closing import Closing
from xgo_show.errors import FileAccessError
from xgo_show.runtime.events import (
    Event,
    EventBus,
    FaultRaised,
    FrameSent,
    PreflightDone,
    RunnerFailed,
    SafeStopped,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
    StateChanged,
    Subscription,
    TelemetryRead,
)

__all__ = ["RunLog", "read_log"]


class RunLog(Closing):
    """A thread-safe JSON-lines writer. ``RunLog(None)`` keeps records in memory only.

    ``keep`` (default: only when there is no file) also keeps every record in
    :attr:`records`, which grows with the show: a log written to a file keeps nothing.
    """

    def __init__(self, path: str | Path | None = None, *, keep: bool | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self._lock = threading.Lock()
        self._file: IO[str] | None = None
        self.records: list[dict[str, Any]] = []
        self._keep = path is None if keep is None else keep
        if self.path is not None:
            try:
                self._file = self.path.open("w", encoding="utf-8")
            except OSError as exc:
                raise FileAccessError(f"cannot write the run log {self.path}: {exc}") from exc

    @property
    def _nowhere(self) -> bool:
        """Whether a record would go nowhere: no file (none given, or closed) and none kept. A
        log that writes nowhere (a relay or run without --log) makes no record at all."""
        return self._file is None and not self._keep

    def write(self, kind: str, *, flush: bool = False, **fields: Any) -> None:
        """Append one record."""
        if self._nowhere:
            return
        record: dict[str, Any] = {"kind": kind, "mono": round(time.monotonic(), 6), **fields}
        line = json.dumps(record, default=str)
        with self._lock:
            if self._keep:
                self.records.append(record)
            if self._file is not None:
                self._file.write(line + "\n")
                if flush:
                    self._file.flush()

    def event(self, event: str, **fields: Any) -> None:
        """Append an event record and flush it to disk."""
        self.write("event", flush=True, event=event, **fields)

    def attach(self, bus: EventBus) -> Subscription:
        """Write a record for every event published on ``bus`` from now on."""
        return bus.subscribe(self.on_event)

    def on_event(self, ev: Event) -> None:
        """One runtime event -> one record (progress ticks are not logged)."""
        if self._nowhere:
            # Not even the record's fields: on a relay this ran for every frame, 4 ms after its
            # write, at real-time priority.
            return
        if isinstance(ev, FrameSent):
            self.write(
                "frame",
                performer=ev.performer,
                send=ev.kind,
                index=ev.index,
                planned=None if ev.planned_show is None else round(ev.planned_show, 6),
                actual=round(ev.actual_show, 6),
                bytes=ev.data.hex(),
            )
        elif isinstance(ev, TelemetryRead):
            self.write("telemetry", performer=ev.performer, name=ev.name, value=ev.value, t=ev.t)
        elif isinstance(ev, StateChanged):
            self.write(
                "state",
                performer=ev.performer,
                state=ev.state.value,
                show_time=round(ev.show_time, 6),
                t=round(ev.t, 6),  # when it changed (a relayed robot's comes back later)
            )
        elif isinstance(ev, FaultRaised):
            self.event("fault", performer=ev.performer, reason=ev.reason, t=round(ev.t, 6))
        elif isinstance(ev, SafeStopped):
            r = ev.result
            self.event(
                "safe_stop",
                performer=ev.performer,
                reason=r.reason,
                ok=r.ok,
                frames=list(r.frames),
                error=r.error,
                elapsed_ms=round(r.elapsed * 1000, 3),
            )
        elif isinstance(ev, PreflightDone):
            self.event("preflight", forced=ev.forced, **ev.report.as_record())
        elif isinstance(ev, ShowStarted):
            self.event(
                "start",
                show=ev.show,
                offset=ev.offset,
                start_at=round(ev.start_at, 6),
                performers=list(ev.performers),
                on_failure=ev.on_failure,
                battery_floor=ev.battery_floor,
            )
        elif isinstance(ev, ShowPaused):
            self.event("pause", show_time=round(ev.show_time, 6))
        elif isinstance(ev, ShowResumed):
            self.event("resume", show_time=round(ev.show_time, 6))
        elif isinstance(ev, ShowSought):
            self.event("seek", show_time=round(ev.show_time, 6), at=round(ev.at, 6))
        elif isinstance(ev, RunnerFailed):
            self.event("exception", error=ev.error, type=ev.type)
        elif isinstance(ev, ShowEnded):
            self.event(
                "end",
                completed=ev.completed,
                reason=ev.reason,
                faults=dict(ev.faults),
                states=dict(ev.states),
                stop_latency_ms=(
                    None if ev.stop_latency is None else round(ev.stop_latency * 1000, 3)
                ),
            )

    def events(self, name: str | None = None) -> list[dict[str, Any]]:
        """The event records kept in memory, optionally only those named ``name``."""
        with self._lock:
            return [
                r
                for r in self.records
                if r["kind"] == "event" and (name is None or r["event"] == name)
            ]

    def close(self) -> None:
        with self._lock:
            if self._file is not None:
                self._file.close()
                self._file = None




def read_log(path: str | Path) -> list[dict[str, Any]]:
    """Read a run log back (one dict per line)."""
    with Path(path).open(encoding="utf-8") as fh:
        return [json.loads(line) for line in fh if line.strip()]
