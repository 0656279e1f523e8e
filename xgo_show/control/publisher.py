"""Publish a running show's events on Zenoh, from a thread of their own.

The listener runs in the runtime's threads (an executor's writer among them), so it only looks
and queues: a frame tells whether a new cue started, a telemetry reading updates the robot's
latest values, anything else worth telling is queued. A publisher thread turns the queue into
JSON puts under ``NS/event/...``. The queue is bounded (the oldest item goes first when full,
counted); progress and telemetry go out at most once per ``progress_interval`` seconds.
Noisy events, those a client can cause at will (a refused trigger, a malformed one dropped),
go out at most ``noisy_per_second`` a second: the rest are counted, and one ``warning`` event
says how many were left out once the second is over, so a flood of triggers never floods the
network in turn.
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
        noisy_per_second: int = 10,
        window: float = 1.0,
    ) -> None:
        self.ns = namespace
        self.put = put
        self.clock = clock
        self.progress_interval = progress_interval
        self.noisy_per_second = noisy_per_second
        self.window = window  # seconds over which noisy_per_second counts
        self.dropped = 0  # events lost to a full queue
        self.suppressed = 0  # noisy events not published (over the rate)
        self._queue: collections.deque[tuple[str, dict[str, Any]]] = collections.deque()
        self._maxlen = maxlen
        self._cond = threading.Condition()
        self._closed = False
        self._schedule: Schedule | None = None
        self._cues: dict[str, str] = {}
        self._readings: dict[str, dict[str, float]] = {}
        self._next_progress = float("-inf")
        self._noisy_start = float("-inf")  # the current window's start
        self._noisy_count = 0  # noisy events in it (published or not)
        self._pending_suppressed = 0  # left out in it: said in a warning when it ends
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

    def publish_noisy(self, kind: str, **fields: Any) -> bool:
        """Queue an event a client can cause at will, within the rate (see the module
        docstring); False when it was left out and counted instead."""
        now = self.clock.now()
        with self._cond:
            self._roll(now)
            self._noisy_count += 1
            if self._noisy_count > self.noisy_per_second * self.window:
                self.suppressed += 1
                self._pending_suppressed += 1
                self._cond.notify()  # the publisher thread says so when the window ends
                return False
        self.publish(kind, **fields)
        return True

    def _roll(self, now: float) -> None:
        """Start a new window if the current one is over, saying what the last left out.
        Holds ``_cond``."""
        if now - self._noisy_start < self.window:
            return
        if self._pending_suppressed:
            n, self._pending_suppressed = self._pending_suppressed, 0
            self._append(event_key(self.ns, "warning"), {
                "event": "warning", "suppressed": n,
                "message": f"{n} refused or malformed trigger(s) not published in the last "
                f"{self.window:g} s",
            })
        self._noisy_start, self._noisy_count = now, 0

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
            self.publish_noisy("trigger", trigger=event.trigger, accepted=False,
                               reason=event.reason)
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

    # ------------------------------------------------------------------ publishing

    def _enqueue(self, key: str, payload: dict[str, Any]) -> None:
        with self._cond:
            self._append(key, payload)
            self._cond.notify()

    def _append(self, key: str, payload: dict[str, Any]) -> None:
        """Queue one event (holds ``_cond``); a full queue loses its oldest, counted."""
        if len(self._queue) >= self._maxlen:
            self._queue.popleft()
            self.dropped += 1
        self._queue.append((key, {"v": PROTOCOL_VERSION, "time": wall_time(), **payload}))

    def _loop(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._closed:
                    if self._pending_suppressed:  # say so when the window ends
                        left = self._noisy_start + self.window - self.clock.now()
                        if left <= 0:
                            self._roll(self.clock.now())
                            continue
                        self._cond.wait(left)
                    else:
                        self._cond.wait()
                if not self._queue:
                    return
                key, payload = self._queue.popleft()
            try:
                self.put(key, payload)
            except Exception:  # a closed session at shutdown: nothing left to tell anyone
                self.dropped += 1
