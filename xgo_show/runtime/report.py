"""End-of-show report per performer, and the live progress line.

Send-time error is the actual send time minus the planned one, for scheduled frames only
(telemetry reads, catch-up and stop frames are counted separately).
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from typing import TextIO

from xgo_show.choreo.timebase import TempoMap
from xgo_show.runtime.events import Event, ProgressTick
from xgo_show.runtime.executor import SafeStopResult
from xgo_show.runtime.show_runner import ShowProgress, ShowResult
from xgo_show.runtime.stats import ErrorStats, SendStats, error_stats, percentile

__all__ = [
    "ErrorStats",
    "PerformerReport",
    "ProgressPrinter",
    "build_report",
    "error_stats",
    "format_report",
    "percentile",
]


@dataclass(frozen=True)
class PerformerReport:
    """What happened to one performer."""

    name: str
    model: str
    state: str
    frames_sent: int
    frames_total: int
    bytes_sent: int
    reads: int
    errors: ErrorStats
    telemetry: dict[str, float]
    ending: str
    fault: str | None

    def format(self) -> str:
        if self.model == "music":  # the soundtrack (xgo_show.audio.player): no frames to count
            return f"{self.name}: {self.state}; {self.ending}"
        lines = [
            f"{self.name} ({self.model}): {self.state}; "
            f"{self.frames_sent}/{self.frames_total} frames, {self.bytes_sent} bytes sent, "
            f"{self.reads} telemetry reads",
            f"  send-time error: {self.errors.format()}",
        ]
        if flag := self.errors.over_target():
            lines[-1] += f"  {flag}"
        if self.telemetry:
            tele = ", ".join(
                f"{_NAMES.get(k, k)} {_fmt(k, v)}" for k, v in sorted(self.telemetry.items())
            )
            lines.append(f"  telemetry: {tele}")
        if self.fault:
            lines.append(f"  fault: {self.fault}")
        lines.append(f"  end: {self.ending}")
        return "\n".join(lines)


# Telemetry names as the report prints them.
_NAMES = {"battery_v": "battery"}


def _fmt(name: str, value: float) -> str:
    if name == "battery":
        return f"{value:.0f}%"
    if name == "battery_v":  # the xArm reports volts
        return f"{value:.2f} V"
    if name.startswith("imu_"):
        return f"{value:.1f} deg"
    return f"{value:g}"


def _ending(stats: SendStats | None, stop: SafeStopResult | None) -> str:
    if stop is not None:
        did = ", ".join(stop.frames) if stop.frames else "nothing sent"
        status = "ok" if stop.ok else f"FAILED ({stop.error})"
        return f"safe stop ({stop.reason}) {status} in {stop.elapsed * 1000:.1f} ms: {did}"
    if stats is not None and stats.rests:
        # A pause rests the robot too: each distinct rest frame is named once, with how many
        # times the robot was rested.
        times = stats.rests
        how = {1: "rested", 2: "rested twice"}.get(times, f"rested {times} times")
        return f"show over; {how}: " + ", ".join(stats.rest_labels)
    return "show over"


def build_report(result: ShowResult) -> list[PerformerReport]:
    """One report per performer of a finished run."""
    out = []
    for name, perf in result.performers.items():
        stats = result.stats.get(name)
        progress = perf.progress
        stop = result.stops.get(name) or perf.stop_result
        out.append(
            PerformerReport(
                name=name,
                model=perf.model,
                state=perf.state.value,
                frames_sent=stats.frames if stats is not None else progress.sent,
                frames_total=progress.total,
                bytes_sent=stats.bytes if stats is not None else 0,
                reads=stats.reads if stats is not None else 0,
                errors=stats.errors.stats() if stats is not None else error_stats([]),
                telemetry=dict(perf.readings),
                ending=_ending(stats, stop),
                fault=perf.fault,
            )
        )
    return out


def format_report(result: ShowResult) -> str:
    """The whole end-of-show report as text."""
    head = "show completed" if result.completed else f"show stopped: {result.reason}"
    if result.stop_latency is not None:
        # The safety target: every robot stopped within 100 ms of the stop request (or fault).
        head += (f"; safe stop finished {result.stop_latency * 1000:.1f} ms after the "
                 "request (target 100 ms)")
    return "\n".join([head, *(r.format() for r in build_report(result))])


_WHERE = re.compile(r" at (?:line \d+|[^()]+:\d+)(?=\))")


class ProgressPrinter:
    """The live progress line: show time, bar:beat, cue and battery per performer.

    On a terminal the line is rewritten in place (call it ~4 times a second); otherwise a plain
    line is printed every ``plain_every`` seconds of show time.
    """

    def __init__(
        self,
        *,
        tempo: TempoMap | None = None,
        out: TextIO | None = None,
        tty: bool | None = None,
        plain_every: float = 2.0,
    ) -> None:
        self.tempo = tempo
        self.out = out or sys.stdout
        self.tty = self.out.isatty() if tty is None else tty
        self.plain_every = plain_every
        self._next_plain = 0.0
        self._width = 0

    def line(self, progress: ShowProgress) -> str:
        t = progress.show_time
        parts = [f"{t:6.1f}/{progress.duration:.1f}s"]
        if self.tempo is not None:
            # Through the tempo map: bars stay right across tempo and metre changes.
            bar, beat = self.tempo.bar_beat(t)
            parts.append(f"bar {bar}:{int(beat + 1e-9)}")
        for p in progress.performers:
            cue = p.cue.removeprefix(f"{p.performer}: ") if p.cue else "-"
            # "(phrase sway at show.yaml:275)" -> "(phrase sway)": the line stays readable.
            cue = _WHERE.sub("", cue)
            text = f"{p.performer}: {cue}"
            if p.state.value not in ("running",):
                text += f" [{p.state.value}]"
            tele = progress.telemetry.get(p.performer, {})
            battery, volts = tele.get("battery"), tele.get("battery_v")
            if battery is not None:
                text += f" (battery {battery:.0f}%)"
            elif volts is not None:
                text += f" (battery {volts:.2f} V)"
            parts.append(text)
        return " | ".join(parts)

    def on_event(self, event: Event) -> None:
        """Subscribe this to the runtime's bus: draws every :class:`ProgressTick`."""
        if isinstance(event, ProgressTick):
            self(event.progress)

    def __call__(self, progress: ShowProgress) -> None:
        text = self.line(progress)
        if self.tty:
            pad = max(0, self._width - len(text))
            self._width = len(text)
            self.out.write("\r" + text + " " * pad)
            self.out.flush()
        elif progress.show_time >= self._next_plain:
            self._next_plain = progress.show_time + self.plain_every
            print(text, file=self.out, flush=True)

    def finish(self) -> None:
        """End the in-place line (call once after the show)."""
        if self.tty and self._width:
            self.out.write("\n")
            self.out.flush()
