"""A director over a runner whose performers only record what they are told, and a clock the
test sets: the director's decisions, one event at a time, in this process (the director and
trigger-script unit tests)."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

from xgo_show.choreo.sections import Section, Wait
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.control.director import Director, TriggerRefused, WaitReleased, WaitStarted
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import FakeClock
from xgo_show.runtime.events import Event, EventBus, ShowStarted, StateChanged
from xgo_show.runtime.executor import ExecutorState

RUNNING, PAUSED = ExecutorState.RUNNING, ExecutorState.PAUSED
LINK = get_profile("mini").link
T0 = 100.0  # the clock time the show starts


def us(t: float | None) -> float | None:
    return None if t is None else round(t, 6)


@dataclass
class Recorder:
    """A performer that records what it is told, times to the microsecond."""

    name: str
    calls: list[tuple[object, ...]] = field(default_factory=list)
    pauses: list[float | None] = field(default_factory=list)  # as given, not rounded

    def pause(self, *, at: float | None = None) -> None:
        self.pauses.append(at)
        self.calls.append(("pause", us(at)))

    def resume(self, *, at: float | None = None) -> None:
        self.calls.append(("resume", us(at)))

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        self.calls.append(("seek", show_time, us(at)))


class Runner:
    """What the director uses of a show runner; the operator's commands are recorded."""

    def __init__(self, schedule: Schedule, *names: str, lead: float = 0.0) -> None:
        self.schedule = schedule
        self.events = EventBus()
        self.performers = {n: Recorder(n) for n in names}
        self.command_lead = lead
        self.calls: list[tuple[object, ...]] = []

    def pause(self, *, at: float | None = None) -> None:
        self.calls.append(("pause", us(at)))

    def resume(self, *, at: float | None = None) -> None:
        self.calls.append(("resume", us(at)))

    def stop(self, reason: str) -> None:
        self.calls.append(("stop", reason))


class SetClock:
    """A real-time clock (not a FakeClock: the director runs its thread) the test sets."""

    def __init__(self, t: float = T0) -> None:
        self.t = t

    def now(self) -> float:
        return self.t

    def sleep_until(self, deadline: float, interrupt: threading.Event | None = None) -> bool:
        self.t = max(self.t, deadline)
        return True


class RunningClock(SetClock):
    """A real-time clock that runs: T0 when made, then as the monotonic clock goes."""

    def __init__(self) -> None:
        super().__init__()
        self._origin = time.monotonic()

    def now(self) -> float:
        return T0 + (time.monotonic() - self._origin)


# Sections: a at 0; b at 1 waits for 'go'; c at 2 waits for 'encore' at most 0.5 s, else e;
# d at 3 waits for 'bow' at most 0.25 s, else end; e at 4 waits for 'go' (again) at most 1 s
# (then on); the show lasts 6 s.
SECTIONS = (
    Section("a", 0.0),
    Section("b", 1.0, Wait("go")),
    Section("c", 2.0, Wait("encore", 0.5, "e")),
    Section("d", 3.0, Wait("bow", 0.25, "end")),
    Section("e", 4.0, Wait("go", 1.0)),
)


def schedule(sections: tuple[Section, ...] = SECTIONS, end: float = 6.0) -> Schedule:
    perf = PerformerSchedule("rex", "mini", LINK, (), end)
    ivy = PerformerSchedule("ivy", "mini", LINK, (), end)
    return Schedule("t", "t.yaml", (perf, ivy), 50.0, sections=sections)  # type: ignore[arg-type]


class Show:
    """A director over a recording runner; ``seen`` holds the director's own events."""

    def __init__(self, *, virtual: bool = True, lead: float = 0.0,
                 sections: tuple[Section, ...] = SECTIONS, names: tuple[str, ...] = ("rex",),
                 arm_margin: float = 0.1, clock: SetClock | None = None) -> None:
        self.clock: FakeClock | SetClock = (
            clock if clock is not None else FakeClock(T0) if virtual else SetClock(T0))
        self.runner = Runner(schedule(sections), *names, lead=lead)
        self.director = Director(self.runner, clock=self.clock,  # type: ignore[arg-type]
                                 arm_margin=arm_margin)
        self.seen: list[Event] = []
        self.runner.events.subscribe(self.seen.append, WaitStarted, WaitReleased,
                                     TriggerRefused)

    def close(self) -> None:
        """Close the director; none of its listeners may have raised (the bus hides it)."""
        self.director.close()
        bus = self.runner.events
        assert bus.listener_errors == 0, repr(bus.last_listener_error)

    def p(self, name: str = "rex") -> Recorder:
        return self.runner.performers[name]

    def publish(self, event: Event) -> None:
        self.runner.events.publish(event)

    def start(self, offset: float = 0.0, at: float = T0) -> None:
        names = tuple(self.runner.performers)
        self.publish(ShowStarted(at, "t", offset, at, names, "halt_all", 20))

    def state(self, what: ExecutorState, t: float, show: float, name: str = "rex") -> None:
        self.publish(StateChanged(t, name, what, show))

    def waits(self) -> list[tuple[object, ...]]:
        out: list[tuple[object, ...]] = []
        for e in self.seen:
            if isinstance(e, WaitStarted):
                out.append(("started", e.section, e.trigger, us(e.t), e.show_time, e.timeout))
            elif isinstance(e, WaitReleased):
                out.append(("released", e.section, e.trigger, e.how, e.goto, us(e.t)))
            elif isinstance(e, TriggerRefused):
                out.append(("refused", e.trigger, e.reason))
        return out
