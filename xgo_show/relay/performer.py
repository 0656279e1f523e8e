"""A robot behind a relay, as the show runner sees it: a :class:`RelayedPerformer`.

Every performer of one relay shares a :class:`RelayShow`: one uploaded schedule, one holder
session with heartbeats, one start command. The runner calls ``start(start_at)`` (and
``pause``/``resume``/``seek`` with an ``at``) on each performer with the same clock time; the
first call sends the command, converted to the relay's show clock, and the others find it sent.
Frames never cross the network: the relay plays its robots' schedules itself.

What comes back: each heartbeat answer carries every performer's state, show time, frames sent
and fault. A fault on the relay becomes a :class:`~xgo_show.runtime.events.FaultRaised` here (the
runner applies the show's failure policy); a relay silent for the watchdog time faults every
performer it serves ("relay ... lost"), while the relay, hearing nothing either, applies the
show's link-loss policy on its side.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from xgo_show.compiler.schedule import PerformerSchedule
from xgo_show.errors import NetworkError, XgoShowError
from xgo_show.profiles import get_profile
from xgo_show.relay.client import RelayClient
from xgo_show.relay.forward import decode_events
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.events import (
    EventBus,
    FaultRaised,
    SafeStopped,
    StateChanged,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.show_runner import default_reach

__all__ = ["NETWORK_LEAD", "RelayShow", "RelayedPerformer"]

#: Seconds a command needs to reach a relay and be acted on (a LAN's round trip is ~1 ms; this
#: covers a busy host and a Zenoh retransmission).
NETWORK_LEAD = 0.2
_DONE = (ExecutorState.FINISHED, ExecutorState.STOPPED, ExecutorState.FAILED)


@dataclass(frozen=True)
class _Remote:
    """What one heartbeat said about one performer."""

    state: ExecutorState
    show_time: float
    sent: int
    total: int
    cue: str
    fault: str | None


class RelayShow:
    """One relay's part of a show: the client, the uploaded schedule's hash, the shared state.

    ``names`` maps each show performer to the robot's name on the relay.
    """

    def __init__(
        self,
        client: RelayClient,
        names: Mapping[str, str],
        sha256: str,
        *,
        clock: Clock,
        events: EventBus,
        watchdog: float,
        synced: bool = True,
    ) -> None:
        self.client = client
        self.synced = synced
        self.names = dict(names)
        self.robots = {robot: perf for perf, robot in self.names.items()}
        self.sha256 = sha256
        self.clock = clock
        self.events = events
        self.watchdog = watchdog
        self._lock = threading.Lock()
        self._sent: set[tuple[str, float | None, float | None]] = set()
        self._status: dict[str, _Remote] = {}
        self._faulted: set[str] = set()
        self._lost: str | None = None
        self._stop: dict[str, Any] | None = None
        self._ended = threading.Event()
        self._readings: dict[str, dict[str, float]] = {}

    # ------------------------------------------------------------------ heartbeat side

    def begin(self) -> None:
        """Start listening to the relay's heartbeat answers (before the start command)."""
        self.client.stop_heartbeat()
        self.client.start_heartbeat(
            period=self.watchdog / 5,
            watchdog=self.watchdog,
            on_status=self._on_status,
            on_lost=self._on_lost,
        )

    def _on_status(self, status: Mapping[str, Any]) -> None:
        # What the relay sent and read since the last answer first: the state below may say
        # the show is over, and the runner then reports at once.
        for event in decode_events(status.get("events"), self.robots, self.to_conductor):
            if isinstance(event, TelemetryRead):
                with self._lock:
                    self._readings.setdefault(event.performer, {})[event.name] = event.value
            self.events.publish(event)
        performers = status.get("performers")
        last = status.get("last")
        now = self.clock.now()
        updates: dict[str, _Remote] = {}
        if isinstance(performers, dict):
            for robot, row in performers.items():
                if robot in self.robots and isinstance(row, dict):
                    updates[self.robots[robot]] = _Remote(
                        ExecutorState(row.get("state", "idle")),
                        float(row.get("show_time", 0.0)),
                        int(row.get("sent", 0)),
                        int(row.get("total", 0)),
                        str(row.get("cue", "")),
                        row.get("fault"),
                    )
        elif (
            status.get("state") == "ended"
            and isinstance(last, dict)
            and last.get("sha256") == self.sha256
        ):
            faults = last.get("faults") or {}
            for perf, robot in self.names.items():
                old = self._status.get(perf)
                if last.get("completed"):
                    state = ExecutorState.FINISHED
                elif robot in faults:
                    state = ExecutorState.FAILED
                else:
                    state = ExecutorState.STOPPED
                updates[perf] = _Remote(
                    state,
                    old.show_time if old else 0.0,
                    old.sent if old else 0,
                    old.total if old else 0,
                    old.cue if old else "",
                    faults.get(robot),
                )
            self._ended.set()
        for perf, remote in updates.items():
            with self._lock:
                old = self._status.get(perf)
                self._status[perf] = remote
                new_fault = remote.fault is not None and perf not in self._faulted
                if new_fault:
                    self._faulted.add(perf)
            if old is None or old.state is not remote.state:
                self.events.publish(StateChanged(now, perf, remote.state, remote.show_time))
            if new_fault and remote.fault is not None:
                self.events.publish(
                    FaultRaised(now, perf, f"on relay {self.client.relay}: {remote.fault}")
                )

    def _on_lost(self, silence: float) -> None:
        why = (
            f"relay {self.client.relay} lost: no answer for {silence * 1e3:.0f} ms "
            f"(watchdog {self.watchdog * 1e3:.0f} ms); it applies the show's link-loss policy"
        )
        with self._lock:
            self._lost = why
            fresh = [p for p in self.names if p not in self._faulted]
            self._faulted.update(fresh)
        now = self.clock.now()
        for perf in fresh:
            self.events.publish(FaultRaised(now, perf, why))
        self._ended.set()

    # ------------------------------------------------------------------ shared commands

    def to_relay(self, t: float) -> float:
        """A time on the conductor's clock, on the relay's show clock.

        The same once the conductor's clock tracker has pushed its timebase (the relay's show
        clock then reads the conductor's time); until then, the offset the heartbeats saw.
        """
        return t if self.synced else t + self.client.link.offset

    def to_conductor(self, t: float) -> float:
        """A time on the relay's show clock, on the conductor's clock."""
        return t if self.synced else t - self.client.link.offset

    def readings(self, perf: str) -> dict[str, float]:
        """The latest telemetry values the relay read from ``perf``'s robot."""
        with self._lock:
            return dict(self._readings.get(perf, {}))

    def once(self, op: str, at: float | None, value: float | None = None, **fields: Any) -> None:
        """Send ``op`` for every performer of this relay, once per (op, at, value)."""
        key = (op, at, value)
        with self._lock:
            if key in self._sent or self._lost is not None:
                return
            self._sent.add(key)
        when = None if at is None else self.to_relay(at)
        if op == "start":
            assert at is not None and when is not None
            self.client.start(self.sha256, when, value or 0.0)
        else:
            self.client.command(op, at=when, **fields)

    def stop(self, reason: str, timeout: float) -> dict[str, Any]:
        """Safe-stop every robot of this relay (once); the relay's answer, or why none."""
        with self._lock:
            if self._stop is not None:
                return self._stop
            lost = self._lost
        if lost is not None:
            out: dict[str, Any] = {"error": lost}
        else:
            try:
                reply = self.client.request("stop", timeout=max(timeout, 0.5), reason=reason)
                out = {"stops": reply.fields.get("stops", {})}
            except NetworkError as exc:
                out = {"error": f"{exc} (the relay's watchdog stops its robots on its own)"}
        with self._lock:
            if self._stop is None:
                self._stop = out
            return self._stop

    def remote(self, perf: str) -> _Remote | None:
        with self._lock:
            return self._status.get(perf)

    def lost(self) -> str | None:
        return self._lost

    def close(self) -> None:
        """Stop the heartbeats and give the relay up (its robots are at rest or stopped)."""
        if self._lost is None:
            self.client.release()
        else:
            self.client.stop_heartbeat()


