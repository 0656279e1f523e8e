"""The behaviour engine: decides which rule runs and what each performer plays.

A pure component: no threads, no I/O, no clock of its own. The caller feeds it what happens,
each with the clock time it happened (:meth:`Engine.start`, :meth:`Engine.trigger`,
:meth:`Engine.on_event` for runtime events such as
:class:`~xgo_show.runtime.events.TelemetryRead` and
:class:`~xgo_show.runtime.events.FaultRaised`, :meth:`Engine.routine_ended` from the stage),
calls :meth:`Engine.advance` when :meth:`Engine.next_deadline` comes, and the engine drives a
:class:`Stage` (play a routine on performers, rest them, safe-stop them, publish). The same
engine runs on a real clock (``behave``) and on virtual time (``behave --fast``, the tests).

Rules: any trigger of ``when`` fires a rule; if every condition of ``if`` holds, a run of its
actions starts (or not, by ``mode``: ``single`` ignores a firing while a run is going,
``restart`` cancels that run, ``queued`` queues up to :data:`QUEUE_LIMIT` runs, ``parallel``
starts another). ``play`` waits for the routine's end; ``loop`` does not (the performers loop
until something else takes them). Ownership: a performer belongs to the rule that last played
on it; a rule of lower rank (safety rules first, then ``priority``) cannot take it, a rule of
the same or a higher rank pre-empts it (the stage hands over through the rest posture, then
the default posture).

Telemetry triggers have hysteresis: ``battery_below: 20, clear: 30`` fires once when the
battery reads below 20 and again only after it has read 30 or more.
"""

from __future__ import annotations

import datetime as dt
import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol, TypeVar

from pydantic import BaseModel

from xgo_show.behave.loader import Behaviour, played, write_key
from xgo_show.behave.model import (
    After,
    AllOf,
    AnyOf,
    AtTime,
    BatteryBelow,
    ConditionModel,
    Every,
    InSet,
    LedCue,
    Loop,
    NotC,
    Offline,
    Online,
    PerformerIs,
    Play,
    Publish,
    RemoteTrigger,
    RoutineEnded,
    RuleModel,
    SafeStop,
    SetCue,
    Startup,
    Stop,
    Switch,
    TelemetryCondition,
    TiltBeyond,
    TimeCondition,
    Wait,
)
from xgo_show.families import get_family
from xgo_show.profiles import get_profile
from xgo_show.runtime.events import Event, FaultRaised, TelemetryRead

__all__ = ["QUEUE_LIMIT", "BehaviourNote", "Engine", "Stage"]

QUEUE_LIMIT = 10
_T = TypeVar("_T", bound=BaseModel)
FALLEN_TILT = 90.0  # degrees: what a robot reporting "fallen" (status, fault) counts as


@dataclass(frozen=True, slots=True)
class BehaviourNote(Event):
    """Something the engine decided: a rule ``fired``, was ``skipped``, ``refused`` a
    performer, an ``action`` ran, a run was ``cut``; ``text`` says it for people."""

    rule: str
    kind: str
    text: str


class Stage(Protocol):
    """What the engine drives: the performers' ports (or simulators, or virtual robots)."""

    def play(self, routine: str, performers: tuple[str, ...], play_id: int, t: float) -> None:
        """Play ``routine``'s parts for ``performers`` now, handing over from whatever they
        play; report each performer's end with :meth:`Engine.routine_ended`."""
        ...

    def rest(self, performers: tuple[str, ...], t: float) -> None:
        """End what the performers play through the rest posture."""
        ...

    def safe_stop(self, performers: tuple[str, ...], reason: str, t: float) -> None:
        """The full safe stop on the performers."""
        ...

    def write(self, key: str, performers: tuple[str, ...], t: float) -> None:
        """Send the frames of a ``set``/``led`` action (``Behaviour.writes[key]``) to the
        performers now, beside whatever they play."""
        ...


@dataclass
class _Claim:
    rule: str
    rank: tuple[int, int]
    routine: str
    play_id: int
    loop: bool
    run: _Run | None


@dataclass
class _Run:
    rule: RuleModel
    pc: int = 0
    until: float | None = None  # waiting for this clock time
    waiting: set[str] = field(default_factory=set)  # performers whose routine must end
    done: bool = False


def _rank(rule: RuleModel) -> tuple[int, int]:
    return (1 if rule.safety else 0, rule.priority)


