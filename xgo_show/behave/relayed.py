"""The behaviour's performers behind relays: the conductor's side of a relay's stage.

One :class:`RelayedStage` drives every ``zenoh:RELAY/ROBOT`` performer of a behaviour, one
:class:`~xgo_show.relay.client.RelayClient` per relay (the relay protocol's commands and
heartbeats, as a relayed show uses them). :meth:`RelayedStage.open` claims each relay, uploads
every routine and ``set``/``led`` action the behaviour can play that involves its robots
(renamed to the relay's robot names, each kept there by its SHA-256), and opens the relay's
stage (:mod:`xgo_show.behave.relay_host`): from then on the relay watches its robots' telemetry.
The engine's actions become ``stage_*`` commands naming a hash; they do not wait for their reply.
A routine played on robots of one relay starts as the command arrives there (nothing to wait
for: the reaction is quickest); played on several hosts (relays, or relays and local ports), it
carries a start time far enough ahead for the slowest relay, on every host alike.

Heartbeats run every ``watch_interval`` (the period the relay reads a fall or tilt at), and each
answer brings the relay's readings and frames since the last one (published on the runner's
event bus: the engine's telemetry triggers, the run log) and the plays that ended. A relay
silent for the watchdog time is lost: ``on_lost`` names its performers (the runner marks them
offline at once), its commands are dropped from then on, and the relay, hearing nothing,
safe-stops its robots itself.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from xgo_show.behave.loader import Behaviour
from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import NetworkError, SetupError
from xgo_show.net import messages as msg
from xgo_show.net.keys import parse_relay_url
from xgo_show.relay.client import Outcome, RelayClient
from xgo_show.relay.forward import decode_events
from xgo_show.relay.performer import RTT_FACTOR
from xgo_show.relay.validate import schedule_digest
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.events import EventBus, FaultRaised

if TYPE_CHECKING:
    import zenoh

__all__ = ["MIN_PLAY_LEAD", "RelayAccess", "RelayedStage"]

#: Seconds between a play command to several hosts and its start time, at least (a reaction,
#: so short: a start time a relay finds past plays at once, and says how late).
MIN_PLAY_LEAD = 0.002


@dataclasses.dataclass(frozen=True)
class RelayAccess:
    """How a behaviour reaches its relayed performers: ``urls`` (performer ->
    ``zenoh:RELAY/ROBOT``) over ``session`` as ``conductor``; ``watchdog`` seconds of silence
    lose a relay; ``timeout`` for each command's reply."""

    urls: Mapping[str, str]
    session: zenoh.Session
    conductor: msg.Conductor
    namespace: str = "xgo-show"
    watchdog: float = 0.5
    timeout: float = 3.0


@dataclasses.dataclass
class _Relay:
    """One relay of the behaviour: its client, robots and uploaded hashes."""

    client: RelayClient
    names: dict[str, str]  # performer -> robot on the relay
    hashes: dict[str, str] = dataclasses.field(default_factory=dict)  # schedule key -> sha256
    lost: str | None = None
    opened: bool = False  # claimed (hello answered): released at the end

    @property
    def performers(self) -> dict[str, str]:
        """robot on the relay -> performer."""
        return {robot: perf for perf, robot in self.names.items()}


