"""A behaviour's stage on a relay: the relay's robots react to a remote behaviour's rules.

``xgo-show behave`` runs the rules; a relay hosts the part that must be near the robots: one
:class:`~xgo_show.behave.ports.PortStage` over the relay's open ports (the same seats as a local
behaviour: one writer and one reader per port, telemetry watched between routines, a pre-empted
routine handed over through rest and the default posture). The conductor uploads every routine
and ``set``/``led`` action the behaviour can play at start-up (``stage_upload``, checked like a
show upload, kept by SHA-256), opens the stage (``stage_open``: the robots start being watched)
and then names a routine by its hash and a time (``stage_play``), or rests, safe-stops or writes
(:mod:`xgo_show.net.messages` lists the fields).

What goes back rides on the heartbeat answers the relay already sends: the telemetry readings
and frames (as for a show, :mod:`xgo_show.relay.forward`), and ``stage.ended``: the plays whose
routine ran to its end since the last answer. The stage closes when its conductor releases the
relay or goes silent for the watchdog time; then every robot is safe-stopped.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Mapping, Sequence
from typing import Any

from xgo_show.behave.ports import PortStage
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import RelayRefused
from xgo_show.net import messages as msg
from xgo_show.relay.robots import OwnedRobot
from xgo_show.relay.validate import validate_upload
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.events import Event, EventBus, StateChanged
from xgo_show.runtime.executor import ExecutorState

__all__ = ["MAX_SCHEDULES", "STAGE_OPS", "StageHost"]

#: Most schedules one behaviour may upload to a relay (routines, phrases, set/led actions).
MAX_SCHEDULES = 512
#: The relay commands a :class:`StageHost` answers.
STAGE_OPS = ("stage_upload", "stage_open", "stage_play", "stage_write", "stage_rest", "stage_stop")


class StageHost:
    """The relay's side of a remote behaviour (see the module doc); one per holder."""

    def __init__(
        self,
        robots: Mapping[str, OwnedRobot],
        *,
        clock: Clock,
        events: EventBus,
        allow_unsafe: bool,
    ) -> None:
        self.robots = robots
        self.clock = clock
        self.events = events
        self.allow_unsafe = allow_unsafe
        self._schedules: dict[str, Schedule] = {}
        self._stage: PortStage | None = None
        self._lock = threading.Lock()  # one command at a time on the seats
        self._ended: list[list[Any]] = []
        self._finished: queue.SimpleQueue[str | None] = queue.SimpleQueue()
        self._sub = events.subscribe(self._on_state, StateChanged)
        # A routine's end is handled off the writer thread that reports it (the hand-over to
        # the watcher joins that thread).
        self._thread = threading.Thread(target=self._watch_ends, daemon=True,
                                        name="xgo-show relay stage")
        self._thread.start()

    @property
    def open(self) -> bool:
        """Whether the robots are being watched (``stage_open`` done, not closed)."""
        return self._stage is not None

    def handle(self, request: msg.Request) -> dict[str, Any]:
        """Carry out one ``stage_*`` command; return its reply's fields (raise to refuse)."""
        op = request.op
        if op == "stage_upload":
            return self._upload(request)
        with self._lock:
            if op == "stage_open":
                return self._open(request)
            stage = self._stage
            if stage is None:
                raise RelayRefused(f"{op}: the behaviour stage is not open (send stage_open)")
            robots = self._robots(request.fields["robots"], stage)
            now = self.clock.now()
            if op == "stage_play":
                sha = self._known(request.text("sha256"))
                at = request.maybe_number("at")
                play_id = request.whole("play")
                stage.play(sha, robots, play_id, now, at)
                when = now if at is None else max(at, now)
                return {"at": when, "late": 0.0 if at is None else max(0.0, now - at)}
            if op == "stage_write":
                stage.write(self._known(request.text("sha256")), robots, now)
            elif op == "stage_rest":
                stage.rest(robots, now)
            else:
                stage.safe_stop(robots, request.text("reason"), now)
            return {"at": now}

    def _upload(self, request: msg.Request) -> dict[str, Any]:
        sha = request.text("sha256")
        if sha not in self._schedules:
            if len(self._schedules) >= MAX_SCHEDULES:
                raise RelayRefused(f"stage_upload: more than {MAX_SCHEDULES} schedules")
            schedule, _ = validate_upload(request.text("schedule"), sha, self.robots,
                                          allow_unsafe=self.allow_unsafe)
            with self._lock:
                self._schedules[sha] = schedule
        return {"sha256": sha}

    def _open(self, request: msg.Request) -> dict[str, Any]:
        if self._stage is not None:
            raise RelayRefused("stage_open: the behaviour stage is open already")
        names = request.fields["robots"]
        unknown = [n for n in names if n not in self.robots]
        if unknown or not names:
            raise RelayRefused(f"stage_open: no robot {', '.join(unknown) or '(none named)'} "
                               f"on this relay (it owns {', '.join(self.robots) or 'none'})")
        watch = request.maybe_number("watch")
        telemetry = request.number("telemetry")
        if not 0.005 <= telemetry <= 60 or (watch is not None and not 0.005 <= watch <= 60):
            raise RelayRefused("stage_open: telemetry periods are 0.005 to 60 s")
        self._stage = PortStage(
            self._schedules, self._schedules,
            {n: self.robots[n].model for n in names},
            {n: self.robots[n].transport for n in names},
            clock=self.clock, events=self.events,
            telemetry_interval=telemetry, watch_interval=watch,
        )
        self._stage.start()
        return {"robots": list(names)}

    def _known(self, sha: str) -> str:
        if sha not in self._schedules:
            raise RelayRefused(f"no uploaded schedule with SHA-256 {sha[:12]}... "
                               "(send stage_upload first)")
        return sha

    @staticmethod
    def _robots(names: Sequence[str], stage: PortStage) -> tuple[str, ...]:
        unknown = [n for n in names if n not in stage.seats]
        if unknown:
            raise RelayRefused(f"robot {', '.join(unknown)} is not on the behaviour stage "
                               f"({', '.join(stage.seats)})")
        return tuple(names)

    def _on_state(self, event: Event) -> None:
        if isinstance(event, StateChanged) and event.state is ExecutorState.FINISHED:
            self._finished.put(event.performer)

    def _watch_ends(self) -> None:
        while (robot := self._finished.get()) is not None:
            with self._lock:
                stage = self._stage
                if stage is None or robot not in stage.seats:
                    continue
                play_id = stage.finished(robot)
                if play_id is not None:
                    self._ended.append([robot, play_id])

    def status(self) -> dict[str, Any]:
        """The heartbeat answer's ``stage``: plays ended since the last answer."""
        with self._lock:
            ended, self._ended = self._ended, []
        return {"open": self._stage is not None, "ended": ended}

    def close(self, reason: str) -> None:
        """Safe-stop every robot of the stage and stop watching them."""
        self._sub.close()
        self._finished.put(None)
        with self._lock:
            stage, self._stage = self._stage, None
            if stage is not None:
                for seat in stage.seats.values():
                    if seat.executor is not None:
                        seat.executor.safe_stop(reason)
                stage.close()
        self._thread.join(2.0)
