"""Launching a show in stages: open -> pre-flight -> arm -> run.

Nothing moves before the last stage, and each stage returns a typed result a caller can show
(the CLI prints them; a relay sends them to its conductor; a show-control server answers
status queries with them)::

    from xgo_show.runtime import EventBus, Launch, MonotonicClock

    bus = EventBus()
    with Launch(schedule, {"rex": "/dev/ttyUSB0"}, clock=MonotonicClock(), events=bus) as launch:
        launch.open()                      # every port, or every relay, opened (concurrently)
        report = launch.preflight()        # firmware, model, battery: a PreflightReport
        launch.arm(force=False)            # PreflightError unless every row passed
        result = launch.run(offset=0.0)    # a ShowResult; any fault ends in a safe stop

Performers are reached through endpoints. A performer's URL picks its endpoint by scheme:
plain ports and pyserial/simulator URLs are :class:`LocalPorts` (an executor per port, in this
process); other schemes are registered with :func:`register_endpoint` (the relay package
registers ``zenoh:``), so local and remote robots mix in one launch with one pre-flight table.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from xgo_show.closing import Closing
from xgo_show.compiler.schedule import Schedule
from xgo_show.errors import SetupError
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import Clock, FakeClock, MonotonicClock
from xgo_show.runtime.events import EventBus, PreflightDone
from xgo_show.runtime.executor import IssueGroup, PerformerExecutor
from xgo_show.runtime.fanout import each
from xgo_show.runtime.latency import Early
from xgo_show.runtime.performer import Performer
from xgo_show.runtime.preflight import (
    PreflightError,
    PreflightReport,
    PreflightRow,
    open_ports,
    preflight,
)
from xgo_show.runtime.realtime import policy
from xgo_show.runtime.safety import check_unsafe
from xgo_show.runtime.show_runner import ShowResult, ShowRunner, default_reach
from xgo_show.runtime.telemetry import TelemetryPoller
from xgo_show.transports.base import Transport

__all__ = [
    "Endpoint",
    "EndpointFactory",
    "Launch",
    "LocalPorts",
    "PerformerContext",
    "endpoints_for",
    "local_performers",
    "local_runner",
    "register_endpoint",
]


@dataclass(frozen=True)
class PerformerContext:
    """What an endpoint needs to build its performers for one run."""

    clock: Clock
    events: EventBus
    telemetry: bool
    battery_floor: float
    linger_until: float  # the whole show's end: performers that finish early keep watching


class Endpoint(Protocol):
    """Performers reached one way: local ports, or one relay host."""

    @property
    def names(self) -> tuple[str, ...]:
        """The performers this endpoint serves."""
        ...

    def open(self) -> Mapping[str, str]:
        """Open every link; return the errors by performer (an opened one is absent)."""
        ...

    def preflight(self, *, battery_floor: float) -> list[PreflightRow]:
        """Check every robot (reads only: nothing moves); one row per performer."""
        ...

    def performers(self, ctx: PerformerContext) -> dict[str, Performer]:
        """One ready-to-start performer per name, publishing on ``ctx.events``."""
        ...

    def close(self) -> None:
        """Release every link (robots are left as the safe stop or the show's end left them)."""
        ...


EndpointFactory = Callable[[Schedule, Mapping[str, str]], Sequence[Endpoint]]
_SCHEMES: dict[str, EndpointFactory] = {}


def register_endpoint(scheme: str, factory: EndpointFactory) -> None:
    """Serve performers whose URL starts with ``scheme:`` through ``factory``.

    ``factory(schedule, {performer: url})`` returns the endpoints for those performers.
    """
    _SCHEMES[scheme.lower()] = factory


def endpoints_for(schedule: Schedule, urls: Mapping[str, str]) -> list[Endpoint]:
    """Group the performers' URLs by endpoint: registered schemes first, the rest local."""
    by_scheme: dict[str, dict[str, str]] = {}
    local: dict[str, str] = {}
    for perf in schedule.performers:
        url = urls.get(perf.name)
        scheme = url.partition(":")[0].lower() if url else ""
        if url and scheme in _SCHEMES:
            by_scheme.setdefault(scheme, {})[perf.name] = url
        else:
            local[perf.name] = url or ""
    endpoints: list[Endpoint] = []
    if local:
        endpoints.append(LocalPorts(schedule, local))
    for scheme, group in by_scheme.items():
        endpoints.extend(_SCHEMES[scheme](schedule, group))
    return endpoints


def local_performers(
    schedule: Schedule, transports: Mapping[str, Transport], ctx: PerformerContext
) -> dict[str, Performer]:
    """One :class:`PerformerExecutor` per open transport, in one :class:`IssueGroup`.

    A :class:`FakeClock` is virtual time: each executor gets its own fork (starting at the
    same instant), so one writer jumping ahead never makes the others late.
    """
    out: dict[str, Performer] = {}
    # Their frames fall due together (one grid): the first writer awake issues them all.
    group = IssueGroup()
    for perf in schedule.performers:
        if perf.name not in transports:
            continue
        profile = get_profile(perf.model)
        clock = ctx.clock.fork() if isinstance(ctx.clock, FakeClock) else ctx.clock
        out[perf.name] = PerformerExecutor(
            perf,
            transports[perf.name],
            clock=clock,
            profile=profile,
            telemetry=(
                TelemetryPoller(profile, battery_floor=ctx.battery_floor) if ctx.telemetry else None
            ),
            reach=default_reach(perf, profile),
            linger_until=ctx.linger_until,
            events=ctx.events,
            group=group,
        )
    return out


def local_runner(
    schedule: Schedule,
    transports: Mapping[str, Transport],
    *,
    clock: Clock | None = None,
    events: EventBus | None = None,
    telemetry: bool = True,
    battery_floor: float | None = None,
    allow_unsafe: bool = False,
    **runner_options: Any,
) -> ShowRunner:
    """A :class:`ShowRunner` over transports the caller opened (and will close) itself.

    For in-process simulators and scripts; :class:`Launch` is the staged way (ports opened
    from URLs, pre-flight). Unsafe writes are refused as in a launch. ``runner_options`` go
    to :class:`ShowRunner`.
    """
    profiles = {p.name: get_profile(p.model) for p in schedule.performers}
    check_unsafe(schedule, profiles, allow_unsafe=allow_unsafe)
    floor = schedule.battery_floor if battery_floor is None else battery_floor
    ctx = PerformerContext(
        clock=clock if clock is not None else MonotonicClock(),
        events=events if events is not None else EventBus(),
        telemetry=telemetry,
        battery_floor=floor,
        linger_until=schedule.duration,
    )
    return ShowRunner(
        schedule,
        local_performers(schedule, transports, ctx),
        events=ctx.events,
        clock=ctx.clock,
        battery_floor=floor,
        **runner_options,
    )


class LocalPorts:
    """Performers on ports of this host (serial devices, pyserial URLs, ``sim:``, ``hid:``)."""

    def __init__(self, schedule: Schedule, urls: Mapping[str, str]) -> None:
        self.schedule = schedule
        self.urls = {name: url for name, url in urls.items()}
        self.transports: dict[str, Transport] = {}
        self.errors: dict[str, str] = {}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.urls)

    def open(self) -> Mapping[str, str]:
        given = {n: u for n, u in self.urls.items() if u}
        self.transports, errors = open_ports(self.schedule, given)
        # open_ports() reports every performer of the show: keep this endpoint's only.
        self.errors = {n: e for n, e in errors.items() if n in self.urls}
        return self.errors

    def preflight(self, *, battery_floor: float) -> list[PreflightRow]:
        report = preflight(
            self.schedule,
            self.transports,
            urls=self.urls,
            open_errors=self.errors,
            battery_floor=battery_floor,
        )
        return [row for row in report.rows if row.performer in self.urls]

    def performers(self, ctx: PerformerContext) -> dict[str, Performer]:
        return local_performers(self.schedule, self.transports, ctx)

    def close(self) -> None:
        for transport in self.transports.values():
            transport.close()
        self.transports = {}