class RelayedStage:
    """The engine's stage for the behaviour's performers behind relays (see the module doc).

    ``urls`` maps each relayed performer to its ``zenoh:RELAY/ROBOT``. ``on_ended(performer,
    play_id)`` and ``on_lost(performers, why)`` are called from Zenoh's threads.
    """

    def __init__(
        self,
        behaviour: Behaviour,
        urls: Mapping[str, str],
        *,
        session: zenoh.Session,
        conductor: msg.Conductor,
        namespace: str,
        clock: Clock,
        events: EventBus,
        on_ended: Callable[[str, int], None],
        on_lost: Callable[[tuple[str, ...], str], None],
        watchdog: float = 0.5,
        watch_interval: float | None = 0.02,
        telemetry_interval: float = 0.25,
        timeout: float = 3.0,
    ) -> None:
        self.behaviour = behaviour
        self.clock = clock
        self.events = events
        self.on_ended = on_ended
        self.on_lost = on_lost
        self.watchdog = watchdog
        self.watch_interval = watch_interval
        self.telemetry_interval = telemetry_interval
        self.relays: dict[str, _Relay] = {}
        for perf, url in urls.items():
            relay, robot = parse_relay_url(url, perf)
            if relay not in self.relays:
                client = RelayClient(session, relay, namespace=namespace, conductor=conductor,
                                     timeout=timeout)
                self.relays[relay] = _Relay(client, {})
            self.relays[relay].names[perf] = robot
        self._of = {p: r for r in self.relays.values() for p in r.names}

    @property
    def performers(self) -> tuple[str, ...]:
        return tuple(self._of)

    # ------------------------------------------------------------------ set-up

    def open(self) -> None:
        """Claim every relay, upload what it may play, open its stage and start its heartbeats;
        a :class:`SetupError` naming the relay if one fails (those opened are released)."""
        try:
            for name, relay in self.relays.items():
                self._open(name, relay)
        except BaseException:
            self.close()
            raise

    def _open(self, name: str, relay: _Relay) -> None:
        client = relay.client
        try:
            description = client.hello()
        except NetworkError as exc:
            raise SetupError(str(exc)) from exc
        relay.opened = True
        # Held from now on: the relay gives up a conductor silent for its watchdog time.
        client.start_heartbeat(
            period=self.watch_interval or self.watchdog / 5,
            watchdog=self.watchdog,
            on_status=lambda status: self._on_status(relay, status),
            on_lost=lambda silence: self._on_lost(name, relay, silence),
        )
        robots = {str(r.get("name")): r for r in description.get("robots", [])}
        models = {p: ref.model for p, ref in self.behaviour.model.performers.items()}
        for perf, robot in relay.names.items():
            row = robots.get(robot)
            if row is None:
                raise SetupError(f"{perf}: relay {name} has no robot {robot!r} "
                                 f"(it has {', '.join(robots) or 'none'})")
            if row.get("model") != models[perf]:
                raise SetupError(f"{perf}: {robot} on relay {name} is a {row.get('model')}, "
                                 f"not a {models[perf]}")
        schedules: dict[str, Schedule] = {**self.behaviour.routines, **self.behaviour.writes}
        try:
            for key, schedule in schedules.items():
                part = self._part(schedule, relay.names)
                if part is None:
                    continue
                text = schedule_to_bytes(part).decode("ascii")
                sha = schedule_digest(text)
                client.request("stage_upload", timeout=30.0, schedule=text, sha256=sha)
                relay.hashes[key] = sha
            client.request("stage_open", robots=list(relay.names.values()),
                           watch=self.watch_interval, telemetry=self.telemetry_interval,
                           watchdog_ms=round(self.watchdog * 1000))
        except NetworkError as exc:
            raise SetupError(str(exc)) from exc

    @staticmethod
    def _part(schedule: Schedule, names: Mapping[str, str]) -> Schedule | None:
        """The relay's part of ``schedule`` under its robots' names (None: none of them)."""
        parts = tuple(dataclasses.replace(p, name=names[p.name], port=None)
                      for p in schedule.performers if p.name in names)
        return dataclasses.replace(schedule, performers=parts) if parts else None

    # ------------------------------------------------------------------ what comes back

    def _on_status(self, relay: _Relay, status: Mapping[str, Any]) -> None:
        performers = relay.performers
        for event in decode_events(status.get("events"), performers, self._to_conductor(relay)):
            self.events.publish(event)
        stage = status.get("stage")
        ended = stage.get("ended") if isinstance(stage, dict) else None
        for row in ended if isinstance(ended, list) else ():
            if (isinstance(row, list) and len(row) == 2 and row[0] in performers
                    and isinstance(row[1], int)):
                self.on_ended(performers[row[0]], row[1])

    def _on_lost(self, name: str, relay: _Relay, silence: float) -> None:
        why = (f"relay {name} lost: no answer for {silence * 1e3:.0f} ms (watchdog "
               f"{self.watchdog * 1e3:.0f} ms); it safe-stops its robots")
        relay.lost = why
        self.on_lost(tuple(relay.names), why)

    @staticmethod
    def _to_conductor(relay: _Relay) -> Callable[[float], float]:
        link = relay.client.link
        return lambda t: t - link.offset

    # ------------------------------------------------------------------ the engine's stage

    def _reached(self, performers: tuple[str, ...]) -> dict[str, list[str]]:
        """relay -> its robots among ``performers`` (relays lost left out)."""
        by_relay: dict[str, list[str]] = {}
        for perf in performers:
            relay = self._of.get(perf)
            if relay is not None and relay.lost is None:
                by_relay.setdefault(relay.client.relay, []).append(relay.names[perf])
        return by_relay

    def hosts(self, performers: tuple[str, ...]) -> int:
        """How many relays play some of ``performers``."""
        return len(self._reached(performers))

    def lead(self, performers: tuple[str, ...]) -> float:
        """Seconds a play on ``performers`` needs to reach every relay of theirs in time:
        :data:`~xgo_show.relay.performer.RTT_FACTOR` half round trips of the slowest (its
        worst recent one), at least :data:`MIN_PLAY_LEAD`."""
        lead = MIN_PLAY_LEAD
        for name in self._reached(performers):
            worst = self.relays[name].client.link.worst_recent_rtt()
            if worst is not None:
                lead = max(lead, RTT_FACTOR * worst / 2)
        return lead

    def _send(self, performers: tuple[str, ...], op: str, key: str | None = None,
              **fields: Any) -> None:
        """``op`` to each relay with some of ``performers``, not waiting for the replies; an
        ``at`` among ``fields`` is a time on this clock (sent on each relay's)."""
        for name, robots in self._reached(performers).items():
            relay = self.relays[name]
            extra = dict(fields)
            if key is not None:
                if key not in relay.hashes:
                    continue  # none of these robots is in that schedule
                extra["sha256"] = relay.hashes[key]
            if extra.get("at") is not None:
                extra["at"] += relay.client.link.offset
            relay.client.send(op, functools.partial(self._answered, name, op),
                              robots=robots, **extra)

    def _answered(self, name: str, op: str, outcome: Outcome) -> None:
        """A refused or unanswered command is a fault of the relay's performers (in the run
        log); a relay that stays silent is lost by its heartbeats' watchdog."""
        if isinstance(outcome, NetworkError):
            now = self.clock.now()
            for perf in self.relays[name].names:
                self.events.publish(FaultRaised(now, perf, f"{op}: {outcome}"))

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float,
             at: float | None = None) -> None:
        """Play ``routine`` on the relayed ``performers`` at ``at`` (this clock), or as soon as
        each relay has the command (None)."""
        self._send(performers, "stage_play", routine, play=play_id, at=at)

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        self._send(performers, "stage_rest")

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        self._send(performers, "stage_stop", reason=reason)

    def write(self, key: str, performers: tuple[str, ...], t: float) -> None:
        self._send(performers, "stage_write", key)

    def close(self, reason: str = "behaviour ended") -> None:
        """Safe-stop every relayed robot (waiting for each relay's answer) and release the
        relays."""
        for relay in self.relays.values():
            if not relay.opened:
                continue
            client = relay.client
            if relay.lost is None:
                with contextlib.suppress(NetworkError):  # else its watchdog stops them
                    client.request("stage_stop", timeout=2.0,
                                   robots=list(relay.names.values()), reason=reason)
            client.release()
            relay.opened = False
