"""Hold a running show at its waits and release it on triggers: the show's sections, live.

A :class:`Director` sits beside a :class:`~xgo_show.runtime.show_runner.ShowRunner` and steers
its performers only through the :class:`~xgo_show.runtime.performer.Performer` primitives
(``pause(at=)``, ``resume(at=)``, ``seek(at=)``); it learns where each performer is from the
:class:`~xgo_show.runtime.events.StateChanged` events they publish. Nothing here runs inside an
executor.

How a wait works. Each performer's timeline is known from its last ``RUNNING`` event (clock
time ``t`` is show time ``s``). Shortly before the wait ahead (``arm_margin`` seconds), the
director asks the performer to pause at the clock time of the wait's show time, so no frame of
the next section goes out and every robot holds at rest, in the posture the show gives it there
(the executor's rest frames: speeds and periodic motions to neutral). A trigger for that wait
resumes every performer: catch-up frames restore the state at the wait (periodic motions
included), then the section plays from its first frame, on the next frame the link allows. A
trigger that arrives while the show still plays the section before its wait is kept: the show
goes through the wait without holding (the robots rest for the instant of the catch-up). A
timeout takes the wait's ``else``: ``continue`` (release), a section (jump there: seek, then
play; a section that waits holds again at once) or ``end`` (jump to the show's end: the robots
take its final posture and the show completes).

Visits. Every time the show comes to a wait is a *visit*; each is released once, for every
performer (when, and where the show goes on), and each performer applies that decision when
it reaches the hold itself. Performers never share one "where the show is": each goes through
the same visits in the same order at its own pace, so one a few frames behind the others (in
real time), or any number of sections behind them (in virtual time, where every writer runs on
its own fake clock), still holds at each wait and leaves it at the decided time, and a
performer is never sent a second command before it has acted on the first one.

Operator commands (pause, resume, seek, stop) go through the director too, so a wait that is
armed is never left behind by a pause or a seek.

Virtual time (a :class:`~xgo_show.runtime.clock.FakeClock`, ``dry-run --fast``). Each writer
runs on its own fork of the clock, so "now" means nothing to the director: every decision
carries its own time instead. Waits are armed at once; a trigger or a timeout is given with the
clock time it happens at (:meth:`Director.trigger` and :meth:`Director.expire` take ``at=``;
by default a trigger comes the instant the show holds and a timeout when it runs out), and each
performer resumes at that time on its own clock: the rehearsal keeps the timing the same show
has in real time, without waiting for it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from xgo_show.choreo.sections import (
    CONTINUE,
    END,
    Section,
    section_at,
    section_named,
    trigger_names,
)
from xgo_show.closing import WorkerClosing
from xgo_show.errors import ControlError
from xgo_show.runtime.clock import Clock, FakeClock
from xgo_show.runtime.events import (
    Event,
    ShowEnded,
    ShowPaused,
    ShowResumed,
    ShowStarted,
    StateChanged,
)
from xgo_show.runtime.executor import ExecutorState
from xgo_show.runtime.realtime import HELPER_PRIORITY, enter_show_thread, leave_show_thread
from xgo_show.runtime.show_runner import ShowRunner

__all__ = [
    "ControlError",
    "Director",
    "TriggerOutcome",
    "TriggerRefused",
    "WaitReleased",
    "WaitStarted",
]

_EPS = 1e-6
#: Seconds a performer's reported timeline may be off what the director knows: a relayed
#: performer's state comes from heartbeat answers, stamped on arrival.
_SLACK = 0.05


@dataclass(frozen=True, slots=True)
class WaitStarted(Event):
    """The show holds at ``section``'s start until ``trigger`` (``timeout`` s at most)."""

    section: str
    trigger: str
    show_time: float
    timeout: float | None


@dataclass(frozen=True, slots=True)
class WaitReleased(Event):
    """A wait ended: ``how`` is ``trigger``, ``early`` (a trigger kept before the wait),
    ``timeout`` (then ``goto`` is where the show went on) or ``seek``."""

    section: str
    trigger: str
    how: str
    goto: str


