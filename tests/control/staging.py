"""Stand-in robots for ``serve``'s in-process tests (test_server_stage.py): a launch endpoint,
scheme ``stand:``, whose performers play nothing. Each says what it was told (``calls``) and
tells the show what a robot would, in order, from one thread of the stage's own (as an
executor's writer would): RUNNING when its start comes, PAUSED at the time a pause asks for,
STOPPED after a safe stop. The launch, the show runner, the director and the server are the
real ones; only the robots and their ports are replaced, so a show starts, holds at a wait and
stops in milliseconds, not in the real seconds a show on simulators takes
(test_server_logic.py, test_server_running.py)."""

from __future__ import annotations

import contextlib
import gc
import queue
import threading
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import pytest

from tests.runtime.recording import RecordsCommands
from xgo_show.compiler.schedule import Schedule
from xgo_show.control import server as server_module
from xgo_show.runtime import launch as launch_module
from xgo_show.runtime.events import Event, FaultRaised, StateChanged
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult
from xgo_show.runtime.launch import Endpoint, PerformerContext
from xgo_show.runtime.preflight import PreflightRow

S = ExecutorState


@dataclass
class Stage:
    """What the stand-in robots do and what was done to them.

    Set before a start: ``open_errors`` (by performer: its port does not open), ``problems``
    (by performer: its pre-flight row's problems), ``lead`` (what every performer needs before
    a start), ``stop_error`` (a safe stop that fails, by performer), ``raise_on_open`` (an
    endpoint that raises instead of saying its errors), ``hold_open`` (every open waits for it;
``opening`` says one began). Recorded: the endpoints opened and
    closed (the performers of each), every performer built (``performers``), their contexts,
and the simulator benches ``serve --sim`` made (:class:`StandBench`)."""

    open_errors: dict[str, str] = field(default_factory=dict)
    problems: dict[str, list[str]] = field(default_factory=dict)
    lead: float = 0.0
    stop_error: dict[str, str] = field(default_factory=dict)
    raise_on_open: BaseException | None = None
    opened: list[tuple[str, ...]] = field(default_factory=list)
    closed: list[tuple[str, ...]] = field(default_factory=list)
    performers: dict[str, Stand] = field(default_factory=dict)
    contexts: list[PerformerContext] = field(default_factory=list)
    benches: list[StandBench] = field(default_factory=list)
    hold_open: threading.Event | None = None  # set: every open waits for it
    opening: threading.Event = field(default_factory=threading.Event)  # an open began

    def __post_init__(self) -> None:
        self._out: queue.Queue[tuple[PerformerContext, Event] | None] = queue.Queue()
        self._thread = threading.Thread(target=self._tell, name="stand robots", daemon=True)
        self._thread.start()

    def tell(self, ctx: PerformerContext, event: Event) -> None:
        """Publish ``event`` on the show's bus from the stage's thread, after those told
        before, at its time (not before: a robot holds at a pause's time, not when asked)."""
        self._out.put((ctx, event))

    def _tell(self) -> None:
        while (item := self._out.get()) is not None:
            ctx, event = item
            ctx.clock.sleep_until(event.t)
            ctx.events.publish(event)

    def close(self) -> None:
        self._out.put(None)
        self._thread.join(5.0)

    def endpoints(self, schedule: Schedule, urls: Mapping[str, str]) -> Sequence[Endpoint]:
        return [StandEndpoint(self, schedule, urls)]

    def p(self, name: str) -> Stand:
        return self.performers[name]