class Launch(Closing):
    """The stages of one show launch over the performers' endpoints.

    ``urls`` maps each performer to its port or URL (performers missing from it use the show
    file's ``port``). Keyword options: ``clock`` (default :class:`MonotonicClock`; a
    :class:`FakeClock` plays without waiting), ``events`` (the bus every stage and performer
    publishes on; default a new one, :attr:`events`), ``battery_floor`` (percent; default the
    show's), ``on_failure`` (default the show's), ``allow_unsafe`` (refused otherwise, before
    anything opens: :class:`~xgo_show.runtime.safety.UnsafeScheduleError`), ``telemetry``
    (poll battery, status and attitude during the show), ``stop_timeout``, ``progress_hz``,
    ``command_lead`` (see :class:`ShowRunner`), ``extra_performers`` (builders of performers
    that play no robot, such as the soundtrack: :func:`xgo_show.audio.player.music_performer`),
    ``latency`` (seconds by performer name: that performer acts so much earlier, to make up
    for its output's own delay).
    """

    def __init__(
        self,
        schedule: Schedule,
        urls: Mapping[str, str] | None = None,
        *,
        clock: Clock | None = None,
        events: EventBus | None = None,
        battery_floor: float | None = None,
        on_failure: str | None = None,
        allow_unsafe: bool = False,
        telemetry: bool = True,
        stop_timeout: float = 0.1,
        progress_hz: float = 4.0,
        command_lead: float = 0.0,
        extra_performers: Sequence[Callable[[PerformerContext], Mapping[str, Performer]]] = (),
        latency: Mapping[str, float] | None = None,
    ) -> None:
        self.schedule = schedule
        #: builders of performers that are no robot (the soundtrack), called at :meth:`arm`
        self.extra_performers = tuple(extra_performers)
        #: seconds each performer's output lags (an adapter, a radio link): it acts that early
        self.latency = dict(latency or {})
        self.clock: Clock = clock if clock is not None else MonotonicClock()
        self.events = events if events is not None else EventBus()
        self.battery_floor = schedule.battery_floor if battery_floor is None else battery_floor
        self.on_failure = on_failure
        self.telemetry = telemetry
        self.stop_timeout = stop_timeout
        self.progress_hz = progress_hz
        self.command_lead = command_lead
        profiles = {p.name: get_profile(p.model) for p in schedule.performers}
        #: the unsafe writes allowed by ``allow_unsafe`` (empty otherwise: refused above)
        self.unsafe = check_unsafe(schedule, profiles, allow_unsafe=allow_unsafe)
        #: each performer's port or URL (the show file's, then ``urls``); see :meth:`map`
        self.urls = {p.name: p.port for p in schedule.performers if p.port}
        self.urls.update(urls or {})
        self.endpoints: list[Endpoint] = []
        self.open_errors: dict[str, str] = {}
        self.report: PreflightReport | None = None
        self.runner: ShowRunner | None = None

    def map(self, urls: Mapping[str, str]) -> None:
        """Give performers ports or URLs (before :meth:`open`), e.g. simulators started after
        the launch refused nothing."""
        if self.endpoints:
            raise SetupError("the launch is already open: map performers before opening it")
        self.urls.update(urls)

    # ------------------------------------------------------------------ stages

    def open(self) -> dict[str, str]:
        """Open every endpoint's links, the endpoints concurrently; returns the errors by
        performer (empty: all open).

        An endpoint that could not open says so in the errors (and in the pre-flight table);
        the others stay open until :meth:`close`, so the table checks every robot that
        answers. Should an endpoint raise instead (or Ctrl-C come), every endpoint is closed
        (whatever part of it opened) before it propagates.
        """
        if self.endpoints:
            raise SetupError("the launch is already open")
        endpoints = endpoints_for(self.schedule, self.urls)
        try:
            results = each(lambda e: e.open(), endpoints, name="xgo-show open")
        except BaseException:
            # Every endpoint, the one that raised too (it may have opened part of its links).
            each(lambda e: e.close(), endpoints, name="xgo-show close")
            raise
        self.endpoints = endpoints
        errors: dict[str, str] = {}
        for found in results:
            errors.update(found)
        self.open_errors = errors
        return errors

    def preflight(self, *, realtime: str | None = None) -> PreflightReport:
        """Check every robot, the endpoints concurrently; one table for every endpoint, in the
        show's performer order.

        ``realtime``: what the report says of real-time scheduling (default: this process's
        :func:`~xgo_show.runtime.realtime.policy`)."""
        found = each(
            lambda endpoint: endpoint.preflight(battery_floor=self.battery_floor),
            self.endpoints,
            name="xgo-show pre-flight",
        )
        rows = {row.performer: row for part in found for row in part}
        ordered = [rows[p.name] for p in self.schedule.performers if p.name in rows]
        said = realtime if realtime is not None else policy().summary
        self.report = PreflightReport(ordered, self.battery_floor, said)
        return self.report

    def arm(self, *, force: bool = False) -> ShowRunner:
        """Build the performers and the runner; refuses unless pre-flight passed.

        A port that did not open always refuses; failed robot checks refuse unless ``force``.
        """
        report = self.report if self.report is not None else self.preflight()
        self.events.publish(PreflightDone(self.clock.now(), report, forced=force))
        if not report.ports_ok:
            raise PreflightError("pre-flight failed: a port did not open; nothing was moved")
        if not report.ok and not force:
            raise PreflightError("pre-flight failed; nothing was moved (--force to start anyway)")
        ctx = PerformerContext(
            clock=self.clock,
            events=self.events,
            telemetry=self.telemetry,
            battery_floor=self.battery_floor,
            linger_until=self.schedule.duration,
        )
        performers: dict[str, Performer] = {}
        for endpoint in self.endpoints:
            performers.update(endpoint.performers(ctx))
        for build in self.extra_performers:
            performers.update(build(ctx))
        performers = {
            name: Early(p, self.latency[name]) if self.latency.get(name) else p
            for name, p in performers.items()
        }
        self.runner = ShowRunner(
            self.schedule,
            performers,
            events=self.events,
            clock=self.clock,
            on_failure=self.on_failure,
            battery_floor=self.battery_floor,
            progress_hz=self.progress_hz,
            stop_timeout=self.stop_timeout,
            command_lead=self.command_lead,
        )
        return self.runner

    def run(
        self,
        *,
        offset: float = 0.0,
        start_at: float | None = None,
        handle_signals: bool = True,
    ) -> ShowResult:
        """Play the armed show from show time ``offset`` (see :meth:`ShowRunner.run`)."""
        if self.runner is None:
            raise SetupError("arm the launch before running it (pre-flight first)")
        return self.runner.run(offset=offset, start_at=start_at, handle_signals=handle_signals)

    def close(self) -> None:
        """Close every endpoint, concurrently (after a run, or when a stage refused)."""
        endpoints, self.endpoints = self.endpoints, []
        each(lambda endpoint: endpoint.close(), endpoints, name="xgo-show close")
