"""Chasing timecode: the show follows an external clock (MTC from a DAW or QLab).

The robots never jump. The show runs on this host's clock, started where the timecode says;
the chaser only watches that the two agree and, when they stop agreeing, holds or stops the
show (the choice is the user's, ``policy``), then goes on with catch-up moves from where the
timecode has gone, as any seek does.

* **Lock.** Positions are taken as consistent while each one, less the clock time it arrived,
  stays within ``tolerance`` of the first: the timecode runs at real speed. After
  ``lock_count`` consistent positions (MTC: quarter frames, 8.3 ms apart at 30 fps) the chaser
  starts the show ``lead`` seconds later at the position the timecode will have then (the mean
  of the lock window, so one late byte does not offset the show).
* **Follow.** Each position is compared with where the show is. Within ``max_drift`` it goes
  on untouched (the drift is kept for the report).
* **Jump** (a position beyond ``max_drift``, or a full-frame locate): ``hold`` pauses every
  robot at once and locks again; on lock the show seeks to the new position and resumes.
  ``stop`` safe-stops the show.
* **Dropout** (no position for ``dropout`` seconds: the DAW stopped, a cable came out):
  ``hold`` pauses and waits for the timecode to come back (then as after a jump); ``stop``
  safe-stops.

``origin`` is the timecode of show time 0 (a DAW session often starts at 01:00:00:00).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, Protocol

__all__ = ["ChaseSettings", "Chaser", "Target"]

Policy = Literal["hold", "stop"]


class Target(Protocol):
    """What the chaser steers (a show runner, through a thin adapter)."""

    def start(self, offset: float, at: float) -> None:
        """Play from show time ``offset`` at clock time ``at``."""
        ...

    def pause(self, at: float) -> None: ...

    def resume(self, at: float) -> None: ...

    def seek(self, show_time: float, at: float) -> None: ...

    def stop(self, reason: str) -> None: ...


@dataclass(frozen=True)
class ChaseSettings:
    """How closely to follow; see the module text."""

    policy: Policy = "hold"
    origin: float = 0.0  # timecode (s) at show time 0
    lock_count: int = 8  # consistent positions before (re)starting: 2 frames of MTC
    tolerance: float = 0.012  # s: positions agree with the clock within this to lock
    max_drift: float = 0.067  # s (2 frames at 30 fps): beyond, a jump
    dropout: float = 0.2  # s without a position: a dropout
    lead: float = 0.1  # s from the lock to the robots moving


@dataclass
class ChaseLog:
    """What happened, for the report: (clock time, what) lines, lock times, drifts."""

    lines: list[tuple[float, str]] = field(default_factory=list)
    lock_times: list[float] = field(default_factory=list)  # s from first position to lock
    drifts: list[float] = field(default_factory=list)  # s, timecode - show, while following


class Chaser:
    """Feed it positions (:meth:`position`) and ticks (:meth:`tick`); it steers ``target``.

    ``duration``: the show's length (a timecode past it starts nothing). Thread-safe: an
    input thread feeds positions while a timer ticks.
    """

    def __init__(
        self,
        target: Target,
        settings: ChaseSettings,
        duration: float,
        *,
        now: Callable[[], float],
    ) -> None:
        self.target = target
        self.settings = settings
        self.duration = duration
        self._now = now
        self._lock = threading.Lock()
        self.state: Literal["waiting", "running", "held", "stopped", "ended"] = "waiting"
        self.log = ChaseLog()
        self._window: list[tuple[float, float]] = []  # (arrived, timecode) while locking
        self._base = 0.0  # while running: timecode - clock time
        self._last = float("-inf")  # clock time of the last position
        self._held_at: float | None = None  # show time where a hold paused the show
        self._started = False

    # ------------------------------------------------------------------ inputs

    def position(self, timecode: float, arrived: float, *, locate: bool = False) -> None:
        """A timecode position (seconds) that arrived at clock time ``arrived``;
        ``locate``: a full-frame jump (always re-locks)."""
        with self._lock:
            self._last = arrived
            if self.state in ("stopped", "ended"):
                return
            if self.state == "running":
                drift = timecode - (self._base + arrived)
                if abs(drift) <= self.settings.max_drift and not locate:
                    self.log.drifts.append(drift)
                    return
                if not self._lost(arrived, f"timecode jump of {drift:+.3f} s"):
                    return
            self._locking(timecode, arrived)

    def tick(self, now: float | None = None) -> None:
        """Check for a dropout; call a few times a second (a timer, the input loop)."""
        now = self._now() if now is None else now
        with self._lock:
            if self.state == "running" and now - self._last > self.settings.dropout:
                self._lost(now, f"no timecode for {now - self._last:.2f} s")
            elif self._window and now - self._window[-1][0] > self.settings.dropout:
                self._window = []  # a lock attempt that petered out

    def end(self) -> None:
        """The show is over: ignore timecode from now on."""
        with self._lock:
            self.state = "ended"

    # ------------------------------------------------------------------ internals

    def _note(self, at: float, what: str) -> None:
        self.log.lines.append((at, what))

    def _lost(self, at: float, why: str) -> bool:
        """Hold (True: lock again) or stop (False), as the policy says."""
        if self.settings.policy == "stop":
            self.state = "stopped"
            self._note(at, f"{why}: stop")
            self.target.stop(f"{why} (chase policy: stop)")
            return False
        self.state = "held"
        self._held_at = self._base + at - self.settings.origin
        self._window = []
        self._note(at, f"{why}: hold at show time {self._held_at:.3f} s")
        self.target.pause(at)
        return True

    def _locking(self, timecode: float, arrived: float) -> None:
        s = self.settings
        if self._window:
            first = self._window[0][1] - self._window[0][0]
            if abs((timecode - arrived) - first) > s.tolerance:
                self._window = []  # not running at real speed from the first: start over
        self._window.append((arrived, timecode))
        if len(self._window) < s.lock_count:
            return
        offsets = [tc - t for t, tc in self._window]
        base = sum(offsets) / len(offsets)
        self.log.lock_times.append(arrived - self._window[0][0])
        self._window = []
        at = arrived + s.lead
        show = base + at - s.origin
        if show < 0:  # timecode before the show's start: start when it gets there
            at, show = at - show, 0.0
        if show >= self.duration:
            self._note(arrived, f"timecode at show time {show:.3f} s is past the show's end")
            return
        self._base = base
        if not self._started:
            self._started = True
            self._note(arrived, f"locked: start at show time {show:.3f} s")
            self.target.start(show, at)
        else:
            # Wherever the timecode came back (the same place after a DAW's stop/play, or
            # elsewhere after a jump), the robots reach it with catch-up moves, then go on.
            self._note(arrived, f"locked again: go on from show time {show:.3f} s")
            self.target.seek(show, at)
            self.target.resume(at)
        self.state = "running"
        self._held_at = None