class Stand(RecordsCommands):
    """One stand-in robot's performer (see the module docstring)."""

    def __init__(self, name: str, model: str, ctx: PerformerContext, stage: Stage) -> None:
        super().__init__()
        self.name = name
        self.model = model
        self.ctx = ctx
        self.stage = stage
        self.state = S.IDLE
        self.fault: str | None = None
        self.stop_result: SafeStopResult | None = None
        self.readings: Mapping[str, float] = {}
        self.show_time = 0.0
        self._anchor = (0.0, 0.0)  # (clock time, show time) of the last start or resume

    @property
    def done(self) -> bool:
        return self.state.ended

    @property
    def progress(self) -> Progress:
        return Progress(self.name, self.state, self.show_time, 0, 1, "", "")

    def _show_at(self, t: float) -> float:
        return self._anchor[1] + (t - self._anchor[0])

    def _become(self, state: ExecutorState, t: float) -> None:
        self.state = state
        self.stage.tell(self.ctx, StateChanged(t, self.name, state, self.show_time))

    def lead_time(self, offset: float) -> float:
        return self.stage.lead

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        self.calls.append(("start", start_at, offset))
        self._anchor, self.show_time = (start_at, offset), offset
        self._become(S.RUNNING, start_at)

    def pause(self, *, at: float | None = None) -> None:
        super().pause(at=at)
        if self.state is S.RUNNING:
            t = at if at is not None else self.ctx.clock.now()
            self.show_time = self._show_at(t)
            self._become(S.PAUSED, t)

    def resume(self, *, at: float | None = None) -> None:
        super().resume(at=at)
        if self.state is S.PAUSED:
            t = at if at is not None else self.ctx.clock.now()
            self._anchor = (t, self.show_time)
            self._become(S.RUNNING, t)

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        super().seek(show_time, at=at)
        self.show_time = show_time
        if at is not None:
            self._anchor = (at, show_time)

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        self.calls.append(("safe_stop", reason, timeout))
        if self.stop_result is None:
            error = self.stage.stop_error.get(self.name, "")
            self.stop_result = SafeStopResult(self.name, reason, not error, ("stop",), error)
            self._become(S.STOPPED, self.ctx.clock.now())
        return self.stop_result

    def join(self, timeout: float | None = None) -> bool:
        return self.done

    def close(self) -> None:
        self.calls.append(("close",))

    def finish(self) -> None:
        """Its part played to the end."""
        self._become(S.FINISHED, self.ctx.clock.now())

    def fail(self, reason: str) -> None:
        """A fault (a port lost): said as an executor says it."""
        self.fault = reason
        now = self.ctx.clock.now()
        self._become(S.FAILED, now)
        self.stage.tell(self.ctx, FaultRaised(now, self.name, reason))


class StandEndpoint:
    """The stand-in robots of one launch (the ``stand:`` URLs)."""

    def __init__(self, stage: Stage, schedule: Schedule, urls: Mapping[str, str]) -> None:
        self.stage = stage
        self.urls = dict(urls)
        self.models = {p.name: p.model for p in schedule.performers}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.urls)

    def open(self) -> Mapping[str, str]:
        self.stage.opened.append(self.names)
        self.stage.opening.set()
        if self.stage.hold_open is not None:
            assert self.stage.hold_open.wait(60.0)
        if self.stage.raise_on_open is not None:
            raise self.stage.raise_on_open
        return {n: e for n, e in self.stage.open_errors.items() if n in self.urls}

    def preflight(self, *, battery_floor: float) -> list[PreflightRow]:
        return [PreflightRow(n, self.models[n], url, opened=n not in self.stage.open_errors,
                             firmware="stand", problems=list(self.stage.problems.get(n, [])))
                for n, url in self.urls.items()]

    def performers(self, ctx: PerformerContext) -> dict[str, Stand]:
        self.stage.contexts.append(ctx)
        built = {n: Stand(n, self.models[n], ctx, self.stage) for n in self.urls}
        self.stage.performers.update(built)
        return built  # type: ignore[return-value]

    def close(self) -> None:
        self.stage.closed.append(self.names)


@contextlib.contextmanager
def staged(monkeypatch: pytest.MonkeyPatch) -> Iterator[Stage]:
    """Stand-in robots behind every ``stand:`` URL (the scheme removed after)."""
    s = Stage()
    monkeypatch.setitem(launch_module._SCHEMES, "stand", s.endpoints)
    # The runner collects garbage before each show (``hold_gc``): a tenth of a second or more
    # in a test process, for a show of stand-ins that makes no garbage worth collecting.
    monkeypatch.setattr(gc, "collect", lambda generation=2: 0)
    monkeypatch.setattr(server_module, "SimBench",
                        lambda schedule, names: StandBench(s, schedule, names))
    try:
        yield s
    finally:
        s.close()


class StandBench:
    """Stands in for :class:`~xgo_show.sim.bench.SimBench` under ``serve --sim``: a stand-in
    robot (``stand:NAME``) for each performer it is given (kept in the stage's ``benches``)."""

    def __init__(self, stage: Stage, schedule: Schedule, names: Sequence[str]) -> None:
        self.names = list(names)
        models = {p.name: p.model for p in schedule.performers}
        self.models = [models[n] for n in names]  # a simulator needs its robot's model
        self.closed = 0
        stage.benches.append(self)

    @property
    def urls(self) -> dict[str, str]:
        return {n: f"stand:{n}" for n in self.names}

    def close(self) -> None:
        self.closed += 1