@dataclass(frozen=True, slots=True)
class TriggerRefused(Event):
    """A trigger nobody waits for."""

    trigger: str
    reason: str


@dataclass(frozen=True)
class TriggerOutcome:
    """What a trigger did: released the wait held now, or was kept for the wait ahead."""

    trigger: str
    section: str
    held: bool  # True: the show was holding and now plays; False: kept for the wait ahead


@dataclass
class _Visit:
    """One time the show comes to a wait: held from ``since``, released once for everyone."""

    section: Section
    due: float  # clock time the show comes here, as the release before it says
    since: float | None = None  # clock time the first performer held here
    how: str = ""  # until released: ""; then trigger, early or timeout
    release_at: float = float("-inf")  # clock time the show goes on (at the earliest)
    target: float | None = None  # show time to jump to (a timeout's else), None: play on
    go_at: float | None = None  # real time: the clock time the robots held here go on
    pause_at: float | None = None  # the clock time the last performer was asked to hold here

    @property
    def released(self) -> bool:
        return bool(self.how)

    def then(self, section: Section) -> _Visit:
        """The visit to ``section`` after this one is released."""
        go = max(self.release_at, self.due if self.since is None else self.since)
        start = self.section.start if self.target is None else self.target
        return _Visit(section, go + (section.start - start))


@dataclass
class _Track:
    """What the director knows of one performer."""

    anchor: tuple[float, float] | None = None  # (clock time, show time) while running
    next: int = 0  # the visit it heads to, or holds at (an index in the show's visits)
    armed: bool = False  # asked to pause at that visit's wait
    held: bool = False  # holding there until the visit is released
    hold_t: float = 0.0  # clock time it began holding (its own clock)
    moving: bool = False  # told to resume or seek: its RUNNING is still to come
    on_hold: Callable[[], None] | None = None  # an operator's seek, for when it holds
    on_running: Callable[[], None] | None = None  # an operator's seek, for when it runs
    done: bool = False


@dataclass
class _State:
    phase: str = "idle"  # idle, playing, waiting, paused, ended
    visits: list[_Visit] = field(default_factory=list)
    cur: int = 0  # the first visit not released yet (== len(visits): no wait ahead)
    tracks: dict[str, _Track] = field(default_factory=dict)

    @property
    def ahead(self) -> _Visit | None:
        return self.visits[self.cur] if self.cur < len(self.visits) else None


