"""The conductor's ``zenoh:`` performers: robots behind relays in a local launch.

``--map rex=zenoh:stage-left/dog1`` plays performer ``rex`` on the robot ``dog1`` of the relay
``stage-left`` (``zenoh:stage-left/rex`` when the names agree; ``zenoh:stage-left`` alone when
the relay has a robot named like the performer). :func:`configure` (the CLI calls it with the
command's Zenoh options) registers the ``zenoh`` scheme with
:func:`~xgo_show.runtime.launch.register_endpoint`; the launch then groups a show's relayed
performers by relay, one :class:`RelayEndpoint` each:

- ``open``: claims the relay (``hello``; another conductor's relay is refused with its
  holder's name) and checks it has the robots, of the right models;
- ``preflight``: uploads the relay's part of the schedule (performers renamed to the relay's
  robot names; content-hashed) and returns the relay's pre-flight rows, so the conductor prints
  ONE table for local and relayed robots and nothing starts unless every row passes;
- ``performers``: one :class:`~xgo_show.relay.performer.RelayedPerformer` per robot.

One Zenoh session serves every relay of the process; :func:`close_session` closes it.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from xgo_show.compiler.artifact import schedule_to_bytes
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import NetworkError, UsageError, XgoShowError
from xgo_show.net import messages as msg
from xgo_show.net.keys import SCHEME, parse_relay_url, relay_key
from xgo_show.net.offset import OffsetEstimate, Timebase
from xgo_show.net.session import SessionOptions, open_session
from xgo_show.net.timesync import ClockTracker, TrackerUpdate
from xgo_show.relay.client import RelayClient, new_conductor
from xgo_show.relay.options import ConductorOptions
from xgo_show.relay.performer import RelayedPerformer, RelayShow
from xgo_show.relay.validate import schedule_digest
from xgo_show.runtime.clock import MonotonicClock
from xgo_show.runtime.launch import Endpoint, PerformerContext, register_endpoint
from xgo_show.runtime.performer import Performer
from xgo_show.runtime.preflight import PreflightRow

if TYPE_CHECKING:
    import zenoh

__all__ = [
    "RelayEndpoint",
    "close_session",
    "configure",
    "parse_zenoh_url",
    "probe_relayed",
    "shared_session",
]

_options = ConductorOptions()
_session: zenoh.Session | None = None
_conductor: msg.Conductor | None = None
_lock = threading.Lock()


def configure(options: ConductorOptions, *, session: zenoh.Session | None = None) -> None:
    """Use ``options`` for the ``zenoh:`` performers of this process; registers the scheme.

    ``session``: a session of the caller's to reach relays through (``xgo-show serve`` has
    one open already) instead of one opened from ``options`` on first use.
    """
    global _options, _session, _conductor
    if options.link_loss not in msg.LINK_LOSS_POLICIES:
        raise UsageError(
            f"link-loss policy {options.link_loss!r}: one of {', '.join(msg.LINK_LOSS_POLICIES)}"
        )
    if not 0.05 <= options.watchdog <= 60:
        raise UsageError(f"watchdog {options.watchdog:g} s: give 0.05 to 60 seconds")
    _options = options
    if session is not None:
        with _lock:
            _session, _conductor = session, new_conductor(options.name)
    register_endpoint(SCHEME, _endpoints)


def shared_session() -> tuple[zenoh.Session, msg.Conductor]:
    """This process's Zenoh session and conductor identity (opened on first use)."""
    global _session, _conductor
    with _lock:
        if _session is None:
            _session = open_session(_options.session)
            _conductor = new_conductor(_options.name)
        assert _conductor is not None
        return _session, _conductor


def close_session() -> None:
    """Close the shared session (after the show)."""
    global _session
    with _lock:
        session, _session = _session, None
    if session is not None:
        session.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type


def parse_zenoh_url(url: str, performer: str) -> tuple[str, str]:
    """``zenoh:RELAY/ROBOT`` (or ``zenoh:RELAY``: the robot is named like the performer)."""
    return parse_relay_url(url, performer)


def probe_relayed(url: str, session: SessionOptions, *, timeout: float) -> list[tuple[str, str]]:
    """``xgo-show probe zenoh:RELAY/ROBOT``: the relay reads its robot (only between shows)."""
    relay, robot = parse_zenoh_url(url, "")
    zsession = open_session(session)
    try:
        client = RelayClient(
            zsession, relay, namespace=session.namespace, timeout=max(timeout, 1.0) + 1.0
        )
        client.hello()
        try:
            rows = client.command("probe", performer=robot).get("rows", [])
        finally:
            client.release()
    finally:
        zsession.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type
    return [("relay", relay), *((str(k), str(v)) for k, v in rows)]


def _endpoints(schedule: Schedule, urls: Mapping[str, str]) -> Sequence[Endpoint]:
    by_relay: dict[str, dict[str, str]] = {}
    for perf, url in urls.items():
        relay, robot = parse_zenoh_url(url, perf)
        by_relay.setdefault(relay, {})[perf] = robot
    return [RelayEndpoint(schedule, relay, names, urls) for relay, names in by_relay.items()]


