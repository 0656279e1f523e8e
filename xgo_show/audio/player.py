"""The soundtrack as a performer: music that keeps the show clock.

:class:`MusicPlayer` implements :class:`~xgo_show.runtime.performer.Performer`, so the show
runner starts, pauses, resumes, seeks and stops it at the same clock times as the robots
(``--start-bar``, Ctrl-Z, a seek all keep music and robots together).

How it keeps time. The device pulls a buffer every few milliseconds; each buffer will sound
``sink.latency`` seconds after the pull (the device buffer). The player renders every sample
for the clock time at which it will sound: the show time there (from the start, pauses and
seeks it was given, each at a clock time) plus the music's ``offset`` is the position in the
recording. Consecutive buffers continue sample by sample (see :meth:`MusicPlayer._place`),
re-anchored on the clock only when the device's queue drifts by more than ``RESYNC_S``, so
steady playback has no clicks and never drifts. The device's fixed output delay beyond one
buffer is not visible to any program: measure it once (a microphone and a click) and give it
as ``--latency music=MS``.
"""

from __future__ import annotations

import bisect
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from xgo_show.audio.decode import require
from xgo_show.runtime.clock import Clock
from xgo_show.runtime.events import EventBus, StateChanged
from xgo_show.runtime.executor import ExecutorState, Progress, SafeStopResult

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from xgo_show.audio.sink import AudioSink

__all__ = ["RESYNC_S", "Anchor", "MusicPlayer", "Tap"]

RESYNC_S = 0.015  # drift (s) of the device queue's mean depth that re-anchors on the clock

#: ``tap(sounds_at, block)``: a rendered buffer and the clock time its first sample sounds
Tap = Callable[[float, "npt.NDArray[np.float32]"], None]


@dataclass(frozen=True)
class Anchor:
    """From clock time ``at`` on, show time runs from ``show_time`` (or stands, paused)."""

    at: float
    show_time: float
    running: bool