class Director(WorkerClosing):
    """Plays ``runner``'s show section by section (see the module docstring).

    Keyword options: ``clock`` (the runner's; a :class:`FakeClock` means virtual time),
    ``arm_margin`` (seconds before a wait at which it is armed: bounds how long a pause or a
    seek just before a wait may take to apply). Call :meth:`close` when the show is over.
    """

    def __init__(self, runner: ShowRunner, *, clock: Clock, arm_margin: float = 0.1) -> None:
        self.runner = runner
        self.schedule = runner.schedule
        self.sections = self.schedule.sections
        self.events = runner.events
        self.clock = clock
        self.virtual = isinstance(clock, FakeClock)
        self.arm_margin = arm_margin
        self._cond = threading.Condition(threading.RLock())
        self._s = _State(tracks={name: _Track() for name in runner.performers})
        self._outbox: list[Event] = []
        self._flushing = False
        self._closed = False
        self._sub = self.events.subscribe(
            self._on_event, StateChanged, ShowStarted, ShowEnded, ShowPaused, ShowResumed
        )
        self._thread: threading.Thread | None = None
        if not self.virtual:
            self._thread = threading.Thread(target=self._loop, name="xgo-show director",
                                            daemon=True)
            self._thread.start()

    # ------------------------------------------------------------------ queries

    @property
    def phase(self) -> str:
        """``idle``, ``playing``, ``waiting`` (for a trigger), ``paused`` or ``ended``."""
        return self._s.phase

    @property
    def waiting_for(self) -> Section | None:
        """The section whose wait holds the show now, or None."""
        v = self._s.ahead
        return v.section if v is not None and self._s.phase == "waiting" else None

    @property
    def wait_ahead(self) -> Section | None:
        """The next wait the show will come to (or holds at), or None."""
        v = self._s.ahead
        return v.section if v is not None else None

    def section_now(self, show_time: float) -> Section | None:
        return section_at(self.sections, show_time)

    def hold_ahead(self) -> float | None:
        """The clock time the show holds (or will hold) at the wait ahead, or None. Exact in
        virtual time; in real time, as the release before it said (the robots may come a
        few milliseconds later)."""
        with self._cond:
            v = self._s.ahead
            return None if v is None else v.due if v.since is None else v.since

    # ------------------------------------------------------------------ commands

    def trigger(self, name: str, *, at: float | None = None) -> TriggerOutcome:
        """Fire trigger ``name``: release the wait held now, or keep it for the wait ahead.

        ``at``: the clock time it was fired (default now; in virtual time, the instant the
        show holds). Raises :class:`ControlError` when nobody waits for it (the message says
        what the show waits for, if anything).
        """
        with self._cond:
            s = self._s
            v = s.ahead
            problem = None
            if s.phase in ("idle", "ended"):
                problem = "no show is running" if s.phase == "idle" else "the show is over"
            elif v is None or v.section.wait is None:
                problem = "the show waits for no trigger from here on"
            elif v.section.wait.trigger != name:
                last = s.visits[s.cur - 1] if s.cur > 0 else None
                if (last is not None and _trigger(last.section) == name
                        and last.how in ("trigger", "early")):
                    problem = f"{name!r} was already given for section {last.section.name!r}"
                else:
                    problem = (f"the show {'waits' if s.phase == 'waiting' else 'will wait'} "
                               f"for {v.section.wait.trigger!r} (section {v.section.name!r})")
            if problem is not None:
                if name not in trigger_names(self.sections):
                    problem = f"no section of this show waits for {name!r}; {problem}"
                self._emit(TriggerRefused(self._stamp(at), name, problem))
                raise ControlError(f"trigger {name!r} refused: {problem}")
            assert v is not None
            if at is None:
                at = self.clock.now() if not self.virtual else (
                    v.since if v.since is not None else float("-inf"))
            held = s.phase == "waiting" and (v.since is None or at >= v.since)
            self._release(v, "trigger" if held else "early", at, None, v.section.name)
            return TriggerOutcome(name, v.section.name, held)

    def expire(self, *, at: float | None = None) -> None:
        """Take the held wait's timeout (its ``else``), or, without a timeout, end the show
        with a safe stop saying no trigger came. Used by virtual-time rehearsals: ``at`` (by
        default the wait's start plus its timeout) is when it happens."""
        with self._cond:
            v = self._s.ahead
            if self._s.phase != "waiting" or v is None or v.section.wait is None:
                return
            wait = v.section.wait
            if wait.timeout is None:
                self.runner.stop(f"no trigger {wait.trigger!r} came for section "
                                 f"{v.section.name!r}, which waits without a timeout")
                return
            if at is None:
                at = (v.since or 0.0) + wait.timeout if self.virtual else self.clock.now()
            self._time_out(v, at)

    def pause(self, *, at: float | None = None) -> None:
        """Pause the show (robots at rest) at clock time ``at`` (default: as soon as it can
        take effect). A no-op while it holds at a wait and when a wait is due within
        ``arm_margin`` (the robots are about to hold there anyway). Refused (ControlError)
        for the instant a release or a seek takes to reach every robot (one command at a
        time): the caller is told, and asks again, instead of a pause lost without a word."""
        with self._cond:
            if self._s.phase == "waiting":
                return
            self._need_running("pause")
            tracks = self._s.tracks.values()
            if any(tr.armed for tr in tracks):
                return
            if any(tr.moving for tr in tracks):
                raise ControlError("cannot pause yet: a release or a seek is still reaching "
                                   "the robots; pause again in a moment")
            self.runner.pause(at=at)

    def resume(self, *, at: float | None = None) -> None:
        """Resume a paused show at clock time ``at`` (default: as soon as it can take
        effect); a wait is released by its trigger, not by resume."""
        with self._cond:
            v = self._s.ahead
            if self._s.phase == "waiting" and v is not None and v.section.wait is not None:
                raise ControlError(
                    f"the show waits for trigger {v.section.wait.trigger!r} (section "
                    f"{v.section.name!r}): fire it, or seek"
                )
            if self._s.phase != "paused":
                raise ControlError(f"the show is not paused (it is {self._s.phase})")
            self.runner.resume(at=at)

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        """Jump to ``show_time`` and play from there (paused: on resume), at clock time
        ``at`` (default: as soon as it can take effect)."""
        with self._cond:
            self._need_running("seek")
            if not 0.0 <= show_time < self.schedule.duration:
                raise ControlError(f"seek to {show_time:g} s: outside the show (0 to "
                                   f"{self.schedule.duration:g} s)", code="bad_request")
            s = self._s
            v = s.ahead
            if s.phase == "waiting" and v is not None:
                v.how = "seek"
                self._emit(WaitReleased(self.clock.now(), v.section.name, _trigger(v.section),
                                        "seek", ""))
            self._goto(show_time, paused=s.phase == "paused", at=at)

    def seek_section(self, name: str) -> float:
        """Jump to the start of section ``name``; returns its show time."""
        section = section_named(self.sections, name)
        if section is None:
            names = ", ".join(s.name for s in self.sections) or "none"
            raise ControlError(f"no section named {name!r}; sections: {names}")
        self.seek(section.start)
        return section.start

    def stop(self, reason: str) -> None:
        """Safe-stop the show (the runner does it at once, from its own thread)."""
        self.runner.stop(reason)

    # ------------------------------------------------------------------ internals

    def _need_running(self, what: str) -> None:
        if self._s.phase in ("idle", "ended"):
            raise ControlError(f"cannot {what}: " + (
                "no show is running" if self._s.phase == "idle" else "the show is over"))

    def _emit(self, event: Event) -> None:
        """Publish ``event`` after any event being published now has reached every listener:
        a listener that fires a trigger as a wait starts (a virtual-time rehearsal) makes
        every listener see the wait start before its release."""
        with self._cond:
            self._outbox.append(event)
            if self._flushing:
                return
            self._flushing = True
            try:
                while self._outbox:
                    self.events.publish(self._outbox.pop(0))
            finally:
                self._flushing = False

    def _stamp(self, at: float | None) -> float:
        """An event's time: ``at`` if it is one, else now."""
        return at if at is not None and at != float("-inf") else self.clock.now()

    def _wait_from(self, show_time: float, *, after: bool = False) -> Section | None:
        """The first section that waits at (or, with ``after``, strictly after) ``show_time``."""
        for sec in self.sections:
            if sec.wait is None:
                continue
            if sec.start > show_time + _EPS or (not after and sec.start >= show_time - _EPS):
                return sec
        return None

    def _performer(self, name: str) -> Any:
        return self.runner.performers[name]

    def _when(self) -> float:
        """The clock time a command given now takes effect: now plus the runner's lead (0
        for local robots; room for the network with relayed ones). Always a time, never
        None: a relayed performer sends one command per (operation, time), so two releases
        must carry two times, and every robot of a release acts at the same one."""
        return self.clock.now() + self.runner.command_lead

    def _shared(self, at: float) -> float:
        """``at`` if a command given now can still take effect then, else the first time it
        can: a command for several robots keeps one time wherever it can."""
        return max(at, self._when())

    def _release(self, v: _Visit, how: str, at: float, target: float | None,
                 goto: str) -> None:
        """Release visit ``v`` (held or ahead) as decided at clock time ``at``: the show goes
        on (from ``target``, if given) at ``at`` plus the runner's lead, each performer as it
        holds there; the visit after it is the wait ahead."""
        s = self._s
        v.how = how
        v.release_at = at + self.runner.command_lead
        v.target = target
        # The wait after this one is known before any performer moves on (a performer may
        # report that it runs again from inside the resume).
        index = s.cur
        after = (self._wait_from(target) if target is not None
                 else self._wait_from(v.section.start, after=True))
        if after is not None:
            s.visits.append(v.then(after))
        s.cur += 1
        if s.phase == "waiting":
            s.phase = "playing"
        if not self.virtual:
            # One time for every robot held: the robots of one relay take one command
            # for all of them, sent once per (operation, time).
            v.go_at = max(v.release_at, self._when())
        for name, tr in s.tracks.items():
            if tr.held and tr.next == index and not tr.done:
                self._leave(name, tr, v, v.go_at)
        # Said once the robots are on their way: listeners cost the release no time.
        self._emit(WaitReleased(self._stamp(at if v.since is None else max(at, v.since)),
                                v.section.name, _trigger(v.section), how, goto))
        self._cond.notify_all()

    def _leave(self, name: str, tr: _Track, v: _Visit, at: float | None = None) -> None:
        """Performer ``name``, holding at released visit ``v``, goes on as the release says
        (at clock time ``at``, when given)."""
        # Virtual time: at the release time on the performer's own clock (never before it
        # held). Real time, one that holds after the release: with the robots held at the
        # release, if that is still to come, else as soon as a command can take effect.
        if at is None:
            if self.virtual:
                at = max(v.release_at, tr.hold_t)
            else:
                at = self._shared(v.go_at if v.go_at is not None else v.release_at)
        p = self._performer(name)
        tr.held = False
        tr.moving = True
        tr.next += 1
        if v.target is not None:
            p.seek(v.target, at=at)
        p.resume(at=at)

    def _time_out(self, v: _Visit, at: float) -> None:
        wait = v.section.wait
        assert wait is not None
        if wait.otherwise == CONTINUE:
            self._release(v, "timeout", at, None, v.section.name)
            return
        target = self.schedule.duration if wait.otherwise == END else None
        if target is None:
            section = section_named(self.sections, wait.otherwise)
            assert section is not None  # the loader checked every else: target
            target = section.start
        self._release(v, "timeout", at, target, wait.otherwise)

    def _goto(self, show_time: float, *, paused: bool, at: float | None = None) -> None:
        """An operator's seek: every performer jumps to ``show_time`` now (then plays,
        unless the show is paused), wherever it is; the waits start again from there."""
        s = self._s
        after = self._wait_from(show_time)
        when = self._when() if at is None else self._shared(at)  # one time for all
        s.visits = [_Visit(after, when + after.start - show_time)] if after is not None else []
        s.cur = 0
        for name, tr in s.tracks.items():
            if tr.done:
                continue
            p = self._performer(name)
            tr.anchor = None
            tr.next = 0

            def jump(p: Any = p, tr: _Track = tr, now: bool = False) -> None:
                go = when if now else self._shared(when)
                p.seek(show_time, at=go)
                if not paused:
                    tr.moving = True
                    p.resume(at=go)

            def seek(p: Any = p, tr: _Track = tr) -> None:
                tr.moving = True
                p.seek(show_time, at=self._shared(when))

            tr.on_hold = tr.on_running = None
            if tr.held or paused:
                tr.held = False
                tr.armed = False
                jump(now=True)
            elif tr.armed:
                # About to hold at its wait (its pause is already asked for, perhaps already
                # being applied): jump from there, rather than ask for a second pause.
                tr.on_hold = jump
            elif tr.moving:
                # Its last command is still to take effect: one at a time.
                tr.on_running = seek
            else:
                tr.moving = True  # playing: a seek alone (catch-up frames, then on from there)
                p.seek(show_time, at=when)
        if s.phase == "waiting":
            s.phase = "playing"
        self._cond.notify_all()

    def _on_event(self, event: Event) -> None:
        with self._cond:
            s = self._s
            if isinstance(event, StateChanged):
                self._on_state(event)
            elif isinstance(event, ShowStarted):
                s.phase = "playing"
                after = self._wait_from(event.offset)
                s.visits = ([_Visit(after, event.start_at + after.start - event.offset)]
                            if after is not None else [])
                s.cur = 0
                # Every performer's timeline until it says otherwise: exact, where a relayed
                # performer's RUNNING comes from a heartbeat, stamped when it arrived.
                for tr in s.tracks.values():
                    tr.anchor = (event.start_at, event.offset)
            elif isinstance(event, ShowPaused):
                if s.phase == "playing":
                    s.phase = "paused"
            elif isinstance(event, ShowResumed):
                if s.phase == "paused":
                    s.phase = "playing"
            elif isinstance(event, ShowEnded):
                s.phase = "ended"
                s.visits, s.cur = [], 0
            self._cond.notify_all()

    def _on_state(self, event: StateChanged) -> None:
        tr = self._s.tracks.get(event.performer)
        if tr is None:
            return
        state = event.state
        if state is ExecutorState.RUNNING:
            tr.moving = False
            if tr.on_running is not None:
                action, tr.on_running = tr.on_running, None
                tr.anchor = None
                action()
                return
            if tr.anchor is None or abs(
                tr.anchor[1] + (event.t - tr.anchor[0]) - event.show_time
            ) > _SLACK:
                tr.anchor = (event.t, event.show_time)
            tr.held = False
            # A wait due within arm_margin is armed here, in the performer's writer thread,
            # not when the director's thread next runs: on a busy machine that may be after
            # the section's first frame went out (a short section after a release).
            self._arm(event.performer, tr, event.t if self.virtual else self.clock.now())
            return
        tr.anchor = None
        if state is ExecutorState.PAUSED:
            if not tr.armed:
                return  # an operator's pause (refused while a wait is armed)
            tr.armed = False  # any hold uses up the performer's pause request
            if tr.on_hold is not None:
                action, tr.on_hold = tr.on_hold, None
                action()  # sent elsewhere by a seek before it got here
                return
            s = self._s
            if tr.next >= len(s.visits):
                return  # the show is over
            v = s.visits[tr.next]
            tr.hold_t = event.t
            if v.released:
                self._leave(event.performer, tr, v)  # released before it got here
                return
            tr.held = True
            if v.since is None:
                v.since = event.t
                s.phase = "waiting"
                wait = v.section.wait
                assert wait is not None
                self._emit(WaitStarted(event.t, v.section.name, wait.trigger, v.section.start,
                                       wait.timeout))
        elif state.ended:
            tr.done = True

    def _arm(self, name: str, tr: _Track, now: float) -> float | None:
        """Arm the wait ahead of one performer if it is due; else when it will be due."""
        s = self._s
        if (tr.anchor is None or tr.armed or tr.held or tr.moving or tr.done
                or s.phase not in ("playing", "waiting")):
            return None
        clock_t, show_t = tr.anchor
        while tr.next < len(s.visits):
            v = s.visits[tr.next]
            at = clock_t + (v.section.start - show_t)
            # A wait released for a time before this performer gets there (an early
            # trigger) is played through; any other it holds at, to leave it as decided.
            if not (v.released and v.target is None and v.release_at <= at):
                break
            tr.next += 1
        else:
            return None
        if not self.virtual and at - self.arm_margin > now:
            return at - self.arm_margin
        if v.pause_at is not None and abs(at - v.pause_at) < 1e-6:
            # The same instant, computed from another performer's timeline: the same float,
            # so the robots of one relay get one pause (one command per operation and time).
            at = v.pause_at
        v.pause_at = at
        tr.armed = True
        self._performer(name).pause(at=at)
        return None

    def _loop(self) -> None:
        # A trigger's handler (on a raised Zenoh thread) takes the lock this thread holds while
        # it arms a wait: above normal threads, so it is never preempted holding it.
        raised = enter_show_thread(HELPER_PRIORITY)
        try:
            self._direct()
        finally:
            if raised:
                leave_show_thread()

    def _direct(self) -> None:
        with self._cond:
            while not self._closed:
                now = self.clock.now()
                due: list[float] = []
                for name, tr in self._s.tracks.items():
                    when = self._arm(name, tr, now)
                    if when is not None:
                        due.append(when)
                v = self._s.ahead
                if (self._s.phase == "waiting" and v is not None and v.section.wait is not None
                        and v.section.wait.timeout is not None and v.since is not None):
                    expiry = v.since + v.section.wait.timeout
                    if now >= expiry:
                        self._time_out(v, now)
                        continue
                    due.append(expiry)
                timeout = None if not due else max(0.0, min(due) - self.clock.now())
                self._cond.wait(timeout)


def _trigger(section: Section) -> str:
    return section.wait.trigger if section.wait is not None else ""
