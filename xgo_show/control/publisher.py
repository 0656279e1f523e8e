"""Publish a running show's events on Zenoh, from a thread of their own.

The listener runs in the runtime's threads (an executor's writer among them), so it only looks
and queues: a frame tells whether a new cue started, a telemetry reading updates the robot's
latest values, anything else worth telling is queued. A publisher thread turns the queue into
JSON puts under ``NS/event/...``. The queue is bounded (the oldest item goes first when full,
counted); progress and telemetry go out at most once per ``progress_interval`` seconds;
refused triggers (a flood of them, say) at most ``refusals_per_second``, the rest counted in a
``warning`` event, so a flood never floods the network in turn.
"""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable
from typing import Any

from xgo_show.compiler.schedule import Schedule
from xgo_show.control.director import TriggerRefused, WaitReleased, WaitStarted
from xgo_show.control.keys import event_key, telemetry_key
from xgo_show.control.protocol import PROTOCOL_VERSION
from xgo_show.control.status import place, robots_status, wall_time
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.events import (
    Event,
    FaultRaised,
    FrameSent,
    ProgressTick,
    SafeStopped,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowSought,
    ShowStarted,
    StateChanged,
    TelemetryRead,
)

__all__ = ["EventPublisher", "Put"]

Put = Callable[[str, dict[str, Any]], None]  # (key, payload dict) -> sent


class EventPublisher:
    """Listens to one show's bus (:meth:`listen`) and publishes through ``put``."""

    def __init__(
        self,
        namespace: str,
        put: Put,
        *,
        clock: Clock,
        maxlen: int = 1024,
        progress_interval: float = 1.0,
        refusals_per_second: int = 10,
    ) -> None:
        self.ns = namespace
        self.put = put
        self.clock = clock
        self.progress_interval = progress_interval
        self.refusals_per_second = refusals_per_second
        self.dropped = 0  # events lost to a full queue
        self.suppressed = 0  # refusals not published (over the rate)
        self._queue: collections.deque[tuple[str, dict[str, Any]]] = collections.deque()
        self._maxlen = maxlen
        self._cond = threading.Condition()
        self._closed = False
        self._schedule: Schedule | None = None
        self._cues: dict[str, str] = {}
        self._readings: dict[str, dict[str, float]] = {}
        self._next_progress = float("-inf")
        self._refusal_window = (float("-inf"), 0)  # (window start, count in it)
        self._pending_suppressed = 0
        self._thread = threading.Thread(target=self._loop, name="xgo-show events", daemon=True)
        self._thread.start()

    def listen(self, schedule: Schedule) -> Callable[[Event], None]:
        """The listener for a show's bus (subscribe it to every event)."""
        self._schedule = schedule
        self._cues = {}
        self._readings = {}
        return self._on_event

    def publish(self, kind: str, **fields: Any) -> None:
        """Queue one event ``NS/event/KIND`` (any thread)."""
        self._enqueue(event_key(self.ns, kind), {"event": kind, **fields})

    def close(self) -> None:
        """Send what is queued (briefly), then stop."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(2.0)

    # ------------------------------------------------------------------ listener

    def _on_event(self, event: Event) -> None:
        if isinstance(event, FrameSent):
            frame = event.frame
            if frame is None or frame.origin is None or not frame.origin.cue:
                return
            cue = frame.origin.cue
            if self._cues.get(event.performer) != cue:
                self._cues[event.performer] = cue
                self.publish("cue", robot=event.performer, cue=cue,
                             show_time=round(event.actual_show, 6))
            return
        if isinstance(event, TelemetryRead):
            self._readings.setdefault(event.performer, {})[event.name] = event.value
            return
        if isinstance(event, ProgressTick):
            now = self.clock.now()
            if now < self._next_progress or self._schedule is None:
                return
            self._next_progress = now + self.progress_interval
            prog = event.progress
            self.publish("progress", duration=round(prog.duration, 6),
                         **place(self._schedule, prog.show_time),
                         robots=robots_status(prog, {}))
            for robot, values in list(self._readings.items()):
                self._enqueue(telemetry_key(self.ns, robot),
                              {"event": "telemetry", "robot": robot, "readings": dict(values)})
            return
        if isinstance(event, TriggerRefused):
            self._refused(event)
            return
        fields = self._describe(event)
        if fields is not None:
            kind = fields.pop("event")
            self.publish(kind, **fields)

    def _describe(self, event: Event) -> dict[str, Any] | None:
        sched = self._schedule
        if isinstance(event, StateChanged):
            return {"event": "state", "robot": event.performer, "state": event.state.value,
                    "show_time": round(event.show_time, 6)}
        if isinstance(event, FaultRaised):
            return {"event": "fault", "robot": event.performer, "reason": event.reason}
        if isinstance(event, SafeStopped):
            r = event.result
            return {"event": "state", "robot": event.performer, "state": "safe_stopped",
                    "ok": r.ok, "reason": r.reason, "error": r.error}
        if isinstance(event, ShowStarted):
            return {"event": "state", "state": "playing", "show": event.show,
                    "offset": round(event.offset, 6)}
        if isinstance(event, ShowPaused):
            return {"event": "state", "state": "paused", "show_time": round(event.show_time, 6)}
        if isinstance(event, ShowResumed):
            return {"event": "state", "state": "playing",
                    "show_time": round(event.show_time, 6)}
        if isinstance(event, ShowSought) and sched is not None:
            return {"event": "state", "state": "seek", **place(sched, event.show_time)}
        if isinstance(event, ShowEnded):
            return {"event": "state", "state": "ended", "completed": event.completed,
                    "reason": event.reason, "faults": dict(event.faults)}
        if isinstance(event, WaitStarted):
            return {"event": "wait", "state": "waiting", "section": event.section,
                    "trigger": event.trigger, "show_time": round(event.show_time, 6),
                    "timeout": event.timeout}
        if isinstance(event, WaitReleased):
            return {"event": "wait", "state": "released", "section": event.section,
                    "trigger": event.trigger, "how": event.how, "goto": event.goto}
        return None

    def _refused(self, event: TriggerRefused) -> None:
        now = self.clock.now()
        start, count = self._refusal_window
        if now - start >= 1.0:
            if self._pending_suppressed:
                self.publish("warning", message=f"{self._pending_suppressed} more refused "
                             "trigger(s) not published in the last second",
                             suppressed=self._pending_suppressed)
                self._pending_suppressed = 0
            start, count = now, 0
        count += 1
        self._refusal_window = (start, count)
        if count > self.refusals_per_second:
            self.suppressed += 1
            self._pending_suppressed += 1
            return
        self.publish("trigger", trigger=event.trigger, accepted=False, reason=event.reason)

    # ------------------------------------------------------------------ publishing

    def _enqueue(self, key: str, payload: dict[str, Any]) -> None:
        payload = {"v": PROTOCOL_VERSION, "time": wall_time(), **payload}
        with self._cond:
            if len(self._queue) >= self._maxlen:
                self._queue.popleft()
                self.dropped += 1
            self._queue.append((key, payload))
            self._cond.notify()

    def _loop(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._closed:
                    self._cond.wait()
                if not self._queue:
                    return
                key, payload = self._queue.popleft()
            try:
                self.put(key, payload)
            except Exception:  # a closed session at shutdown: nothing left to tell anyone
                self.dropped += 1