class RelayEndpoint:
    """The performers of one show that one relay plays (an :class:`Endpoint`)."""

    def __init__(
        self,
        schedule: Schedule,
        relay: str,
        names: Mapping[str, str],
        urls: Mapping[str, str],
        *,
        options: ConductorOptions | None = None,
    ) -> None:
        self.schedule = schedule
        self.relay = relay
        self.map = dict(names)  # show performer -> robot on the relay
        self.urls = {p: urls[p] for p in names}
        self.options = options if options is not None else _options
        self.client: RelayClient | None = None
        self.description: dict[str, Any] = {}
        self.sha256 = ""
        self.show: RelayShow | None = None
        self._errors: dict[str, str] = {}
        self._robots: dict[str, dict[str, Any]] = {}  # the relay's robots by name
        self.tracker: ClockTracker | None = None
        self.timebase: Timebase | None = None  # the first one (for the pre-flight notes)
        self.estimate: OffsetEstimate | None = None  # the first burst's (its round trip)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.map)

    def part(self) -> Schedule:
        """The relay's part of the show, performers under the relay's robot names."""
        performers = tuple(
            dataclasses.replace(p, name=self.map[p.name], port=None)
            for p in self.schedule.performers
            if p.name in self.map
        )
        return dataclasses.replace(self.schedule, performers=performers)

    def open(self) -> Mapping[str, str]:
        try:
            session, conductor = shared_session()
            client = RelayClient(
                session,
                self.relay,
                namespace=self.options.session.namespace,
                conductor=conductor,
                timeout=self.options.timeout,
            )
            self.description = client.hello()
        except XgoShowError as exc:
            self._errors = {p: str(exc) for p in self.map}
            return self._errors
        self.client = client
        # Hold the relay from now on: it gives up a silent conductor after the watchdog.
        client.start_heartbeat(period=self.options.watchdog / 5, watchdog=self.options.watchdog)
        # Measure the relay's clock and push the timebase: from now on its show clock reads
        # this process's time, and keeps doing so (drift included) while the tracker runs.
        self.tracker = ClockTracker(
            session,
            relay_key(self.options.session.namespace, self.relay, "time"),
            conductor=conductor.id,
            clock=MonotonicClock(),
            on_update=self._on_sync,
        )
        try:
            self.timebase = self.tracker.start()
        except XgoShowError as exc:
            self.tracker = None
            self._errors = {p: f"time sync with relay {self.relay} failed: {exc}" for p in self.map}
            return self._errors
        robots = {r.get("name"): r for r in self.description.get("robots", [])}
        self._robots = {str(n): r for n, r in robots.items()}
        models = {p.name: p.model for p in self.schedule.performers}
        for perf, robot in self.map.items():
            row = robots.get(robot)
            if row is None:
                have = ", ".join(str(n) for n in robots) or "none"
                self._errors[perf] = f"relay {self.relay} has no robot {robot!r} (it has {have})"
            elif row.get("model") != models[perf]:
                self._errors[perf] = (
                    f"{robot} on relay {self.relay} is a {row.get('model')}, not a {models[perf]}"
                )
        return self._errors

    def preflight(self, *, battery_floor: float) -> list[PreflightRow]:
        rows = {p: PreflightRow(p, self._model(p), self.urls[p]) for p in self.map}
        if self.client is None or self._errors:
            for perf, row in rows.items():
                row.problems.append(self._errors.get(perf, "relay not opened"))
            return list(rows.values())
        row_of = {robot: perf for perf, robot in self.map.items()}
        text = schedule_to_bytes(self.part()).decode("ascii")
        self.sha256 = schedule_digest(text)
        try:
            reply = self.client.upload(
                text,
                self.sha256,
                link_loss=self.options.link_loss,
                watchdog_ms=round(self.options.watchdog * 1000),
                battery_floor=battery_floor,
            )
        except XgoShowError as exc:
            for row in rows.values():
                row.opened = True
                row.problems.append(str(exc))
            return list(rows.values())
        for got in reply.get("preflight", []):
            found = row_of.get(str(got.get("performer")))
            if found is None:
                continue
            row = rows[found]
            row.opened = bool(got.get("opened"))
            row.firmware = str(got.get("firmware") or "")
            detected = got.get("detected")
            row.detected = detected if isinstance(detected, str) else None
            row.battery = got.get("battery")
            row.voltage = got.get("voltage")
            row.low_latency = bool(got.get("low_latency"))
            row.problems.extend(str(p) for p in got.get("problems", []))
            row.notes.extend(str(n) for n in got.get("notes", []))
            row.notes.append(f"via relay {self.relay}{self._sync_note()}")
            robot = self._robots.get(str(got.get("performer")), {})
            if robot.get("port"):
                row.port = str(robot["port"])
        return list(rows.values())

    def _on_sync(self, update: TrackerUpdate) -> None:
        if self.estimate is None:  # the first burst's, for the pre-flight table
            self.estimate = update.estimate

    def _sync_note(self) -> str:
        tb, est = self.timebase, self.estimate
        if tb is None:
            return ""
        rtt = "" if est is None else f", round trip {est.rtt * 1e3:.3f} ms"
        return f", clock offset {tb.offset:+.6f} s +- {tb.bound * 1e3:.3f} ms{rtt}"

    def _model(self, perf: str) -> str:
        return next(p.model for p in self.schedule.performers if p.name == perf)

    def performers(self, ctx: PerformerContext) -> dict[str, Performer]:
        if self.client is None:
            raise NetworkError(f"relay {self.relay} is not open")
        self.show = RelayShow(
            self.client,
            self.map,
            self.sha256,
            clock=ctx.clock,
            events=ctx.events,
            watchdog=self.options.watchdog,
            synced=self.tracker is not None,
        )
        self.show.begin()
        return {
            p.name: RelayedPerformer(p, self.show)
            for p in self.schedule.performers
            if p.name in self.map
        }

    def close(self) -> None:
        if self.tracker is not None:
            self.tracker.close()
            self.tracker = None
        if self.show is not None:
            self.show.close()
        elif self.client is not None:
            self.client.release()
        self.client = None
