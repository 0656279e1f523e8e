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

Operator commands (pause, resume, seek, stop) go through the director too, so a wait that is
armed is never left behind by a pause or a seek. With a :class:`~xgo_show.runtime.clock.FakeClock`
(``dry-run --fast``) waits are armed at once and timeouts are taken only on request
(:meth:`Director.expire`): virtual time does not pass while the show waits.
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
class _Track:
    """What the director knows of one performer."""

    anchor: tuple[float, float] | None = None  # (clock time, show time) while running
    armed: Section | None = None  # the wait it was asked to pause at
    held: bool = False  # holding at the current wait
    on_hold: Callable[[], None] | None = None  # what to do when it reaches its hold
    done: bool = False


@dataclass
class _Wait:
    section: Section
    released: bool = False
    since: float | None = None  # clock time the show began holding


@dataclass
class _State:
    phase: str = "idle"  # idle, playing, waiting, paused, ended
    wait: _Wait | None = None  # the wait ahead (playing) or held (waiting)
    tracks: dict[str, _Track] = field(default_factory=dict)


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
        w = self._s.wait
        return w.section if w is not None and self._s.phase == "waiting" else None

    @property
    def wait_ahead(self) -> Section | None:
        """The next wait the show will come to (or holds at), or None."""
        w = self._s.wait
        return w.section if w is not None else None

    def section_now(self, show_time: float) -> Section | None:
        return section_at(self.sections, show_time)

    # ------------------------------------------------------------------ commands

    def trigger(self, name: str) -> TriggerOutcome:
        """Fire trigger ``name``: release the wait held now, or keep it for the wait ahead.

        Raises :class:`ControlError` when nobody waits for it (the message says what the show
        waits for, if anything).
        """
        with self._cond:
            s = self._s
            w = s.wait
            problem = None
            if s.phase in ("idle", "ended"):
                problem = "no show is running" if s.phase == "idle" else "the show is over"
            elif w is None or w.section.wait is None:
                problem = "the show waits for no trigger from here on"
            elif w.section.wait.trigger != name:
                problem = (f"the show {'waits' if s.phase == 'waiting' else 'will wait'} for "
                           f"{w.section.wait.trigger!r} (section {w.section.name!r})")
            elif w.released:
                problem = f"{name!r} was already given for section {w.section.name!r}"
            if problem is not None:
                if name not in trigger_names(self.sections):
                    problem = f"no section of this show waits for {name!r}; {problem}"
                self.events.publish(TriggerRefused(self.clock.now(), name, problem))
                raise ControlError(f"trigger {name!r} refused: {problem}")
            assert w is not None and w.section.wait is not None
            held = s.phase == "waiting"
            self._release(w, "trigger" if held else "early", w.section.name)
            return TriggerOutcome(name, w.section.name, held)

    def expire(self) -> None:
        """Take the held wait's timeout now (its ``else``), or, without a timeout, end the
        show with a safe stop saying no trigger came. Used by virtual-time rehearsals."""
        with self._cond:
            w = self._s.wait
            if self._s.phase != "waiting" or w is None or w.section.wait is None:
                return
            if w.section.wait.timeout is None:
                self.runner.stop(f"no trigger {w.section.wait.trigger!r} came for section "
                                 f"{w.section.name!r}, which waits without a timeout")
                return
            self._time_out(w)

    def pause(self) -> None:
        """Pause the show (robots at rest). A no-op while it holds at a wait, and when a wait
        is due within ``arm_margin`` (the robots are about to hold there anyway)."""
        with self._cond:
            if self._s.phase == "waiting":
                return
            self._need_running("pause")
            if any(tr.armed is not None for tr in self._s.tracks.values()):
                return
            self.runner.pause()

    def resume(self) -> None:
        """Resume a paused show (a wait is released by its trigger, not by resume)."""
        with self._cond:
            w = self._s.wait
            if self._s.phase == "waiting" and w is not None and w.section.wait is not None:
                raise ControlError(
                    f"the show waits for trigger {w.section.wait.trigger!r} (section "
                    f"{w.section.name!r}): fire it, or seek"
                )
            if self._s.phase != "paused":
                raise ControlError(f"the show is not paused (it is {self._s.phase})")
            self.runner.resume()

    def seek(self, show_time: float) -> None:
        """Jump to ``show_time`` and play from there (paused: on resume)."""
        with self._cond:
            self._need_running("seek")
            if not 0.0 <= show_time < self.schedule.duration:
                raise ControlError(f"seek to {show_time:g} s: outside the show (0 to "
                                   f"{self.schedule.duration:g} s)")
            s = self._s
            if s.phase == "waiting" and s.wait is not None:
                self.events.publish(WaitReleased(self.clock.now(), s.wait.section.name,
                                                 _trigger(s.wait.section), "seek", ""))
            self._goto(show_time, paused=s.phase == "paused")

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

    def _wait_from(self, show_time: float, *, after: bool = False) -> _Wait | None:
        """The first wait at (or, with ``after``, strictly after) ``show_time``."""
        for sec in self.sections:
            if sec.wait is None:
                continue
            if sec.start > show_time + _EPS or (not after and sec.start >= show_time - _EPS):
                return _Wait(sec)
        return None

    def _performer(self, name: str) -> Any:
        return self.runner.performers[name]

    def _when(self) -> float:
        """The clock time a command given now takes effect: now plus the runner's lead (0
        for local robots; room for the network with relayed ones). Always a time, never
        None: a relayed performer sends one command per (operation, time), so two releases
        must carry two times, and every robot of a release acts at the same one."""
        return self.clock.now() + self.runner.command_lead

    def _release(self, w: _Wait, how: str, goto: str) -> None:
        """End wait ``w`` (held or ahead): every performer plays on; the next wait is ahead."""
        w.released = True
        when = self._when()
        for name, tr in self._s.tracks.items():
            if tr.done:
                continue
            if tr.held:
                tr.held = False
                self._performer(name).resume(at=when)
            elif tr.armed is w.section:
                # Not at its hold yet (a few ms behind the others): resume it on arrival.
                p = self._performer(name)
                tr.on_hold = lambda p=p: p.resume(at=self._when())
        self.events.publish(WaitReleased(self.clock.now(), w.section.name, _trigger(w.section),
                                         how, goto))
        self._s.wait = self._wait_from(w.section.start, after=True)
        if self._s.phase == "waiting":
            self._s.phase = "playing"
        self._cond.notify_all()

    def _time_out(self, w: _Wait) -> None:
        wait = w.section.wait
        assert wait is not None
        if wait.otherwise == CONTINUE:
            self._release(w, "timeout", w.section.name)
            return
        target = self.schedule.duration if wait.otherwise == END else None
        if target is None:
            section = section_named(self.sections, wait.otherwise)
            assert section is not None  # the loader checked every else: target
            target = section.start
        self.events.publish(WaitReleased(self.clock.now(), w.section.name, wait.trigger,
                                         "timeout", wait.otherwise))
        self._goto(target, paused=False)

    def _goto(self, show_time: float, *, paused: bool) -> None:
        """Every performer jumps to ``show_time`` (then plays, unless the show is paused)."""
        s = self._s
        for name, tr in s.tracks.items():
            if tr.done:
                continue
            p = self._performer(name)
            tr.anchor = None

            def jump(p: Any = p, paused: bool = paused) -> None:
                when = self._when()
                p.seek(show_time, at=when)
                if not paused:
                    p.resume(at=when)

            if tr.held or paused:
                tr.held = False
                tr.armed = None
                tr.on_hold = None
                jump()
            elif tr.armed is not None:
                # About to hold at its wait (its pause is already asked for, perhaps already
                # being applied): jump from there, rather than ask for a second pause.
                tr.on_hold = jump
            else:
                # Playing: pause now, jump, go on.
                p.pause(at=self._when())
                jump()
        s.wait = self._wait_from(show_time)
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
                s.wait = self._wait_from(event.offset)
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
                s.wait = None
            self._cond.notify_all()

    def _on_state(self, event: StateChanged) -> None:
        tr = self._s.tracks.get(event.performer)
        if tr is None:
            return
        state = event.state
        if state is ExecutorState.RUNNING:
            if tr.anchor is None or abs(
                tr.anchor[1] + (event.t - tr.anchor[0]) - event.show_time
            ) > _SLACK:
                tr.anchor = (event.t, event.show_time)
            tr.held = False
            if self.virtual:
                self._arm(event.performer, tr, self.clock.now())
            return
        tr.anchor = None
        if state is ExecutorState.PAUSED:
            armed, tr.armed = tr.armed, None  # any hold uses up the performer's pause request
            if armed is None or abs(event.show_time - armed.start) > _SLACK:
                return  # not this wait's hold (pause() is a no-op while a wait is armed)
            action, tr.on_hold = tr.on_hold, None
            if action is not None:
                action()  # released (or sent elsewhere) before it got here
                return
            tr.held = True
            w = self._s.wait
            if w is not None and w.section is armed and self._s.phase != "waiting":
                self._s.phase = "waiting"
                w.since = event.t
                assert armed.wait is not None
                self.events.publish(WaitStarted(event.t, armed.name, armed.wait.trigger,
                                                armed.start, armed.wait.timeout))
        elif state in (ExecutorState.FINISHED, ExecutorState.STOPPED, ExecutorState.FAILED):
            tr.done = True

    def _arm(self, name: str, tr: _Track, now: float) -> float | None:
        """Arm the wait ahead on one performer if it is due; else when it will be due."""
        w = self._s.wait
        if (w is None or w.released or tr.anchor is None or tr.armed is not None or tr.done
                or self._s.phase not in ("playing", "waiting")):
            return None
        clock_t, show_t = tr.anchor
        at = clock_t + (w.section.start - show_t)
        if not self.virtual and at - self.arm_margin > now:
            return at - self.arm_margin
        tr.armed = w.section
        self._performer(name).pause(at=at)
        return None

    def _loop(self) -> None:
        with self._cond:
            while not self._closed:
                now = self.clock.now()
                due: list[float] = []
                for name, tr in self._s.tracks.items():
                    when = self._arm(name, tr, now)
                    if when is not None:
                        due.append(when)
                w = self._s.wait
                if (self._s.phase == "waiting" and w is not None and w.section.wait is not None
                        and w.section.wait.timeout is not None and w.since is not None):
                    expiry = w.since + w.section.wait.timeout
                    if now >= expiry:
                        self._time_out(w)
                        continue
                    due.append(expiry)
                timeout = None if not due else max(0.0, min(due) - self.clock.now())
                self._cond.wait(timeout)


def _trigger(section: Section) -> str:
    return section.wait.trigger if section.wait is not None else ""