class Engine:
    """Runs a :class:`Behaviour`'s rules against a :class:`Stage` (see the module doc).

    ``emit`` receives every :class:`BehaviourNote` (publish them on an event bus, print them);
    ``wall`` gives the local wall-clock time of a clock time (for ``at:`` and ``time:``).
    """

    def __init__(
        self,
        behaviour: Behaviour,
        stage: Stage,
        *,
        emit: Callable[[Event], None],
        wall: Callable[[float], dt.datetime],
    ) -> None:
        self.behaviour = behaviour
        self.model = behaviour.model
        self.stage = stage
        self.emit = emit
        self.wall = wall
        self.active_set = self.model.initial
        self.claims: dict[str, _Claim] = {}
        self.readings: dict[str, dict[str, float]] = {p: {} for p in self.model.performers}
        self._profiles = {p: get_profile(ref.model) for p, ref in self.model.performers.items()}
        self.last_seen: dict[str, float] = {}
        self.offline: set[str] = set()
        self._armed: dict[tuple[int, int, str], bool] = {}
        self._timers: dict[tuple[int, int], float] = {}
        self._runs: list[_Run] = []
        self._queues: dict[str, list[str]] = {}
        self._ids = itertools.count(1)

    # ------------------------------------------------------------------ inputs

    def start(self, now: float) -> None:
        """Start-up: arm the timers and fire ``startup`` triggers."""
        for p in self.model.performers:
            self.last_seen[p] = now
        self._enter_set(now)

    def trigger(self, name: str, now: float) -> bool:
        """A remote trigger arrived; returns whether any rule waits for it."""
        hit = False
        for rule, _, trig in self._triggers(RemoteTrigger):
            if trig.trigger == name:
                hit = True
                self._fire(rule, f"trigger {name}", now)
        return hit

    def on_event(self, event: Event) -> None:
        """A runtime event: telemetry readings and faults feed the telemetry triggers."""
        if isinstance(event, TelemetryRead):
            self._reading(event.performer, event.name, event.value, event.t)
        elif isinstance(event, FaultRaised) and "fallen" in event.reason:
            self._reading(event.performer, "status_fallen", 1.0, event.t)

    def routine_ended(self, performer: str, play_id: int, now: float, completed: bool) -> None:
        """The stage says a performer's part of play ``play_id`` ended (``completed``: ran to
        its end, not cut or stopped)."""
        claim = self.claims.get(performer)
        if claim is None or claim.play_id != play_id:
            return  # a play already handed over to another
        routine = claim.routine
        if claim.loop and completed:
            claim.play_id = next(self._ids)
            self.stage.play(routine, (performer,), claim.play_id, now)
            return
        del self.claims[performer]
        for run in list(self._runs):
            if performer in run.waiting:
                run.waiting.discard(performer)
                if not run.waiting:
                    self._step(run, now)
        if completed:
            for rule, _, trig in self._triggers(RoutineEnded):
                if trig.routine_ended == routine and self._covers(trig.performers, performer):
                    self._fire(rule, f"{routine} ended on {performer}", now)

    def lost(self, performer: str, cause: str, now: float) -> None:
        """The performer cannot be reached any more (its relay went silent): it is offline
        now, whatever seconds without telemetry its ``offline`` triggers wait for."""
        if performer not in self.readings:
            return
        self.offline.add(performer)
        for rule, t, trig in self._triggers(Offline):
            armed = (self.model.rules.index(rule), t, performer)
            if self._covers(trig.performers, performer) and self._armed.get(armed, True):
                self._armed[armed] = False
                self._fire(rule, f"{performer} offline ({cause})", now)

    def advance(self, now: float) -> None:
        """Run everything due at or before ``now``: timers, waits, offline checks."""
        for key, due in sorted(self._timers.items(), key=lambda kv: kv[1]):
            # A rule fired here may switch sets, which arms the timers again from the switch:
            # a timer no longer due when this list was made is left to its new time.
            if due > now or self._timers.get(key) != due:
                continue
            r, t = key
            rule, trig = self.model.rules[r], self.model.rules[r].when[t]
            if isinstance(trig, Every):
                self._timers[key] = due + trig.every
                cause = f"every {trig.every:g} s"
            elif isinstance(trig, AtTime):
                self._timers[key] = self._next_wall(trig.at, now + 1.0)
                cause = f"at {trig.at}"
            else:
                del self._timers[key]
                cause = f"after {trig.after:g} s" if isinstance(trig, After) else "timer"
            if self._active(rule):
                self._fire(rule, cause, due)
        for run in list(self._runs):
            if run.until is not None and run.until <= now:
                run.until = None
                self._step(run, now)
        for rule, t, trig in self._triggers(Offline):
            for p in self._performers(trig.performers):
                armed = (self.model.rules.index(rule), t, p)
                if self.last_seen.get(p, now) + trig.offline <= now and self._armed.get(
                    armed, True
                ):
                    self._armed[armed] = False
                    self.offline.add(p)
                    self._fire(rule, f"{p} offline ({trig.offline:g} s without telemetry)", now)

    def next_deadline(self) -> float | None:
        """The next clock time :meth:`advance` has something to do (None: nothing planned)."""
        times = list(self._timers.values())
        times += [r.until for r in self._runs if r.until is not None]
        for rule, t, trig in self._triggers(Offline):
            for p in self._performers(trig.performers):
                if self._armed.get((self.model.rules.index(rule), t, p), True):
                    times.append(self.last_seen.get(p, 0.0) + trig.offline)
        return min(times) if times else None

    def playing(self, performer: str) -> str | None:
        """The routine a performer plays now (None: idle)."""
        claim = self.claims.get(performer)
        return None if claim is None else claim.routine

    # ------------------------------------------------------------------ triggers

    def _triggers(self, kind: type[_T]) -> list[tuple[RuleModel, int, _T]]:
        """Every trigger of ``kind`` of the rules active now, with its rule and index."""
        out: list[tuple[RuleModel, int, _T]] = []
        for rule in self.model.rules:
            if self._active(rule):
                out += [(rule, t, trig) for t, trig in enumerate(rule.when)
                        if isinstance(trig, kind)]
        return out

    def _active(self, rule: RuleModel) -> bool:
        return rule.sets is None or self.active_set in rule.sets

    def _performers(self, names: list[str] | None) -> list[str]:
        return list(names) if names is not None else list(self.model.performers)

    @staticmethod
    def _covers(names: list[str] | None, performer: str) -> bool:
        return names is None or performer in names

    def _reading(self, performer: str, name: str, value: float, now: float) -> None:
        if performer not in self.readings:
            return
        readings = self.readings[performer]
        readings[name] = value
        if name == "status":
            profile = self._profiles[performer]
            fallen = get_family(profile).telemetry_fault(profile, name, value) is not None
            readings["status_fallen"] = 1.0 if fallen else 0.0
        self.last_seen[performer] = now
        if performer in self.offline:
            self.offline.discard(performer)
            for rule, t, _ in self._triggers(Offline):
                self._armed[(self.model.rules.index(rule), t, performer)] = True
            for rule, _, online in self._triggers(Online):
                if self._covers(online.performers, performer):
                    self._fire(rule, f"{performer} back online", now)
        tilt = self._tilt(readings)
        for rule, t, trig in self._triggers(BatteryBelow):
            battery = readings.get("battery")
            if battery is None or not self._covers(trig.performers, performer):
                continue
            clear = trig.clear if trig.clear is not None else trig.battery_below + 5
            self._edge(rule, t, performer, battery < trig.battery_below, battery >= clear,
                       f"{performer} battery {battery:.0f}% < {trig.battery_below:g}%", now)
        for rule, t, tilt_trig in self._triggers(TiltBeyond):
            if tilt is None or not self._covers(tilt_trig.performers, performer):
                continue
            clear = tilt_trig.clear if tilt_trig.clear is not None else tilt_trig.tilt_beyond / 2
            self._edge(rule, t, performer, tilt > tilt_trig.tilt_beyond, tilt < clear,
                       f"{performer} tilted {tilt:.0f} deg > {tilt_trig.tilt_beyond:g}", now)

    @staticmethod
    def _tilt(readings: Mapping[str, float]) -> float | None:
        if readings.get("status_fallen"):
            return FALLEN_TILT
        angles = [abs(readings[k]) for k in ("imu_roll", "imu_pitch") if k in readings]
        return max(angles) if angles else None

    def _edge(
        self, rule: RuleModel, t: int, performer: str, on: bool, clear: bool, cause: str,
        now: float,
    ) -> None:
        key = (self.model.rules.index(rule), t, performer)
        if on and self._armed.get(key, True):
            self._armed[key] = False
            self._fire(rule, cause, now)
        elif clear:
            self._armed[key] = True

    def _enter_set(self, now: float) -> None:
        self._timers = {}
        for r, rule in enumerate(self.model.rules):
            if not self._active(rule):
                continue
            for t, trig in enumerate(rule.when):
                if isinstance(trig, After):
                    self._timers[(r, t)] = now + trig.after
                elif isinstance(trig, Every):
                    self._timers[(r, t)] = now + trig.every
                elif isinstance(trig, AtTime):
                    self._timers[(r, t)] = self._next_wall(trig.at, now)
        for rule, _, _ in self._triggers(Startup):
            self._fire(rule, "start-up" if self.active_set is None else
                       f"start-up of set {self.active_set}", now)

    def _next_wall(self, hhmm: str, now: float) -> float:
        """The clock time of the next ``HH:MM[:SS]`` (local) at or after ``now``."""
        here = self.wall(now)
        parts = [int(x) for x in hhmm.split(":")] + [0]
        target = here.replace(hour=parts[0], minute=parts[1], second=parts[2], microsecond=0)
        if target < here:
            target += dt.timedelta(days=1)
        return now + (target - here).total_seconds()

    # ------------------------------------------------------------------ rules and runs

    def _note(self, rule: str, kind: str, text: str, now: float) -> None:
        self.emit(BehaviourNote(now, rule, kind, text))

    def _fire(self, rule: RuleModel, cause: str, now: float) -> None:
        if rule.if_ is not None and not self._holds(rule.if_, now):
            self._note(rule.name, "skipped", f"{cause}: conditions do not hold", now)
            return
        running = [r for r in self._runs if r.rule is rule]
        if running and rule.mode == "single":
            self._note(rule.name, "skipped", f"{cause}: already running (single)", now)
            return
        if running and rule.mode == "queued":
            queue = self._queues.setdefault(rule.name, [])
            if len(queue) >= QUEUE_LIMIT:
                self._note(rule.name, "skipped", f"{cause}: queue full ({QUEUE_LIMIT})", now)
            else:
                queue.append(cause)
                self._note(rule.name, "queued", f"{cause}: queued ({len(queue)} waiting)", now)
            return
        if running and rule.mode == "restart":
            for run in running:
                self._end(run, now, cut=f"restarted by {cause}", follow=False)
        self._note(rule.name, "fired", cause, now)
        run = _Run(rule)
        self._runs.append(run)
        self._step(run, now)

    def _end(self, run: _Run, now: float, *, cut: str = "", follow: bool = True) -> None:
        if run.done:
            return
        run.done = True
        if run in self._runs:
            self._runs.remove(run)
        for claim in self.claims.values():
            if claim.run is run:
                claim.run = None
        if cut:
            self._note(run.rule.name, "cut", cut, now)
        if follow:
            self._next_queued(run.rule, now)

    def _next_queued(self, rule: RuleModel, now: float) -> None:
        """Start the next run ``rule`` has queued, if any."""
        queue = self._queues.get(rule.name)
        if queue:
            cause = queue.pop(0)
            self._note(rule.name, "fired", f"{cause} (from the queue)", now)
            nxt = _Run(rule)
            self._runs.append(nxt)
            self._step(nxt, now)

    def _step(self, run: _Run, now: float) -> None:
        """Run actions until one waits (for a time or a routine's end) or the run ends."""
        actions = run.rule.do
        while not run.done and run.pc < len(actions):
            action = actions[run.pc]
            run.pc += 1
            name = run.rule.name
            if isinstance(action, (Play, Loop)):
                routine = played(action)
                claimed = self._claim(run, routine, action.performers, now)
                if claimed is None:
                    self._end(run, now)
                    return
                perfs, cut = claimed
                play_id = next(self._ids)
                loop = isinstance(action, Loop)
                for p in perfs:
                    self.claims[p] = _Claim(name, _rank(run.rule), routine, play_id, loop, run)
                verb = "loops" if loop else "plays"
                self._note(name, "action", f"{', '.join(perfs)} {verb} {routine}", now)
                self.stage.play(routine, perfs, play_id, now)
                if not loop:
                    run.waiting = set(perfs)
                # The runs cut go on with their queues only now that this play holds the
                # performers (before, a queued run took them back and was then left waiting
                # for a play handed over to this one: its rule blocked for good).
                for other in cut:
                    self._next_queued(other.rule, now)
                if not loop:
                    return
            elif isinstance(action, (Stop, SafeStop)):
                value = action.stop if isinstance(action, Stop) else action.safe_stop
                perfs = tuple(self.model.performers) if value == "all" else tuple(value)
                for p in perfs:
                    self.claims.pop(p, None)
                if isinstance(action, Stop):
                    self._note(name, "action", f"{', '.join(perfs)} rest", now)
                    self.stage.rest(perfs, now)
                else:
                    self._note(name, "action", f"{', '.join(perfs)} safe stop", now)
                    self.stage.safe_stop(perfs, f"rule {name}", now)
            elif isinstance(action, (SetCue, LedCue)):
                kind, cue = ("set", action.set) if isinstance(action, SetCue) else (
                    "led", action.led)
                perfs = tuple(action.performers or self.model.performers)
                what = " ".join(f"{k}={v}" for k, v in cue.items())
                self._note(name, "action", f"{', '.join(perfs)} {kind} {what}", now)
                self.stage.write(write_key(name, run.pc - 1), perfs, now)
            elif isinstance(action, Wait):
                run.until = now + action.wait
                return
            elif isinstance(action, Publish):
                self._note(name, "published", action.publish, now)
            elif isinstance(action, Switch):
                self._switch(action.switch, run, now)
        self._end(run, now)

    def _claim(
        self, run: _Run, routine: str, wanted: list[str] | None, now: float
    ) -> tuple[tuple[str, ...], list[_Run]] | None:
        """The performers ``run`` may play ``routine`` on, and the runs it cuts (pre-empting
        lower or equal ranks: their queues are left to the caller); None (and a note) if a
        higher-ranked rule holds one of them."""
        has = self.behaviour.routine_performers(routine)
        perfs = tuple(p for p in has if wanted is None or p in wanted)
        rank = _rank(run.rule)
        for p in perfs:
            claim = self.claims.get(p)
            if claim is not None and claim.rank > rank and claim.run is not run:
                self._note(run.rule.name, "refused",
                           f"{p} is held by rule {claim.rule} (higher rank)", now)
                return None
        cut: list[_Run] = []
        for p in perfs:
            claim = self.claims.get(p)
            if claim is not None and claim.run is not None and claim.run is not run:
                other = claim.run
                if p in other.waiting:
                    self._end(other, now, cut=f"{p} taken by rule {run.rule.name}",
                              follow=False)
                    cut.append(other)
        return perfs, cut

    def _switch(self, name: str, run: _Run, now: float) -> None:
        if name == self.active_set:
            return
        self._note(run.rule.name, "action", f"switch to set {name}", now)
        self.active_set = name
        for other in list(self._runs):
            if other is not run and not self._active(other.rule):
                self._end(other, now, cut=f"set {name} does not include it", follow=False)
        inactive = [
            p for p, c in self.claims.items()
            if c.loop and not self._active(self._rule(c.rule))
        ]
        for p in inactive:
            del self.claims[p]
        if inactive:
            self.stage.rest(tuple(inactive), now)
        self._enter_set(now)

    def _rule(self, name: str) -> RuleModel:
        return next(r for r in self.model.rules if r.name == name)

    # ------------------------------------------------------------------ conditions

    def _holds(self, cond: ConditionModel, now: float) -> bool:
        if isinstance(cond, AllOf):
            return all(self._holds(c, now) for c in cond.and_)
        if isinstance(cond, AnyOf):
            return any(self._holds(c, now) for c in cond.or_)
        if isinstance(cond, NotC):
            return not self._holds(cond.not_, now)
        if isinstance(cond, PerformerIs):
            playing = self.playing(cond.performer)
            if cond.is_ == "idle":
                return playing is None
            return playing is not None and cond.routine in (None, playing)
        if isinstance(cond, TelemetryCondition):
            test = cond.telemetry
            readings = self.readings.get(test.performer, {})
            value = self._tilt(readings) if test.name == "tilt" else readings.get(test.name)
            if value is None:
                return False
            return (test.below is None or value < test.below) and (
                test.above is None or value > test.above
            )
        if isinstance(cond, TimeCondition):
            clock = self.wall(now).strftime("%H:%M:%S")
            after, before = cond.time.after, cond.time.before
            a = _seconds(after) if after else None
            b = _seconds(before) if before else None
            x = _seconds(clock)
            if a is not None and b is not None and b < a:  # a window across midnight
                return x >= a or x < b
            return (a is None or x >= a) and (b is None or x < b)
        if isinstance(cond, InSet):
            return self.active_set == cond.in_set
        raise AssertionError(f"unknown condition {cond!r}")


def _seconds(hhmm: str) -> int:
    parts = [int(x) for x in hhmm.split(":")] + [0]
    return parts[0] * 3600 + parts[1] * 60 + parts[2]