class RelayedPerformer:
    """The :class:`~xgo_show.runtime.performer.Performer` of one robot behind a relay."""

    def __init__(self, schedule: PerformerSchedule, show: RelayShow) -> None:
        self.schedule = schedule
        self.show = show
        self._profile = get_profile(schedule.model)
        self._reach = default_reach(schedule, self._profile)
        self._started = False
        self._fault: str | None = None
        self._stop_result: SafeStopResult | None = None

    @property
    def name(self) -> str:
        return self.schedule.name

    @property
    def model(self) -> str:
        return self.schedule.model

    @property
    def state(self) -> ExecutorState:
        if self._stop_result is not None:
            return ExecutorState.STOPPED if self.fault is None else ExecutorState.FAILED
        if self.show.lost() is not None:
            return ExecutorState.FAILED
        remote = self.show.remote(self.name)
        return remote.state if remote is not None else ExecutorState.IDLE

    @property
    def done(self) -> bool:
        return self.state in _DONE

    @property
    def fault(self) -> str | None:
        lost = self.show.lost()
        if lost is not None:
            return lost
        remote = self.show.remote(self.name)
        if remote is not None and remote.fault is not None:
            return f"on relay {self.show.client.relay}: {remote.fault}"
        return self._fault

    @property
    def progress(self) -> Progress:
        remote = self.show.remote(self.name)
        total = len(self.schedule.frames)
        if remote is None:
            return Progress(self.name, self.state, 0.0, 0, total, "", "")
        label = self.schedule.frames[remote.sent - 1].label if 0 < remote.sent <= total else ""
        return Progress(
            self.name, self.state, remote.show_time, remote.sent, total, remote.cue, label
        )

    @property
    def stop_result(self) -> SafeStopResult | None:
        return self._stop_result

    @property
    def readings(self) -> Mapping[str, float]:
        return self.show.readings(self.name)

    def lead_time(self, offset: float) -> float:
        """The network's lead plus what the robot's catch-up frames need on its link."""
        if offset <= 0:
            return NETWORK_LEAD + 0.05
        link = self.schedule.link
        frames = self._reach(offset)
        return NETWORK_LEAD + sum(link.wire_time(len(d)) + link.gap for d, _ in frames) + 0.05

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        self._started = True
        self._send("start", start_at, offset)

    def pause(self, *, at: float | None = None) -> None:
        self._send("pause", at)

    def resume(self, *, at: float | None = None) -> None:
        self._send("resume", at)

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        self._send("seek", at, show_time, show_time=show_time)

    def _send(self, op: str, at: float | None, value: float | None = None, **fields: Any) -> None:
        try:
            self.show.once(op, at, value, **fields)
        except XgoShowError as exc:
            if self._fault is None:
                self._fault = f"{op} on relay {self.show.client.relay}: {exc}"
                self.show.events.publish(FaultRaised(self.show.clock.now(), self.name, self._fault))

    def abort(self) -> None:
        """Nothing to hold back here: the relay sends the frames (see :meth:`safe_stop`)."""

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        if self._stop_result is not None:
            return self._stop_result
        requested = time.monotonic()
        answer = self.show.stop(reason, timeout)
        robot = self.show.names[self.name]
        elapsed = time.monotonic() - requested
        if "error" in answer:
            result = SafeStopResult(
                self.name, reason, False, error=str(answer["error"]), elapsed=elapsed
            )
        else:
            ok = bool(answer["stops"].get(robot, True))
            error = "" if ok else f"the relay's safe stop of {robot} failed"
            result = SafeStopResult(self.name, reason, ok, ("relay stop",), error, elapsed)
        self._stop_result = result
        self.show.events.publish(SafeStopped(self.show.clock.now(), self.name, result))
        return result

    def join(self, timeout: float | None = None) -> bool:
        if not self._started:
            return True
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self.done:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                return False
            self.show._ended.wait(0.02 if left is None else min(0.02, left))
        return True

    def close(self) -> None:
        """Nothing per performer: the endpoint closes the relay's session."""
