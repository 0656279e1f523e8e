"""A robot behind a relay, as the show runner sees it: a :class:`RelayedPerformer`.

Every performer of one relay shares a :class:`RelayShow`: one uploaded schedule, one holder
session with heartbeats, one start command. The runner calls ``start(start_at)`` (and
``pause``/``resume``/``seek`` with an ``at``) on each performer with the same clock time; the
first call sends the command, converted to the relay's show clock, and the others find it sent.
Frames never cross the network: the relay plays its robots' schedules itself.

Timed commands do not wait for their reply: the runner's loop over the performers puts the
commands to every relay in flight together, and each reply comes back on a Zenoh thread (a
refusal, or none within the timeout, is a :class:`~xgo_show.runtime.events.FaultRaised` for the
relay's performers). So the lead a start needs does not grow with the number of relays: it is
the slowest relay's recent round trip, measured by the heartbeats (:meth:`RelayShow.lead`),
plus the relay's own set-up.

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
from xgo_show.errors import NetworkError
from xgo_show.profiles import get_profile
from xgo_show.relay.client import Outcome, RelayClient
from xgo_show.relay.forward import decode_events
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.events import (
    EventBus,
    FaultRaised,
    SafeStopped,
    TelemetryRead,
)
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.show_runner import default_reach

__all__ = [
    "MIN_NETWORK_LEAD",
    "NETWORK_LEAD",
    "RELAY_SETUP",
    "RTT_FACTOR",
    "RelayShow",
    "RelayedPerformer",
    "executor_lead",
]

#: Seconds between a pause/resume/seek request and the time every host acts on it (the
#: runner's ``command_lead`` when a show has relayed performers; a LAN's round trip is ~1 ms).
NETWORK_LEAD = 0.2
#: A start's network share: this many of the worst recent round trips to the relay ...
RTT_FACTOR = 3.0
#: ... and never less than this (seconds; a heartbeat or two may not show a busy moment).
MIN_NETWORK_LEAD = 0.05
#: Seconds a relay takes from receiving a start to its executors waiting for the start time
#: (decoding, building the runner and its threads; the executors' own lead comes on top).
RELAY_SETUP = 0.05
#: The executors' own lead on the relay (see ``PerformerExecutor.lead_time``).
_EXECUTOR_LEAD = 0.05


@dataclass(frozen=True)
class _Remote:
    """What one heartbeat said about one performer."""

    state: ExecutorState
    show_time: float
    sent: int
    total: int
    cue: str
    fault: str | None
    at: float  # the conductor's clock time the relay's show_time was read

    def show_time_at(self, now: float) -> float:
        """The show time at ``now`` (a running performer's show time moves on)."""
        if self.state is ExecutorState.RUNNING:
            return self.show_time + max(0.0, now - self.at)
        return self.show_time


def executor_lead(schedule: PerformerSchedule, offset: float) -> float:
    """Seconds the executor of ``schedule`` needs before a start at show time ``offset``: its
    own lead, and the catch-up frames of a mid-show start on the robot's link (the relay
    refuses a start that leaves less)."""
    if offset <= 0:
        return _EXECUTOR_LEAD
    link = schedule.link
    frames = default_reach(schedule, get_profile(schedule.model))(offset)
    return _EXECUTOR_LEAD + sum(link.wire_time(len(d)) + link.gap for d, _ in frames)


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
        self._sent: set[tuple[str, float, float | None]] = set()
        #: the time given to the latest command for "now" of each (op, value), see once()
        self._now: dict[tuple[str, float | None], float] = {}
        self._status: dict[str, _Remote] = {}
        self._faulted: set[str] = set()
        self._lost: str | None = None
        self._failed: str | None = None  # a command the relay refused or never answered
        self._stop: dict[str, Any] | None = None
        self._ended = threading.Event()
        self._readings: dict[str, dict[str, float]] = {}
        #: what the relay said of the start: seconds to spare when it armed its executors
        self.start_margin: float | None = None

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
        # What the relay sent, read and did since the last answer first, at the relay's own
        # times: the state below may say the show is over, and the runner then reports at once.
        for event in decode_events(status.get("events"), self.robots, self.to_conductor):
            if isinstance(event, TelemetryRead):
                with self._lock:
                    self._readings.setdefault(event.performer, {})[event.name] = event.value
            elif isinstance(event, FaultRaised):
                with self._lock:
                    if event.performer in self._faulted:
                        continue
                    self._faulted.add(event.performer)
                event = FaultRaised(
                    event.t, event.performer, f"on relay {self.client.relay}: {event.reason}"
                )
            self.events.publish(event)
        performers = status.get("performers")
        last = status.get("last")
        now = self.clock.now()
        # The relay's show clock when it answered (the heartbeat's show times are of then).
        stamped = status.get("t")
        at = self.to_conductor(float(stamped)) if isinstance(stamped, int | float) else now
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
                        at,
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
                    at,
                )
            self._ended.set()
        # State changes were published above, as the relay's executors made them; a fault
        # the relay did not report as an event (its runner's own) is published here.
        for perf, remote in updates.items():
            with self._lock:
                self._status[perf] = remote
                new_fault = remote.fault is not None and perf not in self._faulted
                if new_fault:
                    self._faulted.add(perf)
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

    def network_lead(self) -> float:
        """Seconds a command needs to reach this relay in time: :data:`RTT_FACTOR` times the
        worst of the recent round trips, at least :data:`MIN_NETWORK_LEAD`."""
        worst = self.client.link.worst_recent_rtt()
        return MIN_NETWORK_LEAD if worst is None else max(MIN_NETWORK_LEAD, RTT_FACTOR * worst)

    def lead(self) -> float:
        """Seconds a start needs to reach this relay and be armed there in time.

        :meth:`network_lead` plus :data:`RELAY_SETUP`: commands to several relays go out
        together, so the lead is the slowest relay's, not the sum of theirs.
        """
        return self.network_lead() + RELAY_SETUP

    def once(self, op: str, at: float | None, value: float | None = None, **fields: Any) -> None:
        """Send ``op`` for every performer of this relay, once per (op, at, value).

        Every command goes with a time. One for "now" (``at`` None) acts at now plus
        :meth:`network_lead`, the first moment the relay surely has it: "now" would reach the
        relay already past (it refuses late commands rather than put its robots on another
        frame than the other hosts'), or act a round trip after a local robot. The other
        performers of this relay asking the same before that time get the same time, so the
        relay hears it once. Returns at once: the reply comes back on a Zenoh thread (see the
        module docstring).
        """
        if at is None:
            at = self._immediate(op, value)
        key = (op, at, value)
        with self._lock:
            if key in self._sent or self._lost is not None:
                return
            self._sent.add(key)
        when = self.to_relay(at)
        if op == "start":
            fields = {"sha256": self.sha256, "start_at": when, "offset": value or 0.0}
        else:
            fields = {**fields, "at": when}
        self.client.send(op, lambda outcome: self._answered(op, outcome), **fields)

    def _immediate(self, op: str, value: float | None) -> float:
        """The time of a command for "now" (see :meth:`once`)."""
        now = self.clock.now()
        with self._lock:
            pending = self._now.get((op, value))
            if pending is None or pending <= now:
                pending = self._now[(op, value)] = now + self.network_lead()
            return pending

    def _answered(self, op: str, outcome: Outcome) -> None:
        if isinstance(outcome, NetworkError):
            self.fail(f"{op} on relay {self.client.relay}: {outcome}")
        elif op == "start":
            margin = outcome.fields.get("margin")
            self.start_margin = float(margin) if isinstance(margin, (int, float)) else None

    def fail(self, why: str) -> None:
        """A command failed: every performer of this relay faults (the runner applies the
        show's failure policy, and its safe stop still reaches the relay)."""
        with self._lock:
            if self._failed is None:
                self._failed = why
            fresh = [p for p in self.names if p not in self._faulted]
            self._faulted.update(fresh)
        now = self.clock.now()
        for perf in fresh:
            self.events.publish(FaultRaised(now, perf, why))

    def failed(self) -> str | None:
        """Why a command to this relay failed (None: none did)."""
        return self._failed

    def stop(self, reason: str, timeout: float) -> dict[str, Any]:
        """Safe-stop every robot of this relay (once); the relay's answer, or why none.

        Unlike every other command this one has no time to act at: a safe stop must act as
        soon as the relay has it, and the runner sends it to every relay at once, so hosts stop
        within a round trip of each other rather than all later, at a common time.
        """
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
        self._started = False
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
        return self.state.ended

    @property
    def fault(self) -> str | None:
        lost = self.show.lost()
        if lost is not None:
            return lost
        remote = self.show.remote(self.name)
        if remote is not None and remote.fault is not None:
            return f"on relay {self.show.client.relay}: {remote.fault}"
        return self.show.failed()

    @property
    def progress(self) -> Progress:
        remote = self.show.remote(self.name)
        total = len(self.schedule.frames)
        if remote is None:
            return Progress(self.name, self.state, 0.0, 0, total, "", "")
        label = self.schedule.frames[remote.sent - 1].label if 0 < remote.sent <= total else ""
        show_time = remote.show_time_at(self.show.clock.now())
        return Progress(self.name, self.state, show_time, remote.sent, total, remote.cue, label)

    @property
    def stop_result(self) -> SafeStopResult | None:
        return self._stop_result

    @property
    def readings(self) -> Mapping[str, float]:
        return self.show.readings(self.name)

    def lead_time(self, offset: float) -> float:
        """The relay's lead (:meth:`RelayShow.lead`, from measured round trips) plus what the
        robot's executor needs there (:func:`executor_lead`)."""
        return self.show.lead() + executor_lead(self.schedule, offset)

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
        self.show.once(op, at, value, **fields)

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
