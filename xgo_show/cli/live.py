"""The live view of a running show on a terminal: one row per performer, sized to the width.

Each row shows the performer's state, how far its part has got, the cue *in effect* at the
current show time (the action running, the move under way, read from the schedule, not the
last frame sent) and its battery. Drawn with rich, redrawn a few times a second; the last
drawing is the final state (every performer's last state, the show's end). When stdout is not a
terminal the plain progress lines are printed instead (:class:`ProgressPrinter`).
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass
from typing import Any, TextIO

from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.runtime.events import Event, ProgressTick
from xgo_show.runtime.show_runner import ShowProgress

__all__ = ["CueTimeline", "LiveView"]

_WHERE = re.compile(r" at (?:line \d+|[^()]+:\d+)(?=\))")


@dataclass(frozen=True)
class _Span:
    start: float
    end: float
    cue: str


class CueTimeline:
    """Which cue is in effect when, for one performer: consecutive frames from the same cue
    make one span, from its first frame to its last (plus that frame's own duration, e.g. a
    preset action's run time)."""

    def __init__(self, performer: PerformerSchedule, step: float) -> None:
        spans: list[_Span] = []
        for f in performer.frames:
            cue = f.origin.cue if f.origin is not None and f.origin.cue else f.label
            cue = _WHERE.sub("", cue.removeprefix(f"{performer.name}: "))
            end = f.t + max(f.duration, step)
            if spans and spans[-1].cue == cue and f.t <= spans[-1].end + step:
                spans[-1] = _Span(spans[-1].start, max(spans[-1].end, end), cue)
            else:
                spans.append(_Span(f.t, end, cue))
        self._spans = spans
        self._starts = [s.start for s in spans]

    def at(self, t: float) -> str:
        """The cue in effect at show time ``t``, or "" between cues."""
        i = bisect.bisect_right(self._starts, t) - 1
        if i < 0:
            return ""
        span = self._spans[i]
        return span.cue if t < span.end else ""


class LiveView:
    """Subscribe :meth:`on_event` to the run's bus; call :meth:`finish` after the run."""

    def __init__(self, schedule: Schedule, out: TextIO) -> None:
        from rich.console import Console
        from rich.live import Live

        self.schedule = schedule
        self.tempo = schedule.tempo()
        step = 1.0 / schedule.control_rate if schedule.control_rate else 0.02
        self.timelines = {p.name: CueTimeline(p, step) for p in schedule.performers}
        self.console = Console(file=out, highlight=False)
        self._live = Live(console=self.console, auto_refresh=False, transient=False)
        self._last: ShowProgress | None = None
        self._started = False

    def table(self, progress: ShowProgress, *, final: bool = False) -> Any:
        """The view of ``progress``: a header line and one row per performer."""
        from rich.console import Group
        from rich.progress_bar import ProgressBar
        from rich.table import Table
        from rich.text import Text

        t = min(progress.show_time, progress.duration) if not final else progress.duration
        head = f"{t:6.1f} / {progress.duration:.1f} s"
        if self.tempo is not None:
            bar, beat = self.tempo.bar_beat(t)
            head += f"   bar {bar}:{int(beat + 1e-9)}"
        table = Table(expand=True, box=None, pad_edge=False, show_edge=False)
        table.add_column("performer", no_wrap=True, overflow="ellipsis", max_width=14)
        table.add_column("state", no_wrap=True, width=9)
        table.add_column("", no_wrap=True, ratio=1, min_width=6)
        table.add_column("cue in effect", no_wrap=True, overflow="ellipsis", ratio=3)
        table.add_column("battery", no_wrap=True, justify="right", width=7)
        for p in progress.performers:
            timeline = self.timelines.get(p.performer)
            if timeline is not None:
                cue = timeline.at(t) or ("-" if not final else "(at rest)")
            else:  # the soundtrack, or any performer without a schedule of frames
                cue = p.cue
            tele = progress.telemetry.get(p.performer, {})
            battery = tele.get("battery")
            volts = tele.get("battery_v")
            power = (f"{battery:.0f}%" if battery is not None
                     else f"{volts:.2f} V" if volts is not None else "")
            share = t / progress.duration if progress.duration else 1.0
            table.add_row(
                Text(p.performer),
                Text(p.state.value, style="bold red" if p.state.value in ("failed", "stopped")
                     else ""),
                ProgressBar(total=1.0, completed=min(1.0, max(0.0, share))),
                Text(cue),
                Text(power),
            )
        return Group(Text(head, style="bold"), table)

    def on_event(self, event: Event) -> None:
        """Draws every :class:`ProgressTick`."""
        if isinstance(event, ProgressTick):
            self._last = event.progress
            if not self._started:
                self._live.start()
                self._started = True
            self._live.update(self.table(event.progress), refresh=True)

    def finish(self, final: ShowProgress | None = None, *, completed: bool = True) -> None:
        """Draw the final state (``final``: the runner's last snapshot) and stop drawing."""
        last = final or self._last
        if last is not None:
            if not self._started:
                self._live.start()
                self._started = True
            self._live.update(self.table(last, final=completed), refresh=True)
        if self._started:
            self._live.stop()