class MusicPlayer:
    """Plays ``samples`` (frames x channels at the sink's rate) as show time goes.

    ``offset``: seconds into the recording at show time 0 (bar 1 beat 1); negative, the music
    starts that long after the show. ``until``: the show's end (show time); the part is over
    there. An output's own delay beyond the device buffer (a USB interface, a wireless
    speaker) is :class:`~xgo_show.runtime.latency.Early`'s job, as for any performer.
    """

    def __init__(
        self,
        samples: npt.NDArray[np.float32],
        sink: AudioSink,
        *,
        clock: Clock,
        events: EventBus,
        offset: float = 0.0,
        until: float,
        name: str = "music",
        label: str = "",
        tap: Tap | None = None,
    ) -> None:
        self._np = require("numpy")
        self._samples = samples
        self._sink = sink
        self._clock = clock
        self._events = events
        self._offset = offset
        self._until = until
        self._delay = sink.latency
        self._name = name
        self._label = label or name
        self._tap = tap
        self._lock = threading.Lock()
        self._anchors: list[Anchor] = []
        self._state = ExecutorState.IDLE
        self._fault: str | None = None
        self._stop: SafeStopResult | None = None
        self._next_at: float | None = None  # where the previous buffer ends (clock time)
        self._depth: float | None = None  # how far ahead of the clock buffers sound, steadily
        self._prev_call = 0.0
        self._mean = 0.0  # the depth, averaged
        self._wake = threading.Event()
        self._ended = threading.Event()
        self._watcher: threading.Thread | None = None

    # ------------------------------------------------------------------ identity / status

    @property
    def name(self) -> str:
        return self._name

    @property
    def model(self) -> str:
        return "music"

    @property
    def state(self) -> ExecutorState:
        return self._state

    @property
    def done(self) -> bool:
        return self._state.ended

    @property
    def fault(self) -> str | None:
        return self._fault

    @property
    def stop_result(self) -> SafeStopResult | None:
        return self._stop

    @property
    def readings(self) -> Mapping[str, float]:
        return {}

    @property
    def progress(self) -> Progress:
        show = self.show_time(self._clock.now())
        at = max(0.0, show + self._offset)
        where = f"{int(at // 60)}:{at % 60:04.1f} of {self._label}"
        return Progress(self._name, self._state, show, 0, 0, where, where)

    # ------------------------------------------------------------------ timeline

    def show_time(self, at: float) -> float:
        """The show time at clock time ``at`` on this player's timeline (before the start:
        the start offset)."""
        with self._lock:
            anchors = list(self._anchors)
        i = bisect.bisect_right([a.at for a in anchors], at) - 1
        if i < 0:
            return anchors[0].show_time if anchors else 0.0
        a = anchors[i]
        return a.show_time + (at - a.at if a.running else 0.0)

    def _add(self, at: float | None, show_time: float | None, running: bool) -> None:
        when = self._clock.now() if at is None else at
        now_show = self.show_time(when)
        with self._lock:
            # A later command replaces anything planned after it.
            self._anchors = [a for a in self._anchors if a.at < when]
            self._anchors.append(Anchor(when, now_show if show_time is None else show_time,
                                        running))
        self._wake.set()

    def _running_at(self, at: float) -> bool:
        with self._lock:
            anchors = list(self._anchors)
        i = bisect.bisect_right([a.at for a in anchors], at) - 1
        return i >= 0 and anchors[i].running

    # ------------------------------------------------------------------ Performer

    def lead_time(self, offset: float) -> float:
        """The first buffer must be rendered one output delay before it sounds."""
        return self._delay + 0.02

    def start(self, start_at: float, *, offset: float = 0.0) -> None:
        """Play from clock time ``start_at``, show time ``offset`` then."""
        with self._lock:
            self._anchors = [Anchor(start_at, offset, True)]
        self._set_state(ExecutorState.RUNNING, offset)
        self._sink.start(self._render)
        self._watcher = threading.Thread(target=self._watch, name=f"{self._name}-end",
                                         daemon=True)
        self._watcher.start()

    def pause(self, *, at: float | None = None) -> None:
        """Silence from clock time ``at``; the music stands where it was."""
        self._add(at, None, False)
        self._set_state(ExecutorState.PAUSED, self.show_time(self._clock.now()))

    def resume(self, *, at: float | None = None) -> None:
        """Go on from where the pause left the music, from clock time ``at``."""
        self._add(at, None, True)
        self._set_state(ExecutorState.RUNNING, self.show_time(self._clock.now()))

    def seek(self, show_time: float, *, at: float | None = None) -> None:
        """Jump to ``show_time`` at clock time ``at`` (while paused: stay paused there)."""
        when = self._clock.now() if at is None else at
        self._add(when, show_time, self._running_at(when))

    def abort(self) -> None:
        """Silence now."""
        self._finish(ExecutorState.STOPPED)

    def safe_stop(self, reason: str, *, timeout: float = 0.1) -> SafeStopResult:
        """Silence now (the next buffer is silent); idempotent."""
        started = self._clock.now()
        self._finish(ExecutorState.STOPPED)
        if self._stop is None:
            self._stop = SafeStopResult(self._name, reason, True, ("silence",),
                                        elapsed=self._clock.now() - started)
        return self._stop

    def join(self, timeout: float | None = None) -> bool:
        return self._ended.wait(timeout) or self.done

    def close(self) -> None:
        self._finish(ExecutorState.STOPPED)
        self._sink.close()
        if self._watcher is not None:
            self._watcher.join(1.0)

    # ------------------------------------------------------------------ internals

    def _set_state(self, state: ExecutorState, show_time: float) -> None:
        if self.done:
            return
        self._state = state
        self._events.publish(StateChanged(self._clock.now(), self._name, state, show_time))

    def _finish(self, state: ExecutorState) -> None:
        with self._lock:
            self._anchors = []  # silent from the next buffer on
        if not self.done:
            self._state = state
            self._events.publish(StateChanged(self._clock.now(), self._name, state, 0.0))
        self._ended.set()
        self._wake.set()

    def _watch(self) -> None:
        """Finish when the show time reaches ``until`` (re-planned on every pause/seek)."""
        while not self.done:
            self._wake.clear()
            now = self._clock.now()
            show = self.show_time(now)
            if show >= self._until and self._running_at(now):
                self._set_state(ExecutorState.FINISHED, show)
                self._ended.set()
                return
            wait = self._until - show if self._running_at(now) else 0.25
            self._clock.sleep_until(now + max(0.001, min(wait, 0.25)), self._wake)

    def _place(self, now: float, period: float) -> float:
        """When the buffer asked for at ``now`` will sound.

        Buffers queue behind each other, so each sounds where the previous one ends (frame
        counting, immune to callback jitter). At the start the device asks for several buffers
        at once to fill its queue; the first callback at least half a period after the previous
        one ends that, and how far ahead of the clock it sounds is the queue's depth. From then
        on the buffer re-anchors on the clock when the queue ran dry (an underrun: the buffer
        would sound before it is made) or when its depth, averaged over about half a second,
        drifts more than ``RESYNC_S`` (a device crystal fast or slow against the clock). One
        late callback (the machine busy) changes neither: its buffer still plays in turn.
        """
        if self._next_at is None:
            self._prev_call = now
            return now + self._delay
        at = self._next_at
        ahead = at - now
        if self._depth is None:
            if now - self._prev_call >= period / 2:
                self._depth = self._mean = ahead
        else:
            self._mean += (ahead - self._mean) / 25
            if ahead <= 0 or abs(self._mean - self._depth) > RESYNC_S:
                at = now + self._depth
                self._mean = self._depth
        self._prev_call = now
        return at

    def _render(self, frames: int) -> npt.NDArray[np.float32]:
        """The next ``frames`` frames of sound (called on the device's thread)."""
        xp = self._np
        rate = self._sink.rate
        now = self._clock.now()
        sounds_at = self._place(now, frames / rate)
        self._next_at = sounds_at + frames / rate
        out = xp.zeros((frames, self._sink.channels), dtype=xp.float32)
        with self._lock:
            anchors = list(self._anchors)
        if anchors and not self.done:
            times = sounds_at + xp.arange(frames) / rate
            starts = xp.array([a.at for a in anchors])
            which = xp.searchsorted(starts, times, side="right") - 1
            valid = which >= 0
            idx = xp.where(valid, which, 0)
            base = xp.array([a.show_time for a in anchors])[idx]
            run = xp.array([a.running for a in anchors])[idx] & valid
            show = base + xp.where(run, times - starts[idx], 0.0)
            pos = xp.round((show + self._offset) * rate).astype(xp.int64)
            play = run & (pos >= 0) & (pos < len(self._samples)) & (show < self._until)
            out[play] = self._samples[pos[play]]
        if self._tap is not None:
            self._tap(sounds_at, out)
        result: npt.NDArray[np.float32] = out
        return result


def music_performer(
    samples: Any, sink: AudioSink, **kwargs: Any
) -> Callable[[Any], dict[str, MusicPlayer]]:
    """A factory for :class:`~xgo_show.runtime.launch.Launch`: given the launch's context
    (clock, event bus), the music player as a performer named ``music``."""

    def build(ctx: Any) -> dict[str, MusicPlayer]:
        player = MusicPlayer(samples, sink, clock=ctx.clock, events=ctx.events, **kwargs)
        return {player.name: player}

    return build
